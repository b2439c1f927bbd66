"""Compiled building of the trees over a mesh's triangles: the box tree a mesh pair is decided
on (`mesh_pairs.MeshTree`) and the capsule tree the certifier passes a mesh's pieces by
(`free_certifier._mesh_pieces`). The box trees are the numpy code's to the bit; so are the
capsule trees of the MADAR, UR5, UR10, Panda and Talos meshes, while a few nodes of Baxter's and
TIAGo's differ by up to ~3e-9 m (numba's SVD, not numpy's, on nearly flat groups). Either way a
capsule's radius is measured from the points it must hold, so it holds them.

Why: MADAR's peg-in-hole first plan built them in Python, a node at a time: ~74 ms for the box
trees, ~75 ms for the capsule trees (an SVD and a dozen numpy calls a node); compiled, ~10-20 ms
each. A process pays them once per mesh (both are kept), in its first plan of that robot.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from hriplan.robots.mesh_pair_kernels import COUNT, FIRST, LEFT, RIGHT

LEAF = 1  # triangles a leaf holds at most (see MeshTree)


@njit(cache=True, nogil=True)
def split(centres: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The triangles' leaf order and the tree's nodes (N, 4: rows of `mesh_pair_kernels`), from
    their centres (T, 3): each node's triangles sorted (stably) by their centres along the axis
    they spread most on (the first of equal spreads) and halved, the left half the smaller; nodes
    numbered level by level, the root first, a node's children left then right."""
    count = centres.shape[0]
    order = np.arange(count)
    nodes = np.full((max(2 * count - 1, 1), 4), -1, dtype=np.int64)
    nodes[0, FIRST], nodes[0, COUNT] = 0, count
    made = 1
    level, after = np.empty(count, dtype=np.int64), np.empty(count, dtype=np.int64)
    values, members = np.empty(count), np.empty(count, dtype=np.int64)
    waiting = 0
    if count > LEAF:
        level[0], waiting = 0, 1
    while waiting:
        following = 0
        for i in range(waiting):
            n = level[i]
            first, size = nodes[n, FIRST], nodes[n, COUNT]
            _halve(centres, order, first, size, members, values)
            half = size // 2
            for start, length, side in ((first, half, LEFT), (first + half, size - half, RIGHT)):
                nodes[n, side] = made
                nodes[made, FIRST], nodes[made, COUNT] = start, length
                if length > LEAF:
                    after[following] = made
                    following += 1
                made += 1
        level, after, waiting = after, level, following
    return order, nodes[:made]


@njit(cache=True, nogil=True)
def capsule_tree(vertices: np.ndarray, triangles: np.ndarray, leaf: int) -> tuple[np.ndarray, np.ndarray]:
    """`free_certifier._mesh_pieces`' tree of capsules over a mesh's triangles (T, 3: indices
    into `vertices` (V, 3)): rows (m, 7) in depth-first order and where each node's subtree
    ends. A node's triangles are sorted (stably) by their centres along the axis they spread
    most on (the first of equal spreads) and halved, the first half the smaller, down to `leaf`
    triangles; its capsule holds their corners (`capsule_about`)."""
    count = triangles.shape[0]
    order = np.arange(count)
    total = _subtree_size(count, leaf)
    capsules, ends = np.empty((total, 7)), np.empty(total, dtype=np.int64)
    stack = np.empty((128, 2), dtype=np.int64)  # (first, size) waiting: a few levels per halving
    stack[0, 0], stack[0, 1], waiting, made = 0, count, 1, 0
    values, members = np.empty(count), np.empty(count, dtype=np.int64)
    centres = np.empty((count, 3))
    for t in range(count):
        for a in range(3):
            centres[t, a] = (
                vertices[triangles[t, 0], a] + vertices[triangles[t, 1], a] + vertices[triangles[t, 2], a]
            ) / 3.0
    while waiting:
        waiting -= 1
        first, size = stack[waiting, 0], stack[waiting, 1]
        group = order[first : first + size]
        capsules[made] = capsule_about(vertices[np.unique(triangles[group].ravel())])
        ends[made] = made + _subtree_size(size, leaf)
        made += 1
        if size <= leaf:
            continue
        _halve(centres, order, first, size, members, values)
        half = size // 2
        stack[waiting, 0], stack[waiting, 1] = first + half, size - half  # the second half after the first's subtree
        stack[waiting + 1, 0], stack[waiting + 1, 1] = first, half
        waiting += 2
    return capsules, ends


@njit(cache=True, nogil=True, inline="always")
def _halve(centres, order, first, size, members, values) -> None:
    """The node order[first : first + size] sorted (stably) by its triangles' centres along the
    axis they spread most on, the first of equal spreads: its halves are its children
    (`members` and `values`: scratch of at least `size`)."""
    axis, widest = 0, -1.0
    for a in range(3):
        low = high = centres[order[first], a]
        for p in range(first + 1, first + size):
            low, high = min(low, centres[order[p], a]), max(high, centres[order[p], a])
        if high - low > widest:
            axis, widest = a, high - low
    for p in range(size):
        members[p] = order[first + p]
        values[p] = centres[members[p], axis]
    ranked = np.argsort(values[:size], kind="mergesort")
    for p in range(size):
        order[first + p] = members[ranked[p]]


@njit(cache=True, nogil=True)
def _subtree_size(size: int, leaf: int) -> int:
    """Nodes of the tree over `size` triangles halved down to `leaf`."""
    if size <= leaf:
        return 1
    return 1 + _subtree_size(size // 2, leaf) + _subtree_size(size - size // 2, leaf)


@njit(cache=True, nogil=True)
def capsule_about(points: np.ndarray) -> np.ndarray:
    """A capsule (ends, radius: 7) holding `points` (k, 3): along their principal axis through
    their mean, radius their farthest from that axis, its ends drawn in as far as every point
    allows (a sphere where they meet). The radius is then the farthest point's distance from
    the segment itself, a hair more for rounding: it holds them whatever the fit did."""
    k = points.shape[0]
    centre = np.zeros(3)
    for p in range(k):
        centre += points[p]
    centre /= k
    axis = np.ascontiguousarray(np.linalg.svd(points - centre, full_matrices=False)[2][0])
    offsets = points - centre
    along = offsets @ axis
    across = np.sqrt(((offsets - np.outer(along, axis)) ** 2).sum(axis=1))
    slack = np.sqrt(np.maximum(across.max() ** 2 - across**2, 0.0))
    low, high = (along + slack).min(), (along - slack).max()
    if low > high:
        low = high = (low + high) / 2.0
    start, end = centre + low * axis, centre + high * axis
    span = end - start
    t = np.minimum(np.maximum((points - start) @ span / max(span @ span, 1e-300), 0.0), 1.0)
    reach = np.sqrt(((points - start - np.outer(t, span)) ** 2).sum(axis=1)).max()
    out = np.empty(7)
    out[:3], out[3:6], out[6] = start, end, reach * (1.0 + 1e-9) + 1e-9
    return out
