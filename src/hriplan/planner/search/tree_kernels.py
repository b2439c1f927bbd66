"""The compiled search's nearest node, pruned by the bounding boxes of runs of nodes.

Why: the compiled CBiRRT (`loop_kernels.search`) asks each tree for the node nearest a target
twice an iteration; a scan of every node (`band_kernels.nearest`) cost ~30 ms of a ~180 ms
MADAR peg-in-hole plan (~5 M nodes scanned a plan at ~5 ns, bound by memory). Nodes join a tree
in chains of short steps, so each run of BLOCK consecutive nodes lies in a small box: a run whose
box is no nearer the target than the nearest node found so far cannot hold a nearer node and is
skipped (~80 % of them: ~9.5 ms a plan instead of ~30).

The answer is the full scan's, to the bit: a node's squared distance is summed in the same
order, and each box's bound is a sum in that order of squares no larger than the node's
(rounding is monotone), so a skipped run holds no node the scan would have taken (it takes a
node only when strictly nearer than the best so far: the first of equals).
"""

from __future__ import annotations

import math

import numpy as np

from hriplan.robots.kernel_cache import njit_keyed

BLOCK = 4  # nodes a box holds: 2, 3, 6 and 8 scanned ~5-40 % slower on the peg-in-hole's trees

_keyed = njit_keyed()


@_keyed
def boxes_room(low, high, count):
    """The boxes' arrays (low, high: (dims, boxes), a coordinate's bounds of every box in a row,
    so that the bounds are summed a coordinate at a time over many boxes at once) with room
    for the boxes of `count` nodes (doubled as often as needed, the boxes so far kept)."""
    size = low.shape[1]
    need = (count + BLOCK - 1) // BLOCK
    if need <= size:
        return low, high
    while need > size:
        size *= 2
    grown_low, grown_high = np.empty((low.shape[0], size)), np.empty((high.shape[0], size))
    grown_low[:, : low.shape[1]] = low
    grown_high[:, : high.shape[1]] = high
    return grown_low, grown_high


@_keyed
def boxed(nodes, first, count, low, high) -> None:
    """Widen the boxes by nodes[first:count] (the nodes before `first` in them already): box b
    holds nodes b*BLOCK to (b+1)*BLOCK - 1."""
    for i in range(first, count):
        b = i // BLOCK
        if i % BLOCK == 0:
            for c in range(nodes.shape[1]):
                low[c, b] = nodes[i, c]
                high[c, b] = nodes[i, c]
        else:
            for c in range(nodes.shape[1]):
                low[c, b] = min(low[c, b], nodes[i, c])
                high[c, b] = max(high[c, b], nodes[i, c])


@_keyed
def nearest_boxed(nodes, count, x, low, high) -> int:
    """The index of the node among nodes[:count] nearest `x` (the first of equals), as
    `band_kernels.nearest`, skipping the runs whose box (`boxed`) is no nearer than the best."""
    n, boxes = x.shape[0], (count + BLOCK - 1) // BLOCK
    bounds = np.zeros(boxes)
    for c in range(n):  # every box's bound, a coordinate at a time (the compiler vectorises it)
        xc, below, above = x[c], low[c], high[c]
        for b in range(boxes):
            gap = max(below[b] - xc, xc - above[b], 0.0)
            bounds[b] += gap**2
    best, index = math.inf, 0
    for b in range(boxes):
        if bounds[b] >= best:
            continue
        for i in range(b * BLOCK, min(count, (b + 1) * BLOCK)):
            d = 0.0
            for c in range(n):
                d += (nodes[i, c] - x[c]) ** 2
            if d < best:
                best, index = d, i
    return index
