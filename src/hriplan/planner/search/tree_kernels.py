"""The compiled search's nearest node, pruned by the bounding boxes of runs of nodes.

Why: the compiled CBiRRT (`loop_kernels.search`) asks each tree for the node nearest a target
twice an iteration; a scan of every node (`band_kernels.nearest`) cost ~30 ms of a ~180 ms
MADAR peg-in-hole plan (~5 M nodes scanned a plan at ~5 ns, bound by memory). Nodes join a tree
in chains of short steps, so each run of BLOCK consecutive nodes lies in a small box: a run whose
box is no nearer the target than the nearest node found so far cannot hold a nearer node and is
skipped (about half of them, ~45 % less time).

The answer is the full scan's, to the bit: a node's squared distance is summed in the same
order, and each box's bound is a sum in that order of squares no larger than the node's
(rounding is monotone), so a skipped run holds no node the scan would have taken (it takes a
node only when strictly nearer than the best so far: the first of equals).
"""

from __future__ import annotations

import math

import numpy as np

from hriplan.robots.kernel_cache import njit_keyed

BLOCK = 8  # nodes a box holds: 4 and 16 scanned ~10-35 % slower on the peg-in-hole's trees

_keyed = njit_keyed()


@_keyed
def boxes_room(low, high, count):
    """The boxes' arrays (low, high) with room for the boxes of `count` nodes (doubled as
    often as needed, the boxes so far kept)."""
    size = low.shape[0]
    need = (count + BLOCK - 1) // BLOCK
    if need <= size:
        return low, high
    while need > size:
        size *= 2
    grown_low, grown_high = np.empty((size, low.shape[1])), np.empty((size, low.shape[1]))
    grown_low[: low.shape[0]] = low
    grown_high[: high.shape[0]] = high
    return grown_low, grown_high


@_keyed
def boxed(nodes, first, count, low, high) -> None:
    """Widen the boxes by nodes[first:count] (the nodes before `first` in them already): box b
    holds nodes b*BLOCK to (b+1)*BLOCK - 1."""
    for i in range(first, count):
        b = i // BLOCK
        if i % BLOCK == 0:
            for c in range(nodes.shape[1]):
                low[b, c] = nodes[i, c]
                high[b, c] = nodes[i, c]
        else:
            for c in range(nodes.shape[1]):
                low[b, c] = min(low[b, c], nodes[i, c])
                high[b, c] = max(high[b, c], nodes[i, c])


@_keyed
def nearest_boxed(nodes, count, x, low, high) -> int:
    """The index of the node among nodes[:count] nearest `x` (the first of equals), as
    `band_kernels.nearest`, skipping the runs whose box (`boxed`) is no nearer than the best."""
    best, index = math.inf, 0
    n = x.shape[0]
    for b in range((count + BLOCK - 1) // BLOCK):
        bound = 0.0
        for c in range(n):
            gap = max(low[b, c] - x[c], x[c] - high[b, c], 0.0)
            bound += gap**2
        if bound >= best:
            continue
        for i in range(b * BLOCK, min(count, (b + 1) * BLOCK)):
            d = 0.0
            for c in range(n):
                d += (nodes[i, c] - x[c]) ** 2
            if d < best:
                best, index = d, i
    return index
