"""The last few things made, kept by key (hriplan/recent.py)."""

from hriplan.recent import Recent


def test_the_least_recently_used_is_forgotten_first():
    kept = Recent(2)
    kept.put("a", 1)
    kept.put("b", 2)
    assert kept.get("a") == 1  # a use makes "a" the most recent
    kept.put("c", 3)
    assert kept.get("b") is None and kept.get("a") == 1 and kept.get("c") == 3
    kept.put("a", 4)  # put again: replaced, not doubled
    assert len(kept) == 2 and kept.get("a") == 4
    kept.clear()
    assert len(kept) == 0 and kept.get("a") is None
