"""numpy's pairwise summation compiled (robots/pairwise_sums.py) against numpy's own sums."""

import numpy as np
import pytest

pytest.importorskip("numba")

from hriplan.robots.pairwise_sums import pairwise_sum


def test_sums_are_numpys_to_the_bit(rng):
    """Slices of 0 to 3000 terms of any magnitude and sign: numpy's blocks and halves, the bits
    compared (so a -0.0 is not taken for a 0.0)."""
    for k in range(2000):
        n = int(rng.integers(0, 3000 if k % 2 else 300))
        a = rng.normal(size=n + 9) * 10.0 ** rng.uniform(-3, 3, n + 9)
        first = int(rng.integers(0, 9))
        assert np.float64(pairwise_sum(a, first, n)).tobytes() == a[first : first + n].sum().tobytes()


@pytest.mark.parametrize("n", [0, 1, 3, 7, 8, 9, 130])
def test_zeros_of_either_sign_sum_as_numpys(n):
    """The signs of zero sums: the reduction's start, 0.0, added last (a sum of -0.0s is 0.0)."""
    for a in (np.full(n, -0.0), np.zeros(n), np.where(np.arange(n) % 2, 0.0, -0.0)):
        assert np.float64(pairwise_sum(a, 0, n)).tobytes() == a.sum().tobytes()
