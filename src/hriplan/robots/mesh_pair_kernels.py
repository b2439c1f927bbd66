"""Compiled decision of one mesh pair (numba): do two placed triangle meshes touch, proven
either way by their triangles, or left to coal.

Why: a pair of a clearance table (`mesh_clearance.py`) that its table does not certify at a
state is asked of coal, whose mesh-mesh `collide` tests every triangle pair its bounding
volumes do not part with GJK: ~74 us a free state, ~18 us a colliding one (MADAR's forearm and
wrist 2 near contact: most of a constrained plan's collision time). Here each mesh has an
axis-aligned box tree over its triangles, in its own frame (`mesh_pairs.py` builds it), and the
trees are walked together: two nodes whose boxes (one turned by the relative placement) the
15-axis box test parts by more than the margin are not descended (only the 6 face axes made
the walk ~15 % slower: more node pairs). Each triangle pair left is, after a test of their
bounding boxes:
- apart, when one of the 11 separating-axis candidates (either normal, the 9 edge crosses)
  parts their projections by more than the margin times the axis's length: then they are
  farther apart than the margin, and GJK (tolerance ~1e-6 m) finds them apart;
- touching, when an edge of one pierces the other robustly: its ends more than the margin on
  either side of the other's plane, and the point where it crosses the plane inside each edge
  of the other by more than the margin times (1 + 1 / the sine of the edge's angle to the
  plane). Moving either triangle by less than the margin keeps the edge piercing, so they
  overlap by more than the margin and GJK (with EPA) finds them touching;
- else undecided.
A pair touching proves a collision (coal tests every pair its volumes do not part, and a
touching pair's volumes overlap); every pair apart proves the meshes free; else coal decides.
The last 16 touching pairs found are tried first, the latest first (a search's colliding states
touch in a few places: on the peg-in-hole's, one of them proves 98 % of its colliding states,
the last one alone 12 %). Rounding errs by ~1e-15 m on metre-sized links, far below the margin.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

FREE, TOUCHING, UNDECIDED = 0, 1, -1
# A node's row in a tree's integer array: its children (-1 -1 for a leaf), then the first of its
# triangles and how many (in the tree's triangle order).
LEFT, RIGHT, FIRST, COUNT = 0, 1, 2, 3
_STACK = 256  # node pairs waiting: a tree of a few thousand triangles is ~12 levels deep


@njit(cache=True, inline="always")
def _cross(ax, ay, az, bx, by, bz):
    return ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx


@njit(cache=True, inline="always")
def _parted(p, q, ax, ay, az, margin) -> bool:
    """Do the projections of triangles `p` and `q` (rows of 9) onto axis a part by more than
    `margin` times its length?"""
    norm2 = ax * ax + ay * ay + az * az
    if norm2 < 1e-200:  # no direction
        return False
    p0 = p[0] * ax + p[1] * ay + p[2] * az
    p1 = p[3] * ax + p[4] * ay + p[5] * az
    p2 = p[6] * ax + p[7] * ay + p[8] * az
    q0 = q[0] * ax + q[1] * ay + q[2] * az
    q1 = q[3] * ax + q[4] * ay + q[5] * az
    q2 = q[6] * ax + q[7] * ay + q[8] * az
    gap = max(min(q0, q1, q2) - max(p0, p1, p2), min(p0, p1, p2) - max(q0, q1, q2))
    return gap > 0.0 and gap * gap > margin * margin * norm2


@njit(cache=True)
def triangles_apart(p: np.ndarray, q: np.ndarray, margin: float) -> bool:
    """Are triangles `p` and `q` (rows of 9: three vertices) farther apart than `margin`, by a
    separating axis?"""
    nx, ny, nz = _cross(p[3] - p[0], p[4] - p[1], p[5] - p[2], p[6] - p[0], p[7] - p[1], p[8] - p[2])
    if _parted(p, q, nx, ny, nz, margin):
        return True
    nx, ny, nz = _cross(q[3] - q[0], q[4] - q[1], q[5] - q[2], q[6] - q[0], q[7] - q[1], q[8] - q[2])
    if _parted(p, q, nx, ny, nz, margin):
        return True
    for i in range(3):
        j = (i + 1) % 3
        ex, ey, ez = p[3 * j] - p[3 * i], p[3 * j + 1] - p[3 * i + 1], p[3 * j + 2] - p[3 * i + 2]
        for k in range(3):
            m = (k + 1) % 3
            fx, fy, fz = q[3 * m] - q[3 * k], q[3 * m + 1] - q[3 * k + 1], q[3 * m + 2] - q[3 * k + 2]
            ax, ay, az = _cross(ex, ey, ez, fx, fy, fz)
            if _parted(p, q, ax, ay, az, margin):
                return True
    return False


@njit(cache=True)
def _pierces(e: np.ndarray, t: np.ndarray, margin: float) -> bool:
    """Does an edge of triangle `e` pierce triangle `t` (rows of 9) robustly (module docstring)?"""
    nx, ny, nz = _cross(t[3] - t[0], t[4] - t[1], t[5] - t[2], t[6] - t[0], t[7] - t[1], t[8] - t[2])
    length = math.sqrt(nx * nx + ny * ny + nz * nz)
    if length < 1e-300:
        return False
    nx, ny, nz = nx / length, ny / length, nz / length
    for i in range(3):
        j = (i + 1) % 3
        ux, uy, uz = e[3 * i], e[3 * i + 1], e[3 * i + 2]
        vx, vy, vz = e[3 * j], e[3 * j + 1], e[3 * j + 2]
        du = nx * (ux - t[0]) + ny * (uy - t[1]) + nz * (uz - t[2])
        dv = nx * (vx - t[0]) + ny * (vy - t[1]) + nz * (vz - t[2])
        if not ((du > margin and dv < -margin) or (du < -margin and dv > margin)):
            continue
        s = du / (du - dv)
        x, y, z = ux + s * (vx - ux), uy + s * (vy - uy), uz + s * (vz - uz)
        edge = math.sqrt((vx - ux) ** 2 + (vy - uy) ** 2 + (vz - uz) ** 2)
        need = margin * (1.0 + edge / abs(du - dv))  # margin * (1 + 1 / sine)
        inside = True
        for k in range(3):
            m = (k + 1) % 3
            fx, fy, fz = t[3 * m] - t[3 * k], t[3 * m + 1] - t[3 * k + 1], t[3 * m + 2] - t[3 * k + 2]
            wx, wy, wz = _cross(nx, ny, nz, fx, fy, fz)  # in the plane, towards the inside
            side = math.sqrt(wx * wx + wy * wy + wz * wz)
            if side < 1e-300 or wx * (x - t[3 * k]) + wy * (y - t[3 * k + 1]) + wz * (z - t[3 * k + 2]) <= need * side:
                inside = False
                break
        if inside:
            return True
    return False


@njit(cache=True)
def triangles_touch(p: np.ndarray, q: np.ndarray, margin: float) -> bool:
    """Do triangles `p` and `q` overlap robustly: an edge of one piercing the other?"""
    return _pierces(p, q, margin) or _pierces(q, p, margin)


@njit(cache=True, inline="always")
def _cross_parted(ti2, ti1, pose, spread, a, b, i1, i2, j, j1, j2, margin) -> bool:
    """Does the cross of a's axis i and b's axis j (i1, i2 and j1, j2: the others, in turn)
    part the boxes (`_boxes_apart`)?"""
    i = 3 - i1 - i2
    gap = abs(ti2 * pose[3 * i1 + j] - ti1 * pose[3 * i2 + j])
    reach = a[3 + i1] * spread[3 * i2 + j] + a[3 + i2] * spread[3 * i1 + j]
    reach += b[3 + j1] * spread[3 * i + j2] + b[3 + j2] * spread[3 * i + j1]
    return gap > reach + margin


@njit(cache=True, inline="always")
def _boxes_apart(a: np.ndarray, b: np.ndarray, pose: np.ndarray, spread: np.ndarray, margin: float) -> bool:
    """Are box `a` (centre, half sides) and box `b` carried by `pose` (rotation row-major,
    translation: 12; `spread`: its rotation's absolute values) farther apart than `margin` along
    one of the 15 axes of two boxes (each's 3, the crosses of one's with the other's)?"""
    t0 = pose[9] + pose[0] * b[0] + pose[1] * b[1] + pose[2] * b[2] - a[0]
    t1 = pose[10] + pose[3] * b[0] + pose[4] * b[1] + pose[5] * b[2] - a[1]
    t2 = pose[11] + pose[6] * b[0] + pose[7] * b[1] + pose[8] * b[2] - a[2]
    if abs(t0) > a[3] + spread[0] * b[3] + spread[1] * b[4] + spread[2] * b[5] + margin:
        return True
    if abs(t1) > a[4] + spread[3] * b[3] + spread[4] * b[4] + spread[5] * b[5] + margin:
        return True
    if abs(t2) > a[5] + spread[6] * b[3] + spread[7] * b[4] + spread[8] * b[5] + margin:
        return True
    # b's centre clamped into a's box, if in b's box too, is in both: no axis parts them by the
    # margin (far above rounding). 62 % of the peg-in-hole's pairs not parted are proven so, without
    # their 12 other axes: decide ~11 % faster
    d0 = min(max(t0, -a[3]), a[3]) - t0
    d1 = min(max(t1, -a[4]), a[4]) - t1
    d2 = min(max(t2, -a[5]), a[5]) - t2
    if (
        abs(pose[0] * d0 + pose[3] * d1 + pose[6] * d2) <= b[3]
        and abs(pose[1] * d0 + pose[4] * d1 + pose[7] * d2) <= b[4]
        and abs(pose[2] * d0 + pose[5] * d1 + pose[8] * d2) <= b[5]
    ):
        return False
    for j in range(3):
        if abs(pose[j] * t0 + pose[3 + j] * t1 + pose[6 + j] * t2) > (
            b[3 + j] + spread[j] * a[3] + spread[3 + j] * a[4] + spread[6 + j] * a[5] + margin
        ):
            return True
    # the 9 edge crosses unrolled (looped, indexing a tuple: decide ~30 % slower on MADAR), all
    # asked (`|`: they rarely part, so not branching on each is ~2 % faster)
    return (
        _cross_parted(t2, t1, pose, spread, a, b, 1, 2, 0, 1, 2, margin)
        | _cross_parted(t2, t1, pose, spread, a, b, 1, 2, 1, 2, 0, margin)
        | _cross_parted(t2, t1, pose, spread, a, b, 1, 2, 2, 0, 1, margin)
        | _cross_parted(t0, t2, pose, spread, a, b, 2, 0, 0, 1, 2, margin)
        | _cross_parted(t0, t2, pose, spread, a, b, 2, 0, 1, 2, 0, margin)
        | _cross_parted(t0, t2, pose, spread, a, b, 2, 0, 2, 0, 1, margin)
        | _cross_parted(t1, t0, pose, spread, a, b, 0, 1, 0, 1, 2, margin)
        | _cross_parted(t1, t0, pose, spread, a, b, 0, 1, 1, 2, 0, margin)
        | _cross_parted(t1, t0, pose, spread, a, b, 0, 1, 2, 0, 1, margin)
    )


@njit(cache=True, inline="always")
def _decide_pair(a_tris, b_tris, i, j, pose, margin, q) -> int:
    """Triangle i of a against triangle j of b, carried into a's frame in `q`."""
    t = b_tris[j]
    for v in range(3):
        x, y, z = t[3 * v], t[3 * v + 1], t[3 * v + 2]
        for c in range(3):
            q[3 * v + c] = pose[3 * c] * x + pose[3 * c + 1] * y + pose[3 * c + 2] * z + pose[9 + c]
    p = a_tris[i]
    for c in range(3):  # their boxes first: most pairs a leaf holds are parted there
        if min(q[c], q[3 + c], q[6 + c]) > max(p[c], p[3 + c], p[6 + c]) + margin:
            return FREE
        if max(q[c], q[3 + c], q[6 + c]) < min(p[c], p[3 + c], p[6 + c]) - margin:
            return FREE
    if triangles_apart(p, q, margin):
        return FREE
    if triangles_touch(p, q, margin):
        return TOUCHING
    return UNDECIDED


@njit(cache=True, inline="always")
def _to_front(witnesses: np.ndarray, w: int, i: int, j: int) -> None:
    """Pair (i, j) at the front of `witnesses`, those before row `w` one row down (row w dropped)."""
    for k in range(w, 0, -1):
        witnesses[k, 0], witnesses[k, 1] = witnesses[k - 1, 0], witnesses[k - 1, 1]
    witnesses[0, 0], witnesses[0, 1] = i, j


@njit(cache=True)
def decide(
    a_boxes: np.ndarray,
    a_nodes: np.ndarray,
    a_tris: np.ndarray,
    b_boxes: np.ndarray,
    b_nodes: np.ndarray,
    b_tris: np.ndarray,
    placement: np.ndarray,
    margin: float,
    witnesses: np.ndarray,
) -> int:
    """TOUCHING, FREE or UNDECIDED for mesh a and mesh b placed in a's frame by `placement`
    (4x4), each as its tree: boxes (N, 6: centre, half sides), nodes (N, 4) and triangles (T, 9)
    in its own frame, node 0 the root. Two nodes are parted when their boxes are farther apart
    than the margin along one of the 15 axes of two boxes (an edge cross is at most a unit
    long: the margin along it is not less than its length times the margin).
    `witnesses` (W, 2) holds the touching pairs found lately (triangle indices, latest first; -1:
    none), tried first; one that proves a contact moves to the front, a new one enters there."""
    pose = np.empty(12)
    for i in range(3):
        for j in range(3):
            pose[3 * i + j] = placement[i, j]
        pose[9 + i] = placement[i, 3]
    spread = np.abs(pose[:9])
    q = np.empty(9)
    for w in range(len(witnesses)):
        if witnesses[w, 0] < 0:
            break
        if _decide_pair(a_tris, b_tris, witnesses[w, 0], witnesses[w, 1], pose, margin, q) == TOUCHING:
            _to_front(witnesses, w, witnesses[w, 0], witnesses[w, 1])
            return TOUCHING
    stack = np.empty((_STACK, 2), dtype=np.int64)
    stack[0, 0], stack[0, 1], top = 0, 0, 1
    undecided = False
    while top:
        top -= 1
        a, b = stack[top, 0], stack[top, 1]
        if _boxes_apart(a_boxes[a], b_boxes[b], pose, spread, margin):
            continue
        a_leaf, b_leaf = a_nodes[a, LEFT] < 0, b_nodes[b, LEFT] < 0
        if a_leaf and b_leaf:
            for i in range(a_nodes[a, FIRST], a_nodes[a, FIRST] + a_nodes[a, COUNT]):
                for j in range(b_nodes[b, FIRST], b_nodes[b, FIRST] + b_nodes[b, COUNT]):
                    verdict = _decide_pair(a_tris, b_tris, i, j, pose, margin, q)
                    if verdict == TOUCHING:
                        _to_front(witnesses, len(witnesses) - 1, i, j)
                        return TOUCHING
                    undecided |= verdict == UNDECIDED
            continue
        if top + 2 > _STACK:
            return UNDECIDED
        wider_a = a_boxes[a, 3:].sum() >= b_boxes[b, 3:].sum()
        if b_leaf or (not a_leaf and wider_a):
            stack[top, 0], stack[top, 1] = a_nodes[a, LEFT], b
            stack[top + 1, 0], stack[top + 1, 1] = a_nodes[a, RIGHT], b
        else:
            stack[top, 0], stack[top, 1] = a, b_nodes[b, LEFT]
            stack[top + 1, 0], stack[top + 1, 1] = a, b_nodes[b, RIGHT]
        top += 2
    return UNDECIDED if undecided else FREE
