"""Constraint geometry: signed distances to the volumes and orientation errors, with gradients.

Everything here is pure math on positions, vectors and rotations, so that it can be checked
against finite differences in isolation. Conventions:
- `signed_distance(p) -> (d, grad)`: d > 0 outside the solid, d < 0 inside (minus the depth).
- orientation errors come with their gradient with respect to an angular velocity (the frame
  of that velocity is stated per function).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

_EPS = 1e-12


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product of 3-vectors (np.cross costs ~10 us per call; this ~1 us)."""
    a0, a1, a2 = float(a[0]), float(a[1]), float(a[2])
    b0, b1, b2 = float(b[0]), float(b[1]), float(b[2])
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def box_sd(p: np.ndarray, size: tuple[float, float, float]) -> tuple[float, np.ndarray]:
    # Scalar arithmetic: for 3-vectors it is several times faster than numpy calls.
    x, y, z = float(p[0]), float(p[1]), float(p[2])
    qx, qy, qz = abs(x) - size[0] / 2.0, abs(y) - size[1] / 2.0, abs(z) - size[2] / 2.0
    sx, sy, sz = (1.0 if x >= 0.0 else -1.0), (1.0 if y >= 0.0 else -1.0), (1.0 if z >= 0.0 else -1.0)
    ox, oy, oz = max(qx, 0.0), max(qy, 0.0), max(qz, 0.0)
    norm = math.sqrt(ox * ox + oy * oy + oz * oz)
    if norm > 0.0:
        return norm, np.array([ox * sx / norm, oy * sy / norm, oz * sz / norm])
    if qx >= qy and qx >= qz:
        return qx, np.array([sx, 0.0, 0.0])
    if qy >= qz:
        return qy, np.array([0.0, sy, 0.0])
    return qz, np.array([0.0, 0.0, sz])


def sphere_sd(p: np.ndarray, radius: float) -> tuple[float, np.ndarray]:
    norm = math.sqrt(float(p @ p))
    grad = p / norm if norm > _EPS else np.array([0.0, 0.0, 1.0])
    return norm - radius, grad


def _radial(p: np.ndarray) -> tuple[float, float, float]:
    """(rho, unit radial direction x, y) of a point about the z axis."""
    x, y = float(p[0]), float(p[1])
    rho = math.hypot(x, y)
    return (rho, x / rho, y / rho) if rho > _EPS else (rho, 1.0, 0.0)


def _lift(d_rho: float, d_z: float, cx: float, cy: float) -> np.ndarray:
    """A gradient in the (rho, z) half-plane as a 3-vector."""
    return np.array([d_rho * cx, d_rho * cy, d_z])


def cylinder_sd(p: np.ndarray, radius: float, height: float) -> tuple[float, np.ndarray]:
    """Cylinder with axis z from z = 0 to z = height."""
    rho, cx, cy = _radial(p)
    z, half = float(p[2]), height / 2.0
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
    z = float(p[2])
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


def rotation_angle(r_err: np.ndarray) -> tuple[float, np.ndarray]:
    """Angle of a rotation and its gradient w.r.t. a local (right) angular velocity."""
    log = pin.log3(r_err)
    angle = math.sqrt(float(log @ log))
    grad = log / angle if angle > _EPS else np.zeros(3)
    return angle, grad


def axis_angle(u: np.ndarray, v: np.ndarray) -> tuple[float, np.ndarray]:
    """Angle between unit vectors u (moving) and v (fixed); gradient w.r.t. the angular
    velocity that moves u (du = w x u), in the frame u and v are expressed in."""
    cross_vu = cross(v, u)
    sine = math.sqrt(float(cross_vu @ cross_vu))
    angle = math.atan2(sine, float(u[0] * v[0] + u[1] * v[1] + u[2] * v[2]))
    return angle, (cross_vu / sine if sine > _EPS else np.zeros(3))


def twist_angle(r_err: np.ndarray, axis: np.ndarray) -> tuple[float, np.ndarray]:
    """Twist of a rotation about `axis` (swing-twist decomposition), in (-pi, pi], and its
    gradient w.r.t. a local (right) angular velocity."""
    quat = pin.Quaternion(r_err)
    w, vec = quat.w, np.array([quat.x, quat.y, quat.z])
    if w < 0.0:  # q and -q are the same rotation; keep the twist in (-pi, pi]
        w, vec = -w, -vec
    s, c = float(axis @ vec), w
    angle = 2.0 * math.atan2(s, c)
    norm2 = s * s + c * c
    if norm2 < _EPS:
        return angle, np.zeros(3)
    # dq = q (x) (0, w/2): d(s) = w.(c axis + axis x vec)/2, d(c) = -w.vec/2
    grad = (c * (c * axis + cross(axis, vec)) + s * vec) / norm2
    return angle, grad
