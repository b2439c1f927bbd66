"""Dense validation's densify against the segments split one at a time (tests/independent.py)."""

import numpy as np

from hriplan.planner.validate import densify
from independent import densified


def test_densify_is_the_segments_one_at_a_time(rng):
    """Bit for bit, whatever the segment lengths (repeated rows, one row, long and short)."""
    for _ in range(300):
        rows = rng.normal(0.0, rng.choice([1e-3, 0.05, 1.0]), (rng.integers(1, 7), rng.integers(1, 8)))
        if len(rows) > 2:
            rows[2] = rows[1]
        step = float(rng.choice([0.003, 0.01, 0.05]))
        assert np.array_equal(densify(list(rows), step), densified(rows, step))
    assert densify([np.zeros(3)], 0.01).shape == (1, 3)
