"""The ISO/TS 15066 monitor's compiled code (numba): one person's rows at many states, state by state.

Why: `approach.py` decides which part-capsule rows to measure in numpy batches over (states x
rows) arrays, three rounds of a dozen passes each; with ~200 rows and ~20 of them measured a
state, those passes (and numpy's call overhead) were three quarters of the monitor's time. Here
each state is one loop: every row's bounds, the likely rows measured first, then every row
that could still change the state's sample, measured and folded in at once. What a row needs,
and how its speeds and the sample's aggregates are computed, are `approach.py`'s
(`ApproachMonitor._deciding`, `_Speeds`, `_person`), written per row; the tests hold the two
routes to the same samples. A box or cylinder (palms, adapters, carried objects) is measured
against a capsule exactly (`_shape_capsule`; the numpy route asks coal, ~2.5 us a query from
Python, its distances the same to ~1e-11 m at `collision.PERSON_GJK_TOLERANCE`); a mesh, or
a shape touching the person (a penetration depth), is left to coal: the caller measures those
rows and folds them in with `fold_rows`.

Every jitted function lives in this one file (numba caches a kernel by the file it is defined
in, not by its callees'). Per state the aggregates are ten numbers (`AGGREGATES`): the
nearest row's distance, the nearest outside the contact regions, the least margin (allowed
less approach) and its row, that row's allowed speed, approach and distance, the least scale,
and the stopping row (a moved part closing in where the allowed speed is 0) with its distance.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# Columns of a state's aggregates.
NEAREST, BODY, MARGIN, BINDING, ALLOWED, APPROACH, DISTANCE, SCALE, STOP, STOP_DISTANCE = range(10)
AGGREGATES = 10
# The monitor's numbers, in one array: the policy's padding, S_0, T_r + T_s / 2 and speed factor;
# the bound tolerance; the closing, touching and rounding thresholds (approach.py, person_distance.py).
PADDING, S0, TRAVEL, FACTOR, TOLERANCE, CLOSING, TOUCHING, ROUNDING = range(8)
# What a row's moved part is: measured here (a capsule, a box, a cylinder about z) or by coal.
CAPSULE, BOX, CYLINDER, BY_COAL = range(4)
# `nearest_rows`: a part's bounds are at least those at an earlier state less how far its sphere's
# centre moved since, less this times (1 m + the centre's and the person's reach from the origin)
# for their rounding (`_floor` loses ~6e-8 of that sum at worst, its squares' cancellation).
_MOVED_SLACK = 1e-6


@njit(cache=True, nogil=True, inline="always")
def _kept(distance: float, cap: float, iso: np.ndarray) -> float:
    """`separation.kept_capped_speeds` of one row: the same operations in the same order."""
    room = max(distance - iso[PADDING] - iso[S0], 0.0)
    travel = iso[TRAVEL]
    if travel > 0.0:
        ssm = room / travel
    else:
        ssm = math.inf if room > 0.0 else 0.0
    return iso[FACTOR] * max(ssm, cap)


@njit(cache=True, nogil=True, inline="always")
def _dot(a0: float, a1: float, a2: float, b0: float, b1: float, b2: float) -> float:
    return a0 * b0 + a1 * b1 + a2 * b2


@njit(cache=True, nogil=True, inline="always")
def _clip(x: float, low: float, high: float) -> float:
    return min(max(x, low), high)


@njit(cache=True, nogil=True, inline="always")
def _capsules(
    c1: np.ndarray,
    a1: np.ndarray,
    h1: float,
    r1: float,
    c2: np.ndarray,
    a2: np.ndarray,
    h2: float,
    r2: float,
    out: np.ndarray,
) -> float:
    """`capsule_distance.capsule_distances` of one pair, the same operations on scalars (no
    arrays made: ~5 allocations a pair cost as much as its arithmetic): the signed distance, the
    witness points into out[0:3] (capsule 1) and out[3:6] (capsule 2)."""
    x0, x1, x2 = a1[0], a1[1], a1[2]
    y0, y1, y2 = a2[0], a2[1], a2[2]
    s0, s1, s2 = c1[0] - h1 * x0, c1[1] - h1 * x1, c1[2] - h1 * x2
    t0, t1, t2 = c2[0] - h2 * y0, c2[1] - h2 * y1, c2[2] - h2 * y2
    d0, d1, d2 = 2.0 * h1 * x0, 2.0 * h1 * x1, 2.0 * h1 * x2
    e0, e1, e2 = 2.0 * h2 * y0, 2.0 * h2 * y1, 2.0 * h2 * y2
    r0, r1_, r2_ = s0 - t0, s1 - t1, s2 - t2
    a = _dot(d0, d1, d2, d0, d1, d2)
    e = _dot(e0, e1, e2, e0, e1, e2)
    b = _dot(d0, d1, d2, e0, e1, e2)
    c = _dot(d0, d1, d2, r0, r1_, r2_)
    f = _dot(e0, e1, e2, r0, r1_, r2_)
    safe_a = 1.0 if a <= 1e-18 else a
    safe_e = 1.0 if e <= 1e-18 else e
    denom = a * e - b * b
    s = 0.0 if denom <= 1e-12 * a * e else _clip((b * f - c * e) / denom, 0.0, 1.0)
    t = (b * s + f) / safe_e
    if t < 0.0:
        s = _clip(-c / safe_a, 0.0, 1.0)
    elif t > 1.0:
        s = _clip((b - c) / safe_a, 0.0, 1.0)
    t = _clip(t, 0.0, 1.0)
    if e <= 1e-18:
        s = _clip(-c / safe_a, 0.0, 1.0)
    p0, p1, p2 = s0 + s * d0, s1 + s * d1, s2 + s * d2
    q0, q1, q2 = t0 + t * e0, t1 + t * e1, t2 + t * e2
    g0, g1, g2 = q0 - p0, q1 - p1, q2 - p2
    length = math.sqrt(_dot(g0, g1, g2, g0, g1, g2))
    if length > 1e-12:
        n0, n1, n2 = g0 / length, g1 / length, g2 / length
    else:  # crossing axes: a unit normal to both (to the first if parallel), as `_across`
        n0, n1, n2 = x1 * y2 - x2 * y1, x2 * y0 - x0 * y2, x0 * y1 - x1 * y0
        if not _dot(n0, n1, n2, n0, n1, n2) > 1e-12:
            k0, k1, k2 = (1.0, 0.0, 0.0) if abs(x0) < 0.9 else (0.0, 1.0, 0.0)
            n0, n1, n2 = x1 * k2 - x2 * k1, x2 * k0 - x0 * k2, x0 * k1 - x1 * k0
        size = math.sqrt(_dot(n0, n1, n2, n0, n1, n2))
        n0, n1, n2 = n0 / size, n1 / size, n2 / size
    out[0], out[1], out[2] = p0 + r1 * n0, p1 + r1 * n1, p2 + r1 * n2
    out[3], out[4], out[5] = q0 - r2 * n0, q1 - r2 * n1, q2 - r2 * n2
    return length - r1 - r2


@njit(cache=True, nogil=True, inline="always")
def _nearest_on_shape(kind: int, dims: np.ndarray, x0: float, x1: float, x2: float) -> tuple[float, float, float]:
    """The point of a box (half sides dims[0:3]) or of a cylinder about z (radius dims[0], half
    length dims[1]) nearest (x0, x1, x2), all in the shape's frame: the projection onto it."""
    if kind == BOX:
        return _clip(x0, -dims[0], dims[0]), _clip(x1, -dims[1], dims[1]), _clip(x2, -dims[2], dims[2])
    z, across = _clip(x2, -dims[1], dims[1]), math.sqrt(x0 * x0 + x1 * x1)
    if across > dims[0]:
        return x0 * (dims[0] / across), x1 * (dims[0] / across), z
    return x0, x1, z


@njit(cache=True, nogil=True, inline="always")
def _slope(kind: int, dims: np.ndarray, t: float, a: np.ndarray, d: np.ndarray) -> float:
    """Half the derivative in t of the squared distance from a + t d to the shape: (p - proj p).d,
    non-decreasing in t (the squared distance to a convex set is convex, its gradient 2 (p - proj p))."""
    p0, p1, p2 = a[0] + t * d[0], a[1] + t * d[1], a[2] + t * d[2]
    q0, q1, q2 = _nearest_on_shape(kind, dims, p0, p1, p2)
    return _dot(p0 - q0, p1 - q1, p2 - q2, d[0], d[1], d[2])


@njit(cache=True, nogil=True, inline="always")
def _segment_to_shape(kind: int, dims: np.ndarray, a: np.ndarray, d: np.ndarray) -> float:
    """The t in [0, 1] where a + t d (a segment in the shape's frame) is nearest the shape: where
    `_slope` changes sign, bisected until the interval cannot shrink (the distance is then exact
    to rounding: it is flat there)."""
    if _slope(kind, dims, 0.0, a, d) >= 0.0:
        return 0.0
    if _slope(kind, dims, 1.0, a, d) <= 0.0:
        return 1.0
    low, high = 0.0, 1.0
    for _ in range(64):
        middle = 0.5 * (low + high)
        if middle <= low or middle >= high:
            break
        if _slope(kind, dims, middle, a, d) < 0.0:
            low = middle
        else:
            high = middle
    return 0.5 * (low + high)


@njit(cache=True, nogil=True, inline="always")
def _shape_capsule(
    rotation: np.ndarray,
    origin: np.ndarray,
    n: int,
    f: int,
    local_rotation: np.ndarray,
    local_origin: np.ndarray,
    kind: int,
    dims: np.ndarray,
    c2: np.ndarray,
    a2: np.ndarray,
    h2: float,
    r2: float,
    scratch: np.ndarray,
    out: np.ndarray,
) -> float:
    """A box or cylinder placed at (local_rotation, local_origin) in frame f at state n against
    the capsule (c2, a2, h2, r2): the distance and its witness points into out[0:3] (the
    shape's) and out[3:6] (the capsule's), as `_capsules`; NaN where they touch or overlap (a
    penetration depth is left to coal). scratch (15): the shape's world rotation, then the
    capsule's axis segment (start, end - start) in the shape's frame."""
    r, a, d = scratch[0:9], scratch[9:12], scratch[12:15]
    for i in range(3):  # the shape's world rotation R_f R_local, row-major
        for j in range(3):
            r[3 * i + j] = (
                rotation[n, f, i, 0] * local_rotation[0, j]
                + rotation[n, f, i, 1] * local_rotation[1, j]
                + rotation[n, f, i, 2] * local_rotation[2, j]
            )
    _placed(rotation, origin, n, f, local_origin, out)  # the shape's world origin, in out[0:3]
    s0, s1, s2 = c2[0] - h2 * a2[0] - out[0], c2[1] - h2 * a2[1] - out[1], c2[2] - h2 * a2[2] - out[2]
    e0, e1, e2 = 2.0 * h2 * a2[0], 2.0 * h2 * a2[1], 2.0 * h2 * a2[2]
    for j in range(3):  # R^T (start - origin), R^T (end - start)
        a[j] = r[j] * s0 + r[3 + j] * s1 + r[6 + j] * s2
        d[j] = r[j] * e0 + r[3 + j] * e1 + r[6 + j] * e2
    t = _segment_to_shape(kind, dims, a, d)
    p0, p1, p2 = a[0] + t * d[0], a[1] + t * d[1], a[2] + t * d[2]
    q0, q1, q2 = _nearest_on_shape(kind, dims, p0, p1, p2)
    g0, g1, g2 = p0 - q0, p1 - q1, p2 - q2
    gap = math.sqrt(_dot(g0, g1, g2, g0, g1, g2))
    if not gap - r2 > 0.0:
        return math.nan
    for i in range(3):  # to the world: the shape's point, and the capsule's towards it
        shape_point = r[3 * i] * q0 + r[3 * i + 1] * q1 + r[3 * i + 2] * q2 + out[i]
        out[3 + i] = shape_point + (1.0 - r2 / gap) * (r[3 * i] * g0 + r[3 * i + 1] * g1 + r[3 * i + 2] * g2)
        out[i] = shape_point
    return gap - r2


@njit(cache=True, nogil=True, inline="always")
def _placed(rotation: np.ndarray, origin: np.ndarray, n: int, f: int, local: np.ndarray, out: np.ndarray) -> None:
    """The point `local` of frame f (its joint's frame) in the world at state n, into out."""
    for i in range(3):
        out[i] = rotation[n, f, i, 0] * local[0] + rotation[n, f, i, 1] * local[1] + rotation[n, f, i, 2] * local[2]
        out[i] += origin[n, f, i]


@njit(cache=True, nogil=True, inline="always")
def _velocity(
    linear: np.ndarray, angular: np.ndarray, origin: np.ndarray, n: int, f: int, p0: float, p1: float, p2: float
) -> tuple[float, float, float]:
    """The world velocity of the point (p0, p1, p2) riding on frame f at state n: the frame
    origin's plus its spin across the offset (`person_distance._point_velocity`)."""
    w0, w1, w2 = angular[n, f, 0], angular[n, f, 1], angular[n, f, 2]
    o0, o1, o2 = p0 - origin[n, f, 0], p1 - origin[n, f, 1], p2 - origin[n, f, 2]
    return (
        linear[n, f, 0] + (w1 * o2 - w2 * o1),
        linear[n, f, 1] + (w2 * o0 - w0 * o2),
        linear[n, f, 2] + (w0 * o1 - w1 * o0),
    )


@njit(cache=True, nogil=True, inline="always")
def _fold(
    agg: np.ndarray, row: int, distance: float, allowed: float, approach: float, contact: bool, iso: np.ndarray
) -> None:
    """Fold a measured row into a state's aggregates (ties go to the lower row, as argmin)."""
    if distance < agg[NEAREST]:
        agg[NEAREST] = distance
    if not contact and distance < agg[BODY]:
        agg[BODY] = distance
    margin = allowed - approach
    # Row 0 starts as the binding row, unmeasured (argmin's answer where every margin is inf).
    if margin < agg[MARGIN] or (margin == agg[MARGIN] and row <= agg[BINDING]):
        agg[MARGIN], agg[BINDING] = margin, row
        agg[ALLOWED], agg[APPROACH], agg[DISTANCE] = allowed, approach, distance
    closing = approach > iso[CLOSING]
    if closing and allowed / approach < agg[SCALE]:
        agg[SCALE] = allowed / approach
    if closing and allowed <= 0.0:
        if agg[STOP] < 0 or distance < agg[STOP_DISTANCE] or (distance == agg[STOP_DISTANCE] and row < agg[STOP]):
            agg[STOP], agg[STOP_DISTANCE] = row, distance


@njit(cache=True, nogil=True, inline="always")
def _speeds(
    distance: float, point: np.ndarray, v0: float, v1: float, v2: float, contact: bool, cap: float, iso: np.ndarray
) -> tuple[float, float]:
    """`approach._Speeds.of` of one row: (allowed, approach), the robot point at point[0:3], the
    person's at point[3:6], the robot point's velocity v."""
    allowed = _kept(distance, cap, iso)
    if contact or distance <= iso[TOUCHING]:
        return allowed, math.sqrt(_dot(v0, v1, v2, v0, v1, v2))
    g0, g1, g2 = point[3] - point[0], point[4] - point[1], point[5] - point[2]
    return allowed, _dot(v0, v1, v2, g0, g1, g2) / max(distance, iso[TOUCHING])


@njit(cache=True, nogil=True, inline="always")
def _needed(
    floor: float,
    speed: float,
    lowest: float,
    contact: bool,
    nearest: float,
    body: float,
    margin: float,
    scale: float,
    closing: float,
) -> bool:
    """`approach.ApproachMonitor._deciding`'s `needed` for one row against a state's aggregates
    so far (NEAREST, BODY, MARGIN, SCALE: the caller holds them in locals, read again after a
    fold; read from agg at every row they were a third of the kernel's time)."""
    if floor <= nearest or (not contact and floor <= body) or lowest - speed <= margin:
        return True
    return speed > closing and (lowest <= 0.0 or lowest <= scale * speed)


@njit(cache=True, nogil=True, inline="always")
def _floor(
    centre: np.ndarray,
    centre_sq: np.ndarray,
    terms: np.ndarray,
    robot: tuple,
    rows: tuple,
    person: tuple,
    k: int,
    tolerance: float,
) -> float:
    """A lower bound on row k's distance: its part's sphere (placed in centre, |c|^2 in
    centre_sq) against the person's capsule's axis (|p|^2 and p.a in `terms`: `_person_terms`)
    (`PersonDistances._bounds`), less `tolerance`."""
    p, s = rows[0][k], rows[1][k]
    person_centre, person_axis, person_half, person_radius = person
    c0, c1, c2 = centre[p, 0], centre[p, 1], centre[p, 2]
    p0, p1, p2 = person_centre[s, 0], person_centre[s, 1], person_centre[s, 2]
    x0, x1, x2 = person_axis[s, 0], person_axis[s, 1], person_axis[s, 2]
    # part_spheres.axis_gaps' products: |c|^2 + |p|^2 - (2 c.p + t (2 along - t)), along = c.a - p.a
    along = _dot(c0, c1, c2, x0, x1, x2) - terms[s, 1]
    t = _clip(along, -person_half[s], person_half[s])
    squared = centre_sq[p] + terms[s, 0]
    squared -= 2.0 * _dot(c0, c1, c2, p0, p1, p2) + t * (2.0 * along - t)
    return math.sqrt(max(squared, 0.0)) - robot[5][p] - person_radius[s] - tolerance


@njit(cache=True, nogil=True)
def _person_terms(person: tuple) -> np.ndarray:
    """Per capsule of the person, what `_floor` reads of it at every state and row, found once a
    call: |p|^2 and p.a (S, 2), a capsule's centre p and axis a."""
    person_centre, person_axis = person[0], person[1]
    terms = np.empty((person_centre.shape[0], 2))
    for s in range(person_centre.shape[0]):
        p0, p1, p2 = person_centre[s, 0], person_centre[s, 1], person_centre[s, 2]
        terms[s, 0] = _dot(p0, p1, p2, p0, p1, p2)
        terms[s, 1] = _dot(p0, p1, p2, person_axis[s, 0], person_axis[s, 1], person_axis[s, 2])
    return terms


@njit(cache=True, nogil=True)
def _person_reach(person: tuple) -> float:
    """How far from the origin the person's capsules' axes reach: the most of |centre| + half length."""
    person_centre, person_half = person[0], person[2]
    reach = 0.0
    for s in range(person_centre.shape[0]):
        p0, p1, p2 = person_centre[s, 0], person_centre[s, 1], person_centre[s, 2]
        reach = max(reach, math.sqrt(_dot(p0, p1, p2, p0, p1, p2)) + person_half[s])
    return reach


@njit(cache=True, nogil=True, inline="always")
def _place_parts(
    rotation: np.ndarray,
    origin: np.ndarray,
    n: int,
    robot: tuple,
    centre: np.ndarray,
    centre_sq: np.ndarray,
    placed_centre: np.ndarray,
    placed_axis: np.ndarray,
) -> None:
    """At state n: every part's sphere centre into centre (P, 3) and its squared length into
    centre_sq (P,), every robot capsule's centre and axis into placed_centre, placed_axis (C, 3)."""
    capsule_frame, capsule_centre, capsule_axis, sphere_frame, sphere_centre, _ = robot
    for p in range(sphere_frame.size):
        _placed(rotation, origin, n, sphere_frame[p], sphere_centre[p], centre[p])
        centre_sq[p] = _dot(centre[p, 0], centre[p, 1], centre[p, 2], centre[p, 0], centre[p, 1], centre[p, 2])
    for c in range(capsule_frame.size):
        f = capsule_frame[c]
        _placed(rotation, origin, n, f, capsule_centre[c], placed_centre[c])
        for i in range(3):  # an axis turns with the frame, without its origin
            placed_axis[c, i] = (
                rotation[n, f, i, 0] * capsule_axis[c, 0]
                + rotation[n, f, i, 1] * capsule_axis[c, 1]
                + rotation[n, f, i, 2] * capsule_axis[c, 2]
            )


@njit(cache=True, nogil=True, inline="always")
def _row_distance(
    rotation: np.ndarray,
    origin: np.ndarray,
    n: int,
    k: int,
    placed_centre: np.ndarray,
    placed_axis: np.ndarray,
    rows: tuple,
    person: tuple,
    scratch: np.ndarray,
    point: np.ndarray,
) -> float:
    """Row k's distance at state n and its witness points into point (robot 0:3, person 3:6):
    a capsule (`_capsules`), a box or cylinder (`_shape_capsule`); NaN where coal must measure
    it (BY_COAL, or a shape touching the person)."""
    _, slot, capsule, half, radius, frame, shape, local_rotation, local_origin, dims = rows
    person_centre, person_axis, person_half, person_radius = person
    kind, s = shape[k], slot[k]
    if kind == CAPSULE:
        c = capsule[k]
        return _capsules(
            placed_centre[c], placed_axis[c], half[k], radius[k],
            person_centre[s], person_axis[s], person_half[s], person_radius[s], point,
        )  # fmt: skip
    if kind == BY_COAL:
        return math.nan
    return _shape_capsule(
        rotation, origin, n, frame[k], local_rotation[k], local_origin[k], kind, dims[k],
        person_centre[s], person_axis[s], person_half[s], person_radius[s], scratch, point,
    )  # fmt: skip


@njit(cache=True, nogil=True)
def capsule_rows(
    rotation: np.ndarray,
    origin: np.ndarray,
    linear: np.ndarray,
    angular: np.ndarray,
    geometry: tuple,
    person: tuple,
    contact: np.ndarray,
    caps: np.ndarray,
    iso: np.ndarray,
    agg: np.ndarray,
    left: np.ndarray,
) -> None:
    """Per state n (frames (N, F, ...)): every row's lower bound on its distance and upper bound
    on its part's speed, the likely rows measured, then every row `_needed` against what is
    measured so far, each folded into agg[n] (AGGREGATES). `geometry` (`PersonDistances.
    _kernel_geometry`): the robot's capsules (frame, centre, axis in it) and its parts' spheres
    (frame, centre, radius); per row its part, person capsule slot, robot capsule with half
    length and radius, frame, shape (CAPSULE, BOX, CYLINDER, BY_COAL), a shape's placement in its
    joint's frame and sizes; `person`: the person's capsules' centres, axes, half lengths and
    radii. A row this cannot measure (BY_COAL, or touching) and that is likely or needed is
    flagged in left[n] (N, K) for coal. The bounds are `PersonDistances._bounds`' (its part's
    sphere against the capsule's axis)."""
    robot, rows = geometry
    sphere_frame, sphere_radius, row_part, row_frame = robot[3], robot[5], rows[0], rows[5]
    n_states, n_rows = left.shape
    floor, lowest, likely = np.empty(n_rows), np.empty(n_rows), np.empty(n_rows, dtype=np.bool_)
    n_parts, n_capsules = sphere_radius.size, robot[0].size
    part_speed, centre, centre_sq = np.empty(n_parts), np.empty((n_parts, 3)), np.empty(n_parts)
    placed_centre = np.empty((n_capsules, 3))
    placed_axis = np.empty((n_capsules, 3))
    point, scratch = np.empty(6), np.empty(15)
    terms, tolerance, closing = _person_terms(person), iso[TOLERANCE], iso[CLOSING]
    for n in range(n_states):
        _place_parts(rotation, origin, n, robot, centre, centre_sq, placed_centre, placed_axis)
        for p in range(n_parts):
            f = sphere_frame[p]
            v0, v1, v2 = _velocity(linear, angular, origin, n, f, centre[p, 0], centre[p, 1], centre[p, 2])
            w0, w1, w2 = angular[n, f, 0], angular[n, f, 1], angular[n, f, 2]
            bound = math.sqrt(_dot(v0, v1, v2, v0, v1, v2)) + math.sqrt(_dot(w0, w1, w2, w0, w1, w2)) * sphere_radius[p]
            part_speed[p] = bound * (1.0 + iso[ROUNDING]) + iso[ROUNDING]
        # The likely rows: the first of the least bound, of the least outside the contact regions,
        # of the least allowed less speed and of the least allowed over speed (closing in).
        least_floor = least_body = least_margin = least_ratio = math.inf
        at_floor = at_body = at_margin = at_ratio = 0
        for k in range(n_rows):
            bound, speed = _floor(centre, centre_sq, terms, robot, rows, person, k, tolerance), part_speed[row_part[k]]
            allowed = _kept(bound, caps[k], iso)
            floor[k], lowest[k] = bound, allowed
            if bound < least_floor:
                least_floor, at_floor = bound, k
            if not contact[k] and bound < least_body:
                least_body, at_body = bound, k
            if allowed - speed < least_margin:
                least_margin, at_margin = allowed - speed, k
            if speed > closing and allowed / speed < least_ratio:
                least_ratio, at_ratio = allowed / speed, k
        likely[:] = False
        likely[at_floor] = likely[at_body] = likely[at_margin] = likely[at_ratio] = True
        a = agg[n]
        a[NEAREST] = a[BODY] = a[MARGIN] = a[DISTANCE] = a[SCALE] = math.inf
        a[BINDING], a[ALLOWED], a[APPROACH], a[STOP], a[STOP_DISTANCE] = 0.0, math.inf, 0.0, -1.0, math.inf
        for sweep in range(2):  # the likely rows first, then the others while they may matter
            nearest, body, margin, scale = a[NEAREST], a[BODY], a[MARGIN], a[SCALE]
            for k in range(n_rows):
                if likely[k] != (sweep == 0):
                    continue
                speed = part_speed[row_part[k]]
                if sweep == 1 and not _needed(
                    floor[k], speed, lowest[k], contact[k], nearest, body, margin, scale, closing
                ):
                    continue
                distance = _row_distance(
                    rotation, origin, n, k, placed_centre, placed_axis, rows, person, scratch, point
                )
                if math.isnan(distance):  # coal's to measure
                    left[n, k] = True
                    continue
                v0, v1, v2 = _velocity(linear, angular, origin, n, row_frame[k], point[0], point[1], point[2])
                allowed, approach = _speeds(distance, point, v0, v1, v2, contact[k], caps[k], iso)
                _fold(a, k, distance, allowed, approach, contact[k], iso)
                nearest, body, margin, scale = a[NEAREST], a[BODY], a[MARGIN], a[SCALE]


@njit(cache=True, nogil=True)
def fold_rows(
    states: np.ndarray,
    rows: np.ndarray,
    distance: np.ndarray,
    points: np.ndarray,
    origin: np.ndarray,
    linear: np.ndarray,
    angular: np.ndarray,
    row_frame: np.ndarray,
    contact: np.ndarray,
    caps: np.ndarray,
    iso: np.ndarray,
    agg: np.ndarray,
) -> None:
    """Rows measured elsewhere (coal), (states[i], rows[i]) at distance[i] with witness points
    points[i] (robot 0:3, person 3:6), folded into agg (N, AGGREGATES)."""
    for i in range(states.size):
        n, k, point = states[i], rows[i], points[i]
        v0, v1, v2 = _velocity(linear, angular, origin, n, row_frame[k], point[0], point[1], point[2])
        allowed, approach = _speeds(distance[i], point, v0, v1, v2, contact[k], caps[k], iso)
        _fold(agg[n], k, distance[i], allowed, approach, contact[k], iso)


@njit(cache=True, nogil=True)
def nearest_rows(
    rotation: np.ndarray,
    origin: np.ndarray,
    geometry: tuple,
    person: tuple,
    tolerance: float,
    ceiling: float,
    best: np.ndarray,
    left: np.ndarray,
) -> None:
    """The least distance over every row and state (frames (N, F, ...); `geometry` and `person`
    as `capsule_rows`') into best: (distance, state, row), the first state and row of equal
    ones; a row is measured only where its bound
    (`_floor`) is within the least found so far and `ceiling` (what the caller found elsewhere),
    so no row left out could come closer or as close. A row this cannot measure is flagged in
    left (N, K) for coal, as `capsule_rows` flags it. A part whose rows' bounds were all far above
    at an earlier state and whose sphere has not moved as far since is passed whole (its bounds
    are a distance's to its centre: they fall no faster than it moves): the rows passed are
    among those the bound passes, so the same rows are measured (scenario a's path report: the
    bounds were ~85 of its ~95 us)."""
    robot, rows = geometry
    n_states, n_rows = left.shape
    n_parts = robot[5].size
    centre, centre_sq = np.empty((n_parts, 3)), np.empty(n_parts)
    placed_centre, placed_axis = np.empty((robot[0].size, 3)), np.empty((robot[0].size, 3))
    point, scratch = np.empty(6), np.empty(15)
    terms = _person_terms(person)
    # Per part: a lower bound on its rows' bounds at this state (-inf: none), where its centre was
    # at the last, and the least bound of its rows at this one (-inf for a NaN).
    lower, was, found = np.full(n_parts, -math.inf), np.zeros((n_parts, 3)), np.empty(n_parts)
    reach = 1.0 + _person_reach(person)
    least, state, row = math.inf, -1, -1  # in locals: read from best at every row they cost more
    for n in range(n_states):
        _place_parts(rotation, origin, n, robot, centre, centre_sq, placed_centre, placed_axis)
        for p in range(n_parts):
            d0, d1, d2 = centre[p, 0] - was[p, 0], centre[p, 1] - was[p, 1], centre[p, 2] - was[p, 2]
            lower[p] -= math.sqrt(_dot(d0, d1, d2, d0, d1, d2)) + _MOVED_SLACK * (reach + math.sqrt(centre_sq[p]))
            was[p, 0], was[p, 1], was[p, 2] = centre[p, 0], centre[p, 1], centre[p, 2]
            found[p] = math.inf
        for k in range(n_rows):
            p = rows[0][k]
            if lower[p] > min(least, ceiling):  # so is the row's bound
                found[p] = min(found[p], lower[p])
                continue
            bound = _floor(centre, centre_sq, terms, robot, rows, person, k, tolerance)
            found[p] = -math.inf if math.isnan(bound) else min(found[p], bound)
            if bound > min(least, ceiling):
                continue
            distance = _row_distance(rotation, origin, n, k, placed_centre, placed_axis, rows, person, scratch, point)
            if math.isnan(distance):
                left[n, k] = True
            elif distance < least:
                least, state, row = distance, n, k
        lower, found = found, lower
    best[0], best[1], best[2] = least, float(state), float(row)
