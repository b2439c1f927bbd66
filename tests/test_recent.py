"""The last few things made, kept by key (hriplan/recent.py)."""

from hriplan.recent import MadeFor, Recent


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


class _Model:
    """A stand-in for an object kept by identity (a pinocchio model): equal to any other."""

    def __eq__(self, other: object) -> bool:
        return True

    __hash__ = object.__hash__


def test_made_for_finds_a_value_by_its_objects_identity_and_its_extra_key():
    made: MadeFor[list] = MadeFor(2)
    a, b = _Model(), _Model()
    calls = []

    def make(tag):
        calls.append(tag)
        return [tag]

    first = made.made((a,), lambda: make("a"), extra=1)
    assert made.made((a,), lambda: make("again"), extra=1) is first  # the same object: found
    assert made.made((b,), lambda: make("b"), extra=1) == ["b"]  # equal, not the same: made anew
    assert made.made((a,), lambda: make("a2"), extra=2) == ["a2"]  # another extra key: made anew
    assert calls == ["a", "b", "a2"]
    assert made.get((a,), 1) is None  # three made, two kept: the least recent forgotten
    made.put((a,), ["put"], 1)
    assert made.get((a,), 1) == ["put"] and made.get((b,), 1) is None
