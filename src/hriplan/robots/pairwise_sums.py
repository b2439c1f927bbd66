"""numpy's sum of a 1-D float array, compiled (numba), to the bit: for the kernels whose results
must equal the numpy code they replace (CBiRRT's path lengths in `loop_kernels`, the row norms
of the path TOPP-RA retimes in `path_kernels`).

numpy adds a contiguous run pairwise (its `pairwise_sum`): up to 128 terms in one block, in
turn below 8 terms, else in eight running sums combined as a tree and the rest in turn; a longer
run is halved at a multiple of 8 and the halves' sums added; the reduction then adds that to its
start, 0.0 (so a sum of -0.0s is 0.0, as numpy 2.4 gives; whether a block of under 8 terms starts
from 0.0 or numpy's -0.0 then makes no difference). numpy recurses; here
a stack of frames does, as numba's disk-cached code crashes on recursion. Numba is imported only with the kernels on (their modules import this one).
"""

from __future__ import annotations

import numpy as np

from hriplan.robots.kernel_cache import njit_keyed

_keyed = njit_keyed()


@_keyed
def _block_sum(a, first, n) -> float:
    """numpy's sum of a[first : first + n], n <= 128."""
    if n < 8:
        s = 0.0
        for i in range(n):
            s += a[first + i]
        return s
    r0, r1, r2, r3 = a[first], a[first + 1], a[first + 2], a[first + 3]
    r4, r5, r6, r7 = a[first + 4], a[first + 5], a[first + 6], a[first + 7]
    i = 8
    while i < n - n % 8:
        k = first + i
        r0, r1, r2, r3 = r0 + a[k], r1 + a[k + 1], r2 + a[k + 2], r3 + a[k + 3]
        r4, r5, r6, r7 = r4 + a[k + 4], r5 + a[k + 5], r6 + a[k + 6], r7 + a[k + 7]
        i += 8
    s = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        s += a[first + i]
        i += 1
    return s


@_keyed
def pairwise_sum(a, first, n) -> float:
    """numpy's sum of a[first : first + n] (1-D, contiguous), `a[first : first + n].sum()`: a
    stack of frames (start, size, phase, the left half's sum) in place of numpy's recursion."""
    starts, sizes = np.empty(64, dtype=np.int64), np.empty(64, dtype=np.int64)
    phases, lefts = np.zeros(64, dtype=np.int64), np.empty(64)
    top, result = 0, 0.0
    starts[0], sizes[0] = first, n
    while top >= 0:
        start, size = starts[top], sizes[top]
        if size <= 128:
            result = _block_sum(a, start, size)
            top -= 1
            continue
        half = size // 2
        half -= half % 8
        if phases[top] == 0:  # sum the left half first
            phases[top] = 1
            top += 1
            starts[top], sizes[top], phases[top] = start, half, 0
        elif phases[top] == 1:  # the left half's sum is back: the right half
            lefts[top], phases[top] = result, 2
            top += 1
            starts[top], sizes[top], phases[top] = start + half, size - half, 0
        else:
            result = lefts[top] + result
            top -= 1
    return 0.0 + result
