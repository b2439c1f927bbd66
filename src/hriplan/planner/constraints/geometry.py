"""Constraint geometry: signed distances to the volumes and orientation errors, with gradients.

Everything here is pure math on positions, vectors and rotations, so that it can be checked
against finite differences in isolation. The functions named in COMPILED are also numba's source
(`compiled.py` compiles them unchanged, for many states in one call): they keep to scalars,
tuples and `math`. Conventions:
- `signed_distance(p) -> (d, grad)`: d > 0 outside the solid, d < 0 inside (minus the depth).
- points and gradients are 3-sequences of floats, computed with scalars: numpy costs ~0.5-1 us
  per call on a 3-vector, more than these formulas (the planner evaluates them per state).
- orientation errors come with their gradient with respect to an angular velocity (the frame
  of that velocity is stated per function).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pinocchio as pin

_EPS = 1e-12
# Volume shapes by code (`shape_distance`), and the code of a tilt (an orientation with one free axis).
BOX, SPHERE, CYLINDER, CONE, TILT = 0, 1, 2, 3, 4


Vec = tuple[float, float, float]
Rows = tuple[Vec, Vec, Vec]  # a 3x3 matrix as rows of floats


def times(m: Rows, v: Sequence[float]) -> Vec:
    """m v for a 3x3 matrix given by rows: scalars cost less than a numpy call here."""
    (a, b, c), (d, e, f), (g, h, i) = m
    x, y, z = v
    return a * x + b * y + c * z, d * x + e * y + f * z, g * x + h * y + i * z


def in_frame(frame_t: Rows, origin: Vec, p: Vec) -> Vec:
    """A world point in a constraint frame (frame_t: its rotation transposed, origin: its origin)."""
    return times(frame_t, (p[0] - origin[0], p[1] - origin[1], p[2] - origin[2]))


def cross(a: Sequence[float], b: Sequence[float]) -> Vec:
    """Cross product of 3-vectors (np.cross costs ~10 us per call; this well under 1 us)."""
    a0, a1, a2 = a
    b0, b1, b2 = b
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


def box_sd(p: Sequence[float], size: tuple[float, float, float]) -> tuple[float, Vec]:
    x, y, z = p
    qx, qy, qz = abs(x) - size[0] / 2.0, abs(y) - size[1] / 2.0, abs(z) - size[2] / 2.0
    sx, sy, sz = (1.0 if x >= 0.0 else -1.0), (1.0 if y >= 0.0 else -1.0), (1.0 if z >= 0.0 else -1.0)
    ox, oy, oz = max(qx, 0.0), max(qy, 0.0), max(qz, 0.0)
    norm = math.sqrt(ox * ox + oy * oy + oz * oz)
    if norm > 0.0:
        return norm, (ox * sx / norm, oy * sy / norm, oz * sz / norm)
    if qx >= qy and qx >= qz:
        return qx, (sx, 0.0, 0.0)
    if qy >= qz:
        return qy, (0.0, sy, 0.0)
    return qz, (0.0, 0.0, sz)


def sphere_sd(p: Sequence[float], radius: float) -> tuple[float, Vec]:
    x, y, z = p
    norm = math.sqrt(x * x + y * y + z * z)
    grad = (x / norm, y / norm, z / norm) if norm > _EPS else (0.0, 0.0, 1.0)
    return norm - radius, grad


def _radial(p: Sequence[float]) -> tuple[float, float, float]:
    """(rho, unit radial direction x, y) of a point about the z axis."""
    x, y = p[0], p[1]
    rho = math.hypot(x, y)
    return (rho, x / rho, y / rho) if rho > _EPS else (rho, 1.0, 0.0)


def _lift(d_rho: float, d_z: float, cx: float, cy: float) -> Vec:
    """A gradient in the (rho, z) half-plane as a 3-vector."""
    return d_rho * cx, d_rho * cy, d_z


def cylinder_sd(p: np.ndarray, radius: float, height: float) -> tuple[float, np.ndarray]:
    """Cylinder with axis z from z = 0 to z = height."""
    rho, cx, cy = _radial(p)
    z, half = p[2], height / 2.0
    q_rho, q_z = rho - radius, abs(z - half) - half
    s_z = 1.0 if z >= half else -1.0
    out_rho, out_z = max(q_rho, 0.0), max(q_z, 0.0)
    norm = math.hypot(out_rho, out_z)
    if norm > 0.0:
        return norm, _lift(out_rho / norm, out_z * s_z / norm, cx, cy)
    return (q_rho, _lift(1.0, 0.0, cx, cy)) if q_rho >= q_z else (q_z, _lift(0.0, s_z, cx, cy))


def _closest_on_segment(r: float, z: float, a: tuple[float, float], b: tuple[float, float]) -> tuple[float, float]:
    ab_r, ab_z = b[0] - a[0], b[1] - a[1]
    t = ((r - a[0]) * ab_r + (z - a[1]) * ab_z) / (ab_r * ab_r + ab_z * ab_z)
    t = min(max(t, 0.0), 1.0)
    return a[0] + t * ab_r, a[1] + t * ab_z


def cone_sd(p: np.ndarray, radius: float, height: float) -> tuple[float, np.ndarray]:
    """Solid cone, apex at the origin, opening along +z, radius `radius` at z = height.

    In the (rho, z) half-plane the solid is the triangle (0,0), (r,h), (0,h); its boundary there
    is the slant edge and the top edge (the axis is not a boundary)."""
    rho, cx, cy = _radial(p)
    z = p[2]
    best, best_d2 = (0.0, 0.0), math.inf
    for a, b in (((0.0, 0.0), (radius, height)), ((radius, height), (0.0, height))):
        c = _closest_on_segment(rho, z, a, b)
        d2 = (rho - c[0]) ** 2 + (z - c[1]) ** 2
        if d2 < best_d2:
            best, best_d2 = c, d2
    dist = math.sqrt(best_d2)
    inside = 0.0 <= z <= height and rho * height <= radius * z
    if dist < _EPS:  # on the boundary: use the outward normal of the nearer edge
        if z < height:
            slant = math.hypot(radius, height)
            return 0.0, _lift(height / slant, -radius / slant, cx, cy)
        return 0.0, _lift(0.0, 1.0, cx, cy)
    sign = -1.0 if inside else 1.0
    return sign * dist, _lift(sign * (rho - best[0]) / dist, sign * (z - best[1]) / dist, cx, cy)


def shape_distance(shape: int, dims: Vec, p: Vec) -> tuple[float, Vec]:
    """Signed distance and gradient to a volume: BOX (sides dims), SPHERE (radius dims[0]),
    CYLINDER or CONE (radius dims[0], height dims[1])."""
    if shape == BOX:
        return box_sd(p, dims)
    if shape == SPHERE:
        return sphere_sd(p, dims[0])
    if shape == CYLINDER:
        return cylinder_sd(p, dims[0], dims[1])
    return cone_sd(p, dims[0], dims[1])


def widening(gradient: float, goal: Vec, p: Vec) -> tuple[float, Vec]:
    """A dynamic tolerance's widening at `p` (gradient times the distance from `goal`: the margin
    is less by it) and the gradient of minus the widening with respect to p (the margin's pull)."""
    ox, oy, oz = p[0] - goal[0], p[1] - goal[1], p[2] - goal[2]
    distance = math.sqrt(ox * ox + oy * oy + oz * oz)
    if distance <= 1e-12:
        return gradient * distance, (0.0, 0.0, 0.0)
    k = -gradient / distance
    return gradient * distance, (k * ox, k * oy, k * oz)


def rotation_angle(r_err: np.ndarray) -> tuple[float, Vec]:
    """Angle of a rotation and its gradient w.r.t. a local (right) angular velocity."""
    x, y, z = pin.log3(r_err).tolist()
    angle = math.sqrt(x * x + y * y + z * z)
    return angle, ((x / angle, y / angle, z / angle) if angle > _EPS else (0.0, 0.0, 0.0))


def axis_angle(u: Sequence[float], v: Sequence[float]) -> tuple[float, Vec]:
    """Angle between unit vectors u (moving) and v (fixed); gradient w.r.t. the angular
    velocity that moves u (du = w x u), in the frame u and v are expressed in."""
    x, y, z = cross(v, u)
    sine = math.sqrt(x * x + y * y + z * z)
    angle = math.atan2(sine, u[0] * v[0] + u[1] * v[1] + u[2] * v[2])
    return angle, ((x / sine, y / sine, z / sine) if sine > _EPS else (0.0, 0.0, 0.0))


def twist_angle(r_err: np.ndarray, axis: Sequence[float]) -> tuple[float, Vec]:
    """Twist of a rotation about `axis` (swing-twist decomposition), in (-pi, pi], and its
    gradient w.r.t. a local (right) angular velocity."""
    vx, vy, vz, w = pin.Quaternion(r_err).coeffs().tolist()
    if w < 0.0:  # q and -q are the same rotation; keep the twist in (-pi, pi]
        vx, vy, vz, w = -vx, -vy, -vz, -w
    ax, ay, az = axis
    s, c = ax * vx + ay * vy + az * vz, w
    angle = 2.0 * math.atan2(s, c)
    norm2 = s * s + c * c
    if norm2 < _EPS:
        return angle, (0.0, 0.0, 0.0)
    # dq = q (x) (0, w/2): d(s) = w.(c axis + axis x vec)/2, d(c) = -w.vec/2
    kx, ky, kz = cross(axis, (vx, vy, vz))
    return angle, (
        (c * (c * ax + kx) + s * vx) / norm2,
        (c * (c * ay + ky) + s * vy) / norm2,
        (c * (c * az + kz) + s * vz) / norm2,
    )


# A term's ints: its kind (a shape code or TILT), the joint carrying its link, a tilt's free axis.
KIND, JOINT, AXIS = 0, 1, 2
# A term's floats: its frame's rotation and that transposed (9 each, row-major) and origin (3); a
# volume's dims (3) and sign, or a tilt's target axis (3, in the dims' place), tolerance,
# tolerance gradient (0: none) and goal (3); its link's placement on its joint: rotation (9,
# row-major) and translation (3).
FRAME, FRAME_T, ORIGIN, DIMS, SIGN, TOLERANCE, GRADIENT, GOAL, LINK_R, LINK_T = 0, 9, 18, 21, 24, 25, 26, 27, 30, 39
TERM_ROW = 42


def volume_term(
    shape: int, dims: Vec, sign: float, frame: Rows, frame_t: Rows, origin: Vec, p: Vec, with_grad: bool
) -> tuple[float, Vec]:
    """A volume's margin (sign: +1 inside, -1 outside) with its link at world point p, and (if
    `with_grad`) its gradient with respect to p."""
    value, grad = shape_distance(shape, dims, in_frame(frame_t, origin, p))
    if not with_grad:
        return sign * value, (0.0, 0.0, 0.0)
    x, y, z = times(frame, grad)
    return sign * value, (sign * x, sign * y, sign * z)


def beyond_tolerance(angle: float, tolerance: float, gradient: float, goal: Vec, p: Vec) -> tuple[float, Vec]:
    """An orientation's margin: its error angle beyond the tolerance, widened by `gradient` per
    metre of its link (at p) from `goal` (0: a fixed tolerance); with its gradient w.r.t. p."""
    if gradient > 0.0:
        widened, pull = widening(gradient, goal, p)
        return angle - tolerance - widened, pull
    return angle - tolerance, (0.0, 0.0, 0.0)


def _rows3(f: np.ndarray, at: int) -> Rows:
    return (f[at], f[at + 1], f[at + 2]), (f[at + 3], f[at + 4], f[at + 5]), (f[at + 6], f[at + 7], f[at + 8])


def _vec3(f: np.ndarray, at: int) -> Vec:
    return f[at], f[at + 1], f[at + 2]


def _joint_rows(rotation: np.ndarray, j: int) -> Rows:
    """Joint j's world rotation, of the joints' (J, 3, 3), as rows."""
    return (
        (rotation[j, 0, 0], rotation[j, 0, 1], rotation[j, 0, 2]),
        (rotation[j, 1, 0], rotation[j, 1, 1], rotation[j, 1, 2]),
        (rotation[j, 2, 0], rotation[j, 2, 1], rotation[j, 2, 2]),
    )


def _row_times(row: Vec, m: Rows) -> Vec:
    """A row vector times a 3x3 matrix given by rows (a row of a matrix product)."""
    return (
        row[0] * m[0][0] + row[1] * m[1][0] + row[2] * m[2][0],
        row[0] * m[0][1] + row[1] * m[1][1] + row[2] * m[2][1],
        row[0] * m[0][2] + row[1] * m[1][2] + row[2] * m[2][2],
    )


def _link_pose(r: np.ndarray, o: np.ndarray, f: np.ndarray) -> tuple[Rows, Vec]:
    """A term's link in the world: its joint's world rotation r (3x3) and origin o times the
    link's placement on the joint (the term's LINK_R, LINK_T)."""
    joint = (r[0, 0], r[0, 1], r[0, 2]), (r[1, 0], r[1, 1], r[1, 2]), (r[2, 0], r[2, 1], r[2, 2])
    m = _rows3(f, LINK_R)
    x, y, z = times(joint, _vec3(f, LINK_T))
    return (_row_times(joint[0], m), _row_times(joint[1], m), _row_times(joint[2], m)), (o[0] + x, o[1] + y, o[2] + z)


def _term(kind: int, axis: int, f: np.ndarray, rotation: Rows, p: Vec, with_grad: bool) -> tuple[float, Vec, Vec]:
    """A term's margin with its link at (rotation, p), and (if `with_grad`) its gradient w.r.t.
    the link's world linear and angular velocity: the evaluator's `_Volume` and one-free-axis
    `_Orientation`, formula for formula."""
    frame_t = _rows3(f, FRAME_T)
    if kind == TILT:
        angle, grad = axis_angle(
            times(frame_t, (rotation[0][axis], rotation[1][axis], rotation[2][axis])), _vec3(f, DIMS)
        )
        margin, pull = beyond_tolerance(angle, f[TOLERANCE], f[GRADIENT], _vec3(f, GOAL), p)
        return margin, pull, (times(_rows3(f, FRAME), grad) if with_grad else (0.0, 0.0, 0.0))
    margin, linear = volume_term(
        kind, _vec3(f, DIMS), f[SIGN], _rows3(f, FRAME), frame_t, _vec3(f, ORIGIN), p, with_grad
    )
    return margin, linear, (0.0, 0.0, 0.0)


def term_margins(
    joint_rotation: np.ndarray, joint_origin: np.ndarray, ints: np.ndarray, floats: np.ndarray, out: np.ndarray
) -> None:
    """out[n, k]: term k's margin at state n, given every joint's world rotation (N, J, 3, 3) and
    origin (N, J, 3) there; the terms' KIND, JOINT, AXIS ints and TERM_ROW floats."""
    for n in range(out.shape[0]):
        for k in range(ints.shape[0]):
            j = ints[k, JOINT]
            rotation, p = _link_pose(joint_rotation[n, j], joint_origin[n, j], floats[k])
            out[n, k] = _term(ints[k, KIND], ints[k, AXIS], floats[k], rotation, p, False)[0]


def term_gradients(
    joint_rotation: np.ndarray,
    joint_origin: np.ndarray,
    ints: np.ndarray,
    floats: np.ndarray,
    columns: np.ndarray,
    axes: np.ndarray,
    carries: np.ndarray,
    margins: np.ndarray,
    gradients: np.ndarray,
) -> None:
    """At one state (joints' world rotations (J, 3, 3) and origins (J, 3)): margins[k] and
    gradients[k, c], term k's derivative along planned joint c (`gradient_row`)."""
    for k in range(ints.shape[0]):
        margins[k] = gradient_row(joint_rotation, joint_origin, ints, floats, columns, axes, carries, k, gradients)


def rows_gradients(
    joint_rotation: np.ndarray,
    joint_origin: np.ndarray,
    ints: np.ndarray,
    floats: np.ndarray,
    columns: np.ndarray,
    axes: np.ndarray,
    carries: np.ndarray,
    rows: np.ndarray,
    count: int,
    gradients: np.ndarray,
) -> None:
    """`term_gradients`' rows rows[:count] only (the others' gradients[k] left as they were): a
    Newton step solves on the rows near their band, ~1-2 of MADAR's 4, and has their margins."""
    for r in range(count):
        gradient_row(joint_rotation, joint_origin, ints, floats, columns, axes, carries, rows[r], gradients)


def gradient_row(
    joint_rotation: np.ndarray,
    joint_origin: np.ndarray,
    ints: np.ndarray,
    floats: np.ndarray,
    columns: np.ndarray,
    axes: np.ndarray,
    carries: np.ndarray,
    k: int,
    gradients: np.ndarray,
) -> float:
    """Term k's margin, with gradients[k, c], its derivative along planned joint c: its velocity
    gradient times the link's Jacobian column (world axis a, lever a x (p - joint origin); a
    sliding joint moves it along a). columns[c]: the joint and 1 if it slides; axes[c]: its axis
    in its own frame; carries[k, c]: 1 if joint c moves term k's link."""
    j = ints[k, JOINT]
    rotation, p = _link_pose(joint_rotation[j], joint_origin[j], floats[k])
    margin, linear, angular = _term(ints[k, KIND], ints[k, AXIS], floats[k], rotation, p, True)
    for c in range(columns.shape[0]):
        if carries[k, c] == 0:
            gradients[k, c] = 0.0
            continue
        i = columns[c, 0]
        # Read by index, not through r[i].reshape(9): numba's reshape is a call into its runtime,
        # which made a row cost ~0.19 us instead of ~0.11 (MADAR's peg-in-hole).
        a = times(_joint_rows(joint_rotation, i), (axes[c, 0], axes[c, 1], axes[c, 2]))
        if columns[c, 1] == 1:
            gradients[k, c] = linear[0] * a[0] + linear[1] * a[1] + linear[2] * a[2]
            continue
        lever = cross(a, (p[0] - joint_origin[i, 0], p[1] - joint_origin[i, 1], p[2] - joint_origin[i, 2]))
        gradients[k, c] = (
            linear[0] * lever[0]
            + linear[1] * lever[1]
            + linear[2] * lever[2]
            + angular[0] * a[0]
            + angular[1] * a[1]
            + angular[2] * a[2]
        )
    return margin


# What compiled.py compiles, callees before their callers: scalar code only (no numpy calls, no pinocchio).
COMPILED = (
    "times",
    "in_frame",
    "cross",
    "box_sd",
    "sphere_sd",
    "_radial",
    "_lift",
    "cylinder_sd",
    "_closest_on_segment",
    "cone_sd",
    "shape_distance",
    "widening",
    "axis_angle",
    "volume_term",
    "beyond_tolerance",
    "_rows3",
    "_vec3",
    "_joint_rows",
    "_row_times",
    "_link_pose",
    "_term",
    "term_margins",
    "gradient_row",
    "term_gradients",
    "rows_gradients",
)
