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


# A term's row of floats for `term_margins`: its frame's rotation transposed (9, row-major) and
# origin (3); a volume's dims (3) and sign (+1 inside, -1 outside); a tilt's target axis (3, at
# the dims' place), tolerance, tolerance gradient and goal (3).
FRAME_T, ORIGIN, DIMS, SIGN, TOLERANCE, GRADIENT, GOAL = 0, 9, 12, 15, 16, 17, 18
TERM_ROW = 21


def term_margins(
    rotation: np.ndarray, position: np.ndarray, kinds: np.ndarray, links: np.ndarray, rows: np.ndarray, out: np.ndarray
) -> None:
    """out[n, k]: the margin of term k at state n, from its link's world rotation (N, L, 3, 3)
    and position (N, L, 3); kinds[k] a shape code or TILT, links[k] (link, free axis of a tilt),
    rows[k] its TERM_ROW floats. The evaluator's `_Volume` and `_Orientation` margins, formula
    for formula, for many states in one call (compiled: `compiled.py`)."""
    for n in range(rotation.shape[0]):
        for k in range(kinds.shape[0]):
            r, p, f = rotation[n, links[k, 0]], position[n, links[k, 0]], rows[k]
            frame_t = ((f[0], f[1], f[2]), (f[3], f[4], f[5]), (f[6], f[7], f[8]))
            at = (p[0], p[1], p[2])
            if kinds[k] == TILT:
                a = links[k, 1]
                u = times(frame_t, (r[0, a], r[1, a], r[2, a]))
                angle = axis_angle(u, (f[DIMS], f[DIMS + 1], f[DIMS + 2]))[0]
                widened = widening(f[GRADIENT], (f[GOAL], f[GOAL + 1], f[GOAL + 2]), at)[0]
                out[n, k] = angle - f[TOLERANCE] - widened
            else:
                local = in_frame(frame_t, (f[ORIGIN], f[ORIGIN + 1], f[ORIGIN + 2]), at)
                out[n, k] = f[SIGN] * shape_distance(kinds[k], (f[DIMS], f[DIMS + 1], f[DIMS + 2]), local)[0]


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
    "term_margins",
)
