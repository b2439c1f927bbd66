"""The certifier's compiled code (numba): forward kinematics, lower bounds on distances, and the
per-state verdict over a certifier's packed arrays (`free_certifier.py` makes them).

Every jitted function lives in this one file: numba's disk cache is keyed by the source file a
function is defined in, not by its callees in other modules, nor by the globals it read, so a
kernel calling into another file could run stale code after an upgrade. Constants that are
data (the tolerance) travel in the arrays. Functions called per row or once per state are
inlined by numba (`inline="always"`): LLVM left them as calls, each passing its arrays field by
field, which cost more than their arithmetic (the verdict x0.8-0.9). The hot loop is written out
(a loop over the levels of runs made every pair ~40 % slower).

The bounds are conservative: a capsule (or box) holds its geometry (`free_certifier._held_by`),
a mesh's pieces hold its triangles (coal tests a mesh by its triangles), a node's sphere (a
link's geometries, a person's capsules) holds its members' spheres, and each distance below is
a true lower bound in exact arithmetic; rounding errs by ~1e-15 m on metre sized scenes, far
below the 1e-4 m tolerance.
- Segments: the least distance is reached at an end of one of them (a point-to-segment
  distance) or at points inside both, where it is the distance between their lines; the line
  distance is never above the segments', so the least of the four end distances and the line
  distance (when the lines' nearest points fall within the segments, 1e-3 of margin for
  rounding) is a lower bound. Nearly parallel lines (sine below 1e-4) have an ill-conditioned
  line distance: there the distance of the second segment's ends to the first's line, less the
  second's length times 1e-4, bounds it instead (along a segment at angle t to a line, the
  squared distance is the lines' squared distance plus (s sin t)^2).
- Capsule to box: beyond a face when both ends of the segment lie past the face's plane by more
  than the radius (the plane separates them). Else each piece of the segment lies in a sphere
  about its middle of radius half its length (plus the capsule's), whose distance to the box is
  exact; a piece too near is halved, down to `_DEPTH` levels.
- An exact capsule (or sphere) and an exact box still not cleared: the plane through the box's
  point nearest the segment's nearest point bounds their distance, tight to rounding
  (`capsule_box_floor`): a UR5 arm walked along a box, a few mm away, no longer goes to coal.
A pair not cleared is named to the caller, which asks coal about it alone (up to a few; more:
the whole broad phase); unless it is proven to touch (`exact_verdict`): an exact capsule
reaching more than the tolerance into an exact box, where coal finds a collision too. Most
states a search walks into an obstacle end there, with no call to coal (the UR5 scenes: ~130 a
plan).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from hriplan.robots import mesh_pair_kernels
from hriplan.robots.kernel_cache import njit_keyed
from hriplan.robots.mesh_pair_kernels import FREE as MESHES_FREE
from hriplan.robots.mesh_pair_kernels import TOUCHING as MESHES_TOUCH
from hriplan.robots.mesh_pair_kernels import decide

KEYED_BY = (mesh_pair_kernels,)  # the verdict walks tabled mesh pairs' triangles (`_decided_tables`)

REVOLUTE, CONTINUOUS, PRISMATIC = 0, 1, 2
JOINT_ROW = 15  # a joint's row: placement rotation (9, row-major), translation (3), unit axis (3)
_DEPTH = 6  # a capsule against a box: pieces of 1/64 of its segment at the finest
_PARALLEL = 1e-4  # sine below which two segments' line distance is not used
_INSIDE = 1e-3  # margin on the lines' nearest points falling within both segments
# A geometry's row: capsule ends in its joint's frame (3 + 3) and radius; box rotation (9),
# centre (3) and half sides (3) in the joint's frame (a box of infinite sides when it has none);
# the radius of the sphere about the capsule's middle that holds it (half its length + radius);
# which of its capsule and box is the geometry itself (EXACT_CAPSULE: a capsule or sphere,
# EXACT_BOX: a box), not a shape holding it: only there is a pair decided exactly (`exact_verdict`).
CAPSULE, BOX, REACH, EXACT = 7, 15, 22, 23
ROW = EXACT + 1
EXACT_CAPSULE, EXACT_BOX = 1.0, 2.0
TOUCHING = -2  # `_verdict`: a pair surely touches
APART = 1  # `exact_verdict`: a pair surely apart
_HALVINGS = 53  # of [0, 1], to the segment's nearest point to a box: a double's precision
# A pair's row: its geometries' rows a, b, its id, then per level (coarse to fine: a's node and
# b's, a and b's node, a and b's part) the two rows tested and where the run of pairs they pass
# ends (on its first pair; 0 elsewhere and where the level tests nothing).
PAIR_ID, NODES, NODE, PART = 2, 3, 6, 9
LEVELS, PAIR = 3, 12
# A tabled mesh pair's row (`FreeCertifier._mesh_rows`): per mesh (the pair's first, then its
# second) its joint, where its placement in that joint's frame starts in the float array (12:
# rotation row-major, translation), and its tree's boxes (floats), nodes (ints), triangles
# (floats) and their counts; then where its 16 witnesses (ints, 2 each) start.
MESH_JOINT, MESH_PLACED, MESH_BOXES, MESH_NODES, MESH_TRIS, MESH_NODE_COUNT, MESH_TRI_COUNT = range(7)
MESH_SIDE, MESH_WITNESSES = 7, 14
MESH_ROW, WITNESSES = 15, 16


@njit(cache=True, nogil=True)
def place_joints(q: np.ndarray, rows: np.ndarray, ints: np.ndarray, rotation: np.ndarray, origin: np.ndarray) -> None:
    """World frames of every joint at `q` into `rotation` (njoints, 3, 3) and `origin` (njoints, 3):
    a joint's frame is its parent's, times its placement, times its own motion (as pinocchio).
    Scalars throughout: an array made per joint cost more than the arithmetic."""
    _world(rotation, origin)
    for j in range(1, rows.shape[0]):
        _place_joint(q, rows, ints, rotation, origin, j)


@njit(cache=True, nogil=True)
def walk_frames(
    qs: np.ndarray,
    dqs: np.ndarray,
    rows: np.ndarray,
    ints: np.ndarray,
    idx_v: np.ndarray,
    rotation: np.ndarray,
    origin: np.ndarray,
    linear: np.ndarray,
    angular: np.ndarray,
) -> None:
    """Per state n (qs (N, nq), dqs (N, nv)): every joint's world frame, as `place_joints`, and
    its origin's linear and its body's angular velocity in the world (N, J, 3), as
    `BatchKinematics`' numpy walk: a joint spins as its parent plus its world axis times its
    speed (a prismatic one as its parent), its origin moves as its parent's plus the parent's spin
    across the offset between them, plus its axis times its speed if it slides. `idx_v`: each
    joint's place in dq."""
    for n in range(qs.shape[0]):
        _world(rotation[n], origin[n])
        for r in range(3):
            linear[n, 0, r] = angular[n, 0, r] = 0.0
        for j in range(1, rows.shape[0]):
            _place_joint(qs[n], rows, ints, rotation[n], origin[n], j)
            p, speed = ints[j, 0], dqs[n, idx_v[j]]
            ax, ay, az = rows[j, 12], rows[j, 13], rows[j, 14]
            w0, w1, w2 = angular[n, p, 0], angular[n, p, 1], angular[n, p, 2]
            o0, o1, o2 = (
                origin[n, j, 0] - origin[n, p, 0],
                origin[n, j, 1] - origin[n, p, 1],
                origin[n, j, 2] - origin[n, p, 2],
            )
            linear[n, j, 0] = linear[n, p, 0] + (w1 * o2 - w2 * o1)
            linear[n, j, 1] = linear[n, p, 1] + (w2 * o0 - w0 * o2)
            linear[n, j, 2] = linear[n, p, 2] + (w0 * o1 - w1 * o0)
            for r in range(3):
                along = (rotation[n, j, r, 0] * ax + rotation[n, j, r, 1] * ay + rotation[n, j, r, 2] * az) * speed
                if ints[j, 1] == PRISMATIC:
                    angular[n, j, r] = angular[n, p, r]
                    linear[n, j, r] += along
                else:
                    angular[n, j, r] = angular[n, p, r] + along


@njit(cache=True, nogil=True)
def place_many(
    qs: np.ndarray, rows: np.ndarray, ints: np.ndarray, asked: np.ndarray, rotation: np.ndarray, origin: np.ndarray
) -> None:
    """Per state n (qs (N, nq)): every joint's world frame, as `place_joints`, the joints `asked`
    (F,) kept, into `rotation` (N, F, 3, 3) and `origin` (N, F, 3): `walk_frames`' frames without
    its velocities (a distance bound needs none) nor a gather of the asked joints after."""
    frames, at = np.empty((rows.shape[0], 3, 3)), np.empty((rows.shape[0], 3))
    for n in range(qs.shape[0]):
        _world(frames, at)
        for j in range(1, rows.shape[0]):
            _place_joint(qs[n], rows, ints, frames, at, j)
        for f in range(asked.shape[0]):
            for r in range(3):
                origin[n, f, r] = at[asked[f], r]
                for c in range(3):
                    rotation[n, f, r, c] = frames[asked[f], r, c]


@njit(cache=True, nogil=True, inline="always")
def _world(rotation, origin) -> None:
    """Joint 0's frame, the world's (np.eye would allocate at every call)."""
    for r in range(3):
        origin[0, r] = 0.0
        for c in range(3):
            rotation[0, r, c] = 1.0 if r == c else 0.0


@njit(cache=True, nogil=True, inline="always")
def _place_moved_joints(q, rows, ints, rotation, origin, last, moved) -> None:
    """`place_joints`, keeping the frames of the joints neither whose coordinates nor whose
    ancestors' changed since `last` (the state they were placed at, NaN for none): a planner moves
    one arm at a time, and a frame costs ~40 ns (its sine and cosine). `moved[j]` says which."""
    _world(rotation, origin)
    moved[0] = 0.0
    for j in range(1, rows.shape[0]):
        if _joint_moved(q, ints, last, moved, j):
            _place_joint(q, rows, ints, rotation, origin, j)
    for i in range(q.shape[0]):
        last[i] = q[i]


@njit(cache=True, nogil=True, inline="always")
def _take_moved_joints(q, ints, rotation, origin, last, moved, frames) -> None:
    """`_place_moved_joints` where every joint's frame at `q` is placed already (`frames`:
    rotation and origin from `place_joints` on the same tables, the same arithmetic): those of
    the joints that moved are copied, not computed again."""
    given_rotation, given_origin = frames
    _world(rotation, origin)
    moved[0] = 0.0
    for j in range(1, ints.shape[0]):
        if _joint_moved(q, ints, last, moved, j):
            for r in range(3):
                origin[j, r] = given_origin[j, r]
                for c in range(3):
                    rotation[j, r, c] = given_rotation[j, r, c]
    for i in range(q.shape[0]):
        last[i] = q[i]


@njit(cache=True, nogil=True, inline="always")
def _joint_moved(q, ints, last, moved, j) -> bool:
    """Sets and returns moved[j]: did joint j's coordinates or its parent's frame change since `last`?"""
    p, kind, iq = ints[j, 0], ints[j, 1], ints[j, 2]
    changed = moved[p] != 0.0 or q[iq] != last[iq] or (kind == CONTINUOUS and q[iq + 1] != last[iq + 1])
    moved[j] = 1.0 if changed else 0.0
    return changed


@njit(cache=True, nogil=True, inline="always")
def _place_joint(q, rows, ints, rotation, origin, j) -> None:
    """Joint j's frame: its parent's (placed before it), times its placement, times its motion."""
    p, kind, iq = ints[j, 0], ints[j, 1], ints[j, 2]
    ax, ay, az = rows[j, 12], rows[j, 13], rows[j, 14]
    if kind == PRISMATIC:
        cos, sin, slide = 1.0, 0.0, q[iq]
    elif kind == CONTINUOUS:
        cos, sin, slide = q[iq], q[iq + 1], 0.0
    else:
        cos, sin, slide = math.cos(q[iq]), math.sin(q[iq]), 0.0
    # The joint's own motion in its placement's frame, Rodrigues: cos I + sin [a]x + (1 - cos) a a^T.
    v = 1.0 - cos
    t00, t01, t02 = cos + v * ax * ax, v * ax * ay - sin * az, v * ax * az + sin * ay
    t10, t11, t12 = v * ay * ax + sin * az, cos + v * ay * ay, v * ay * az - sin * ax
    t20, t21, t22 = v * az * ax - sin * ay, v * az * ay + sin * ax, cos + v * az * az
    # Placement times motion (rotation), and the placement's translation plus the slide.
    m00 = rows[j, 0] * t00 + rows[j, 1] * t10 + rows[j, 2] * t20
    m01 = rows[j, 0] * t01 + rows[j, 1] * t11 + rows[j, 2] * t21
    m02 = rows[j, 0] * t02 + rows[j, 1] * t12 + rows[j, 2] * t22
    m10 = rows[j, 3] * t00 + rows[j, 4] * t10 + rows[j, 5] * t20
    m11 = rows[j, 3] * t01 + rows[j, 4] * t11 + rows[j, 5] * t21
    m12 = rows[j, 3] * t02 + rows[j, 4] * t12 + rows[j, 5] * t22
    m20 = rows[j, 6] * t00 + rows[j, 7] * t10 + rows[j, 8] * t20
    m21 = rows[j, 6] * t01 + rows[j, 7] * t11 + rows[j, 8] * t21
    m22 = rows[j, 6] * t02 + rows[j, 7] * t12 + rows[j, 8] * t22
    x = rows[j, 9] + (rows[j, 0] * ax + rows[j, 1] * ay + rows[j, 2] * az) * slide
    y = rows[j, 10] + (rows[j, 3] * ax + rows[j, 4] * ay + rows[j, 5] * az) * slide
    z = rows[j, 11] + (rows[j, 6] * ax + rows[j, 7] * ay + rows[j, 8] * az) * slide
    for r in range(3):
        u0, u1, u2 = rotation[p, r, 0], rotation[p, r, 1], rotation[p, r, 2]
        rotation[j, r, 0] = u0 * m00 + u1 * m10 + u2 * m20
        rotation[j, r, 1] = u0 * m01 + u1 * m11 + u2 * m21
        rotation[j, r, 2] = u0 * m02 + u1 * m12 + u2 * m22
        origin[j, r] = origin[p, r] + u0 * x + u1 * y + u2 * z


@njit(cache=True, nogil=True, inline="always")
def _uncertified_tables(q, tables, axis_ints, axis_floats, words) -> int:
    """The tables that do not certify `q`, bit k for table k: `ClearanceTable.certified`'s
    arithmetic (the cell's word, then the bit of the sub-cell `q` falls in: a table's row is its
    first axis, its axes, its first word and its sub-cells a joint)."""
    mask = 0
    for k in range(tables.shape[0]):
        first, count, fine, flat, sub, inside = tables[k, 0], tables[k, 1], tables[k, 3], 0, 0, True
        for a in range(first, first + count):
            i, n, wrap = axis_ints[a, 0], axis_ints[a, 1], axis_ints[a, 2]
            lower, step = axis_floats[a, 0], axis_floats[a, 1]
            x = (q[i] - lower) / step
            c = math.floor(x)
            s = min(max(math.floor((x - c) * fine), 0), fine - 1)
            if wrap:
                c %= n
            elif c == n and q[i] - lower <= step * n:
                c, s = n - 1, fine - 1
            elif not 0 <= c < n:
                inside = False
                break
            flat, sub = flat * n + c, sub * fine + s
        if not inside or (words[tables[k, 2] + flat] >> sub) & 1 != 1:
            mask |= 1 << k
    return mask


@njit(cache=True, nogil=True)
def _point_segment(px, py, pz, ax, ay, az, bx, by, bz) -> float:
    """Distance from a point to the segment a-b."""
    dx, dy, dz = bx - ax, by - ay, bz - az
    length = dx * dx + dy * dy + dz * dz
    t = 0.0
    if length > 0.0:
        t = min(max(((px - ax) * dx + (py - ay) * dy + (pz - az) * dz) / length, 0.0), 1.0)
    ex, ey, ez = px - ax - t * dx, py - ay - t * dy, pz - az - t * dz
    return math.sqrt(ex * ex + ey * ey + ez * ez)


@njit(cache=True, nogil=True)
def _point_line(px, py, pz, ax, ay, az, dx, dy, dz, length) -> float:
    """Distance from a point to the line through a along d (|d|^2 = length > 0)."""
    t = ((px - ax) * dx + (py - ay) * dy + (pz - az) * dz) / length
    ex, ey, ez = px - ax - t * dx, py - ay - t * dy, pz - az - t * dz
    return math.sqrt(ex * ex + ey * ey + ez * ez)


@njit(cache=True, nogil=True)
def segment_floor(rows, a, b) -> float:
    """A lower bound on the distance between the segments of rows a and b (ends at 0:3 and 3:6;
    module docstring: the ends' distances and, where it can hold the least, the lines' distance).
    Rows and indices, not views: making a view costs more than the arithmetic."""
    p0, p1, p2, p3, p4, p5 = rows[a, 0], rows[a, 1], rows[a, 2], rows[a, 3], rows[a, 4], rows[a, 5]
    q0, q1, q2, q3, q4, q5 = rows[b, 0], rows[b, 1], rows[b, 2], rows[b, 3], rows[b, 4], rows[b, 5]
    least = min(
        _point_segment(p0, p1, p2, q0, q1, q2, q3, q4, q5),
        _point_segment(p3, p4, p5, q0, q1, q2, q3, q4, q5),
        _point_segment(q0, q1, q2, p0, p1, p2, p3, p4, p5),
        _point_segment(q3, q4, q5, p0, p1, p2, p3, p4, p5),
    )
    ux, uy, uz = p3 - p0, p4 - p1, p5 - p2
    vx, vy, vz = q3 - q0, q4 - q1, q5 - q2
    a, e = ux * ux + uy * uy + uz * uz, vx * vx + vy * vy + vz * vz
    if a == 0.0 or e == 0.0:  # a point: its distance is one of the ends'
        return least
    nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    normal = nx * nx + ny * ny + nz * nz
    if normal <= _PARALLEL * _PARALLEL * a * e:
        across = min(
            _point_line(q0, q1, q2, p0, p1, p2, ux, uy, uz, a),
            _point_line(q3, q4, q5, p0, p1, p2, ux, uy, uz, a),
        )
        return min(least, across - math.sqrt(e) * _PARALLEL)
    rx, ry, rz = p0 - q0, p1 - q1, p2 - q2
    b, c, f = ux * vx + uy * vy + uz * vz, ux * rx + uy * ry + uz * rz, vx * rx + vy * ry + vz * rz
    denominator = a * e - b * b
    s, t = (b * f - c * e) / denominator, (a * f - b * c) / denominator
    if s < -_INSIDE or s > 1.0 + _INSIDE or t < -_INSIDE or t > 1.0 + _INSIDE:
        return least
    return min(least, abs(rx * nx + ry * ny + rz * nz) / math.sqrt(normal))


@njit(cache=True, nogil=True)
def _box_gap(x, y, z, hx, hy, hz) -> float:
    """Distance from a point in a box's frame to the box (0 inside)."""
    dx, dy, dz = max(abs(x) - hx, 0.0), max(abs(y) - hy, 0.0), max(abs(z) - hz, 0.0)
    return math.sqrt(dx * dx + dy * dy + dz * dz)


@njit(cache=True, nogil=True)
def _along(rows, a, e, b, c) -> float:
    """End e of row a's segment along axis c of row b's box, from the box's centre."""
    ox, oy, oz = rows[a, 3 * e] - rows[b, 16], rows[a, 3 * e + 1] - rows[b, 17], rows[a, 3 * e + 2] - rows[b, 18]
    return rows[b, 7 + c] * ox + rows[b, 10 + c] * oy + rows[b, 13 + c] * oz


@njit(cache=True, nogil=True, inline="always")
def capsule_beyond_face(rows: np.ndarray, a: int, b: int, tolerance: float) -> bool:
    """True if row a's capsule lies beyond a face of row b's box by more than `tolerance`: both
    ends of its segment past the face's plane by more than its radius (the segment between them
    is too). No square root and no halving: an arm above a table is cleared here."""
    reach = rows[a, 6] + tolerance
    for c in range(3):
        s, t, half = _along(rows, a, 0, b, c), _along(rows, a, 1, b, c), rows[b, 19 + c] + reach
        if (s > half and t > half) or (s < -half and t < -half):
            return True
    return False


@njit(cache=True, nogil=True, inline="always")
def _segment_in_box(rows, a, b):
    """Row a's capsule segment in row b's box frame: its first end and its end minus its first."""
    ox, oy, oz = rows[a, 0] - rows[b, 16], rows[a, 1] - rows[b, 17], rows[a, 2] - rows[b, 18]
    x0 = rows[b, 7] * ox + rows[b, 10] * oy + rows[b, 13] * oz
    y0 = rows[b, 8] * ox + rows[b, 11] * oy + rows[b, 14] * oz
    z0 = rows[b, 9] * ox + rows[b, 12] * oy + rows[b, 15] * oz
    ox, oy, oz = rows[a, 3] - rows[a, 0], rows[a, 4] - rows[a, 1], rows[a, 5] - rows[a, 2]
    dx = rows[b, 7] * ox + rows[b, 10] * oy + rows[b, 13] * oz
    dy = rows[b, 8] * ox + rows[b, 11] * oy + rows[b, 14] * oz
    dz = rows[b, 9] * ox + rows[b, 12] * oy + rows[b, 15] * oz
    return x0, y0, z0, dx, dy, dz


@njit(cache=True, nogil=True)
def capsule_clears_box(rows, a, b, tolerance) -> bool:
    """True if row a's capsule (ends, radius: 0:7) is more than `tolerance` from row b's box
    (rotation 7:16, centre 16:19, half sides 19:22): its segment's pieces, halved where near,
    each in a sphere clear of the box. The pieces are the nodes of a binary tree walked depth
    first (piece i of level l spans [i, i + 1] / 2^l), with no stack."""
    x0, y0, z0, dx, dy, dz = _segment_in_box(rows, a, b)
    hx, hy, hz, radius = rows[b, 19], rows[b, 20], rows[b, 21], rows[a, 6]
    length = math.sqrt(dx * dx + dy * dy + dz * dz)
    level, i = 0, 0
    while True:
        width = 1.0 / (1 << level)
        middle = (i + 0.5) * width
        gap = _box_gap(x0 + middle * dx, y0 + middle * dy, z0 + middle * dz, hx, hy, hz)
        if gap - radius - width * length / 2.0 > tolerance:
            while i % 2 == 1:  # the last of its siblings: up to the first ancestor with a next one
                level, i = level - 1, i // 2
            if level == 0:
                return True
            i += 1
        elif level == _DEPTH:
            return False
        else:
            level, i = level + 1, 2 * i


@njit(cache=True, nogil=True)
def _nearest_along(x0, y0, z0, dx, dy, dz, hx, hy, hz) -> float:
    """The t in [0, 1] where the segment x0 + t d (in a box's frame) comes nearest the box of
    half sides h: the squared distance is convex in t, so its slope grows with t and halving
    [0, 1] on the slope's sign finds where it turns (to rounding)."""
    low, high = 0.0, 1.0
    for _ in range(_HALVINGS):
        t = 0.5 * (low + high)
        slope = 0.0
        for p, d, h in ((x0 + t * dx, dx, hx), (y0 + t * dy, dy, hy), (z0 + t * dz, dz, hz)):
            slope += d * (p - min(max(p, -h), h))
        if slope > 0.0:
            high = t
        else:
            low = t
    return 0.5 * (low + high)


@njit(cache=True, nogil=True, inline="always")
def _nearest_in_box(rows, a, b):
    """Row a's segment in row b's box frame, the box's half sides, and the point of the segment
    nearest the box (`_nearest_along`): what `capsule_in_box` and `capsule_box_floor` read."""
    x0, y0, z0, dx, dy, dz = _segment_in_box(rows, a, b)
    hx, hy, hz = rows[b, 19], rows[b, 20], rows[b, 21]
    t = _nearest_along(x0, y0, z0, dx, dy, dz, hx, hy, hz)
    return x0, y0, z0, dx, dy, dz, hx, hy, hz, x0 + t * dx, y0 + t * dy, z0 + t * dz


@njit(cache=True, nogil=True, inline="always")
def _reaches_in(near, radius, depth) -> bool:
    """`capsule_in_box` given `_nearest_in_box`'s answer `near` and the capsule's radius."""
    _, _, _, _, _, _, hx, hy, hz, px, py, pz = near
    return _box_gap(px, py, pz, hx, hy, hz) < radius - depth


@njit(cache=True, nogil=True, inline="always")
def _floor_of(near, radius) -> float:
    """`capsule_box_floor` given `_nearest_in_box`'s answer `near` and the capsule's radius."""
    x0, y0, z0, dx, dy, dz, hx, hy, hz, px, py, pz = near
    nx, ny, nz = px - min(max(px, -hx), hx), py - min(max(py, -hy), hy), pz - min(max(pz, -hz), hz)
    norm = math.sqrt(nx * nx + ny * ny + nz * nz)
    if norm == 0.0:
        return -radius
    ends = min(nx * x0 + ny * y0 + nz * z0, nx * (x0 + dx) + ny * (y0 + dy) + nz * (z0 + dz))
    return (ends - (abs(nx) * hx + abs(ny) * hy + abs(nz) * hz)) / norm - radius


@njit(cache=True, nogil=True)
def capsule_in_box(rows, a, b, depth) -> bool:
    """True if row a's capsule reaches more than `depth` into row b's box: the point of its
    segment nearest the box (`_nearest_along`) is nearer than its radius less `depth`. It is a
    point's own distance, so a True holds wherever the search stopped."""
    return _reaches_in(_nearest_in_box(rows, a, b), rows[a, 6], depth)


@njit(cache=True, nogil=True)
def capsule_box_floor(rows, a, b) -> float:
    """A lower bound on the distance between row a's capsule and row b's box, tight to rounding:
    the plane through the box's point nearest the segment's nearest point (`_nearest_along`),
    facing it, has the segment's ends (so all of it) on one side and the box's corners on the
    other; their gap along its normal bounds any two points' distance. Any plane would bound
    it: a nearest point found wrong only loosens the bound. Not above 0 where they meet."""
    return _floor_of(_nearest_in_box(rows, a, b), rows[a, 6])


@njit(cache=True, nogil=True)
def exact_verdict(shapes, placed, a, b, tolerance) -> int:
    """For geometries a and b (their rows placed in the world) not cleared by their rows' bounds:
    TOUCHING if one is an exact capsule (or sphere) reaching more than `tolerance` into the
    other, an exact box (coal finds them collide); APART if they are more than `tolerance` apart
    (`capsule_box_floor`: coal finds them apart); else 0, left to coal. Other shapes are held by
    their rows, not equal to them: nothing is proven of them (0). `shapes`: the rows as packed,
    whose EXACT the placed rows do not carry."""
    if shapes[b, EXACT] == EXACT_CAPSULE and shapes[a, EXACT] == EXACT_BOX:
        a, b = b, a
    elif not (shapes[a, EXACT] == EXACT_CAPSULE and shapes[b, EXACT] == EXACT_BOX):
        return 0
    near = _nearest_in_box(placed, a, b)  # one search for both tests
    if _reaches_in(near, placed[a, 6], tolerance):
        return TOUCHING
    return APART if _floor_of(near, placed[a, 6]) > tolerance else 0


@njit(cache=True, nogil=True, inline="always")
def _place(rows, g, rotation, origin, j, out) -> None:
    """Row g (joint j's frame) in the world, into out[g]: capsule ends and radius, box rotation,
    centre and sides, reach."""
    for e in range(2):
        x, y, z = rows[g, 3 * e], rows[g, 3 * e + 1], rows[g, 3 * e + 2]
        for r in range(3):
            out[g, 3 * e + r] = origin[j, r] + rotation[j, r, 0] * x + rotation[j, r, 1] * y + rotation[j, r, 2] * z
    out[g, 6] = rows[g, 6]
    out[g, 19], out[g, 20], out[g, 21], out[g, REACH] = rows[g, 19], rows[g, 20], rows[g, 21], rows[g, REACH]
    if rows[g, 19] == np.inf:  # no box (a capsule or sphere): nothing more is read
        return
    for r in range(3):
        u0, u1, u2 = rotation[j, r, 0], rotation[j, r, 1], rotation[j, r, 2]
        for c in range(3):
            out[g, 7 + 3 * r + c] = u0 * rows[g, 7 + c] + u1 * rows[g, 10 + c] + u2 * rows[g, 13 + c]
        out[g, 16 + r] = origin[j, r] + u0 * rows[g, 16] + u1 * rows[g, 17] + u2 * rows[g, 18]


@njit(cache=True, nogil=True)
def spheres_apart(rows: np.ndarray, a: int, b: int, tolerance: float) -> bool:
    """True if the spheres about placed rows a and b (about their capsules' middles, radius their
    reach) are more than `tolerance` apart: the cheapest test, first for every pair and group."""
    cx = rows[a, 0] + rows[a, 3] - rows[b, 0] - rows[b, 3]
    cy = rows[a, 1] + rows[a, 4] - rows[b, 1] - rows[b, 4]
    cz = rows[a, 2] + rows[a, 5] - rows[b, 2] - rows[b, 5]
    apart = 2.0 * (rows[a, REACH] + rows[b, REACH] + tolerance)  # |cx, cy, cz| is twice the centres' gap
    return cx * cx + cy * cy + cz * cz > apart * apart


@njit(cache=True, nogil=True)
def pair_clear(rows, a, b, tolerance) -> bool:
    """True if placed rows a and b (in the world) are more than `tolerance` apart: the spheres
    about their capsules' middles, else a capsule beyond a face of the other's box, else their
    capsules, else a capsule against the other's box in halved pieces."""
    if spheres_apart(rows, a, b, tolerance):
        return True
    if rows[b, 19] < np.inf and capsule_beyond_face(rows, a, b, tolerance):
        return True
    if rows[a, 19] < np.inf and capsule_beyond_face(rows, b, a, tolerance):
        return True
    if segment_floor(rows, a, b) - rows[a, 6] - rows[b, 6] > tolerance:
        return True
    if rows[b, 19] < np.inf and capsule_clears_box(rows, a, b, tolerance):
        return True
    return rows[a, 19] < np.inf and capsule_clears_box(rows, b, a, tolerance)


@njit(cache=True, nogil=True, inline="always")
def _unpack(floats, ints):
    """The parts of `FreeCertifier._packed`, as views (the tolerance is floats[0])."""
    nj, ng, npairs, ntables, naxes, nused = ints[0], ints[1], ints[2], ints[3], ints[4], ints[5]
    joint_rows = floats[ints[8] : ints[8] + nj * JOINT_ROW].reshape((nj, JOINT_ROW))
    rows = floats[ints[9] : ints[9] + ng * ROW].reshape((ng, ROW))
    axis_floats = floats[ints[10] : ints[10] + naxes * 2].reshape((naxes, 2))
    joint_ints = ints[ints[12] : ints[12] + nj * 3].reshape((nj, 3))
    carrier = ints[ints[13] : ints[13] + ng]
    pairs = ints[ints[14] : ints[14] + npairs * PAIR].reshape((npairs, PAIR))
    tables = ints[ints[15] : ints[15] + ntables * 4].reshape((ntables, 4))
    axis_ints = ints[ints[16] : ints[16] + naxes * 3].reshape((naxes, 3))
    children = ints[ints[17] : ints[17] + nused * 2].reshape((nused, 2))
    bits = ints[ints[19] : ints[24]]  # the words run to the mesh pairs' witnesses
    return joint_rows, rows, axis_floats, joint_ints, carrier, pairs, tables, axis_ints, children, bits


@njit(cache=True, nogil=True, inline="always")
def _scratch(work, nj, ng):
    """The joints' frames, the state they were placed at (up to 2 nj coordinates) and which moved
    then, the placed rows, and the verdict at that state (its code, then the ids of its pairs
    left: `verdict_of`), as views of `work` (made once: an array made at every state cost
    ~0.15 us)."""
    rotation = work[: nj * 9].reshape((nj, 3, 3))
    origin = work[nj * 9 : nj * 12].reshape((nj, 3))
    last, moved = work[nj * 12 : nj * 14], work[nj * 14 : nj * 15]
    return (
        rotation,
        origin,
        last,
        moved,
        work[nj * 15 : nj * 15 + ng * ROW].reshape((ng, ROW)),
        work[nj * 15 + ng * ROW :],
    )


@njit(cache=True, nogil=True)
def _pieces_clear(rows, carrier, children, ints, rotation, origin, placed, a, b, tolerance) -> bool:
    """True if geometries a and b are clear, a mesh taken as its tree of pieces (which hold all
    its triangles: `free_certifier._mesh_pieces`): the larger mesh's nodes against the other
    geometry whole, a node not clear of it split into its children, and a leaf not clear then
    against the other's tree, split the same way; only a leaf against a leaf (or the whole
    geometry) not clear fails. Pieces are placed as they are reached: few states need them.
    Where each piece's subtree ends is read here from `ints` (`FreeCertifier._packed`), not
    unpacked at every state: a view more per state made a UR5 walk step ~6 % slower."""
    subtrees = ints[ints[18] : ints[18] + ints[1]]
    if children[a, 1] == 0 or (children[b, 1] > 0 and rows[a, REACH] < rows[b, REACH]):
        a, b = b, a
    i, last = children[a, 0], children[a, 0] + children[a, 1]
    while i < last:
        _place(rows, i, rotation, origin, carrier[i], placed)
        if pair_clear(placed, i, b, tolerance):
            i = max(subtrees[i], i + 1)  # on, whatever the arrays hold: a walk always ends
            continue
        if subtrees[i] == i + 1 and not _tree_clear(
            rows, carrier, children, subtrees, rotation, origin, placed, i, b, tolerance
        ):
            return False
        i += 1
    return True


@njit(cache=True, nogil=True, inline="always")
def _tree_clear(rows, carrier, children, subtrees, rotation, origin, placed, x, b, tolerance) -> bool:
    """True if placed row x is clear of geometry b's tree of pieces (b's leaves, where its nodes
    are not clear of x); False if b has none."""
    j, last = children[b, 0], children[b, 0] + children[b, 1]
    if j == last:
        return False
    while j < last:
        _place(rows, j, rotation, origin, carrier[j], placed)
        if pair_clear(placed, x, j, tolerance):
            j = max(subtrees[j], j + 1)
        elif subtrees[j] == j + 1:
            return False
        else:
            j += 1
    return True


@njit(cache=True, nogil=True, inline="always")
def _mesh_placed(floats, row, side, rotation, origin, out) -> None:
    """out (3, 4): the world placement of a mesh pair's side (0 its first, MESH_SIDE its second):
    its joint's frame times its placement in that frame."""
    j, at = row[side + MESH_JOINT], row[side + MESH_PLACED]
    for r in range(3):
        for c in range(3):
            out[r, c] = (
                rotation[j, r, 0] * floats[at + c]
                + rotation[j, r, 1] * floats[at + 3 + c]
                + rotation[j, r, 2] * floats[at + 6 + c]
            )
        out[r, 3] = (
            origin[j, r]
            + rotation[j, r, 0] * floats[at + 9]
            + rotation[j, r, 1] * floats[at + 10]
            + rotation[j, r, 2] * floats[at + 11]
        )


@njit(cache=True, nogil=True, inline="always")
def _mesh_tree(floats, ints, row, side):
    """A side's tree as `decide` takes it, views of the packed arrays: boxes, nodes, triangles."""
    nodes, tris = row[side + MESH_NODE_COUNT], row[side + MESH_TRI_COUNT]
    boxes = floats[row[side + MESH_BOXES] : row[side + MESH_BOXES] + 6 * nodes].reshape((nodes, 6))
    links = ints[row[side + MESH_NODES] : row[side + MESH_NODES] + 4 * nodes].reshape((nodes, 4))
    corners = floats[row[side + MESH_TRIS] : row[side + MESH_TRIS] + 9 * tris].reshape((tris, 9))
    return boxes, links, corners


@njit_keyed(mesh_pair_kernels)
def _mesh_pair_verdict(floats, ints, row, margin, rotation, origin) -> int:
    """`mesh_pair_kernels.decide` on a tabled mesh pair (its row of `FreeCertifier`'s mesh rows)
    placed by the joints' frames: MESHES_FREE, MESHES_TOUCH or undecided (its witnesses, in
    `ints`, kept as `decide` leaves them)."""
    a, b = np.empty((3, 4)), np.empty((3, 4))
    _mesh_placed(floats, row, 0, rotation, origin, a)
    _mesh_placed(floats, row, MESH_SIDE, rotation, origin, b)
    placement = np.zeros((4, 4))  # b in a's frame
    for r in range(3):
        for c in range(3):
            placement[r, c] = a[0, r] * b[0, c] + a[1, r] * b[1, c] + a[2, r] * b[2, c]
        placement[r, 3] = a[0, r] * (b[0, 3] - a[0, 3]) + a[1, r] * (b[1, 3] - a[1, 3]) + a[2, r] * (b[2, 3] - a[2, 3])
    placement[3, 3] = 1.0
    a_boxes, a_nodes, a_tris = _mesh_tree(floats, ints, row, 0)
    b_boxes, b_nodes, b_tris = _mesh_tree(floats, ints, row, MESH_SIDE)
    witnesses = ints[row[MESH_WITNESSES] : row[MESH_WITNESSES] + 2 * WITNESSES].reshape((WITNESSES, 2))
    return decide(a_boxes, a_nodes, a_tris, b_boxes, b_nodes, b_tris, placement, margin, witnesses)


@njit_keyed(mesh_pair_kernels)
def _decided_tables(uncertified, floats, ints, rotation, origin) -> int:
    """`uncertified` (bit k: table k does not certify the state) less the tables whose mesh
    pairs their triangles prove apart (`_mesh_pair_verdict`); -1 if one proves a pair touching.
    A table with a pair that is not two meshes (none packed) keeps its bit: coal's."""
    ntables, meshes_of, rows = ints[3], ints[ints[22] : ints[22] + 2 * ints[3]], ints[ints[23] :]
    margin = floats[ints[21]]
    for k in range(ntables):
        if not (uncertified >> k) & 1 or meshes_of[2 * k + 1] == 0:
            continue
        proven = True
        for m in range(meshes_of[2 * k], meshes_of[2 * k] + meshes_of[2 * k + 1]):
            verdict = _mesh_pair_verdict(
                floats, ints, rows[m * MESH_ROW : (m + 1) * MESH_ROW], margin, rotation, origin
            )
            if verdict == MESHES_TOUCH:
                return -1
            proven = proven and verdict == MESHES_FREE
        if proven:
            uncertified &= ~(1 << k)
    return uncertified


@njit(cache=True, nogil=True, inline="always")
def verdict_views(floats, ints):
    """What `verdict_of` takes besides a state, made once for many states (their views made at
    every state cost ~0.35 us of a UR5 state's ~1.55): `_unpack`'s parts, `_scratch`'s, and the
    pairs left (at the end of the int array, as `verdict_one` has them)."""
    return _unpack(floats, ints), _scratch(floats[ints[11] :], ints[0], ints[1]), ints[ints[20] :]


@njit(cache=True, nogil=True, inline="always")
def verdict_of(q, floats, ints, parts, scratch, left, frames) -> int:
    """`_verdict_made`, kept in the scratch beside the state it placed (its code, then the ids of
    its pairs left), whatever the caller: `verdict_one` gives it again for that state."""
    code = _verdict_made(q, floats, ints, parts, scratch, left, frames)
    kept = scratch[5]
    kept[0] = code
    for i in range(1, _left_count(code) + 1):
        kept[i] = left[i]
    return code


@njit(cache=True, nogil=True, inline="always")
def _left_count(code) -> int:
    """How many pair ids a verdict's code says `left` holds from left[1] on (none below 0)."""
    return code >> 32 if code > 0 else 0


@njit(cache=True, nogil=True, inline="always")
def _verdict_made(q, floats, ints, parts, scratch, left, frames) -> int:
    """TOUCHING if a pair surely touches at `q` (`exact_verdict`, the first found, or a tabled mesh
    pair's triangles: coal would find it collide); -1 if more pairs may touch than `left` holds
    (stopped there); else the tables that do not certify `q` and whose mesh pairs their triangles
    do not prove apart (bit k for table k) plus 2^32 times the count of pairs that may
    touch, whose ids `left` gets from left[1] on: 0 is free. A run of pairs passes at once when
    its level's rows are clear: two nodes' spheres, a geometry and a node's sphere as a pair, a
    geometry and a part's. `parts`: `_unpack`'s views; `scratch`: `_scratch`'s, the joints' frames
    and the rows as the last state asked left them (those on no joint placed once, when packed).
    `frames`: None, or every joint's frame at `q` placed by the caller (`_take_moved_joints`)."""
    joint_rows, rows, axis_floats, joint_ints, carrier, pairs, tables, axis_ints, children, bits = parts
    tolerance = floats[0]
    rotation, origin, last, moved, placed, _ = scratch
    if frames is None:
        _place_moved_joints(q, joint_rows, joint_ints, rotation, origin, last, moved)
    else:
        _take_moved_joints(q, joint_ints, rotation, origin, last, moved, frames)
    for g in range(ints[6]):  # the geometries and the links' spheres on a joint that moved
        if carrier[g] != 0 and moved[carrier[g]] != 0.0:
            _place(rows, g, rotation, origin, carrier[g], placed)
    count, k = 0, 0
    while k < pairs.shape[0]:
        a, b = pairs[k, 0], pairs[k, 1]
        if pairs[k, NODES + 2] > 0 and spheres_apart(placed, pairs[k, NODES], pairs[k, NODES + 1], tolerance):
            k = pairs[k, NODES + 2]
            continue
        if pairs[k, NODE + 2] > 0 and pair_clear(placed, a, pairs[k, NODE + 1], tolerance):
            k = pairs[k, NODE + 2]
            continue
        if pairs[k, PART + 2] > 0 and pair_clear(placed, a, pairs[k, PART + 1], tolerance):
            k = pairs[k, PART + 2]
            continue
        if not pair_clear(placed, a, b, tolerance) and (
            (children[a, 1] == 0 and children[b, 1] == 0)
            or not _pieces_clear(rows, carrier, children, ints, rotation, origin, placed, a, b, tolerance)
        ):
            exact = exact_verdict(rows, placed, a, b, tolerance)
            if exact == TOUCHING:
                return TOUCHING
            if exact != APART:
                if count + 1 == left.shape[0]:
                    return -1
                count += 1
                left[count] = pairs[k, PAIR_ID]
        k += 1
    uncertified = _uncertified_tables(q, tables, axis_ints, axis_floats, bits)
    if uncertified != 0:  # the tables' mesh pairs, on their triangles
        uncertified = _decided_tables(uncertified, floats, ints, rotation, origin)
        if uncertified < 0:
            return TOUCHING
    return uncertified + (count << 32)


@njit(cache=True, nogil=True, inline="always")
def _is_last(q, last) -> bool:
    """Is `q` the state the scratch was last placed at, to the bit (NaN, for none, never is)?"""
    for i in range(q.shape[0]):
        if q[i] != last[i] or math.copysign(1.0, q[i]) != math.copysign(1.0, last[i]):
            return False
    return True


@njit_keyed(mesh_pair_kernels)
def verdict_one(q, floats, ints) -> int:
    """`verdict_of` one state (a call from Python: three arrays, the scratch and the pairs left
    at the ends of the float and int arrays, as each array costs the call ~0.05 us). The state
    the scratch was last placed at gets the verdict kept there, its pairs left copied: CBiRRT's
    compiled walk stops at a state it cannot clear and asks the checker, whose first question is
    this one (~9 us a MADAR state near contact, ~330 a peg-in-hole plan)."""
    left, scratch = ints[ints[20] :], _scratch(floats[ints[11] :], ints[0], ints[1])
    _, _, last, moved, _, kept = scratch
    if not _is_last(q, last):
        return verdict_of(q, floats, ints, _unpack(floats, ints), scratch, left, None)
    code = int(kept[0])
    for i in range(1, _left_count(code) + 1):
        left[i] = int(kept[i])
    moved[:] = 0.0  # no joint moved: the scratch as placing `q` again leaves it
    return code


@njit(cache=True, nogil=True)
def same_joints(floats, ints, rows, joint_ints) -> bool:
    """Are `rows` and `joint_ints` (`place_joints`' tables) the certifier's own?"""
    parts = _unpack(floats, ints)
    own_rows, own_ints = parts[0], parts[3]
    if own_rows.shape != rows.shape or own_ints.shape != joint_ints.shape:
        return False
    return (own_rows == rows).all() and (own_ints == joint_ints).all()


@njit_keyed(mesh_pair_kernels)
def verdicts(qs, floats, ints, left) -> np.ndarray:
    """Per state (row n of `left` its pairs that may touch), the arrays unpacked once for all
    states (`verdict_views`)."""
    parts, scratch, _ = verdict_views(floats, ints)
    out = np.empty(qs.shape[0], dtype=np.int64)
    for n in range(qs.shape[0]):
        out[n] = verdict_of(qs[n], floats, ints, parts, scratch, left[n], None)
    return out
