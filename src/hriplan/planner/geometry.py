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
    half = np.asarray(size) / 2.0
    q = np.abs(p) - half
    sign = np.where(p >= 0.0, 1.0, -1.0)
    outside = np.maximum(q, 0.0)
    norm = math.sqrt(float(outside @ outside))
    if norm > 0.0:
        return norm, outside / norm * sign
    k = int(np.argmax(q))
    grad = np.zeros(3)
    grad[k] = sign[k]
    return float(q[k]), grad


def sphere_sd(p: np.ndarray, radius: float) -> tuple[float, np.ndarray]:
    norm = math.sqrt(float(p @ p))
    grad = p / norm if norm > _EPS else np.array([0.0, 0.0, 1.0])
    return norm - radius, grad


def _radial(p: np.ndarray) -> tuple[float, np.ndarray]:
    rho = math.hypot(p[0], p[1])
    direction = np.array([p[0] / rho, p[1] / rho, 0.0]) if rho > _EPS else np.array([1.0, 0.0, 0.0])
    return rho, direction


def cylinder_sd(p: np.ndarray, radius: float, height: float) -> tuple[float, np.ndarray]:
    """Cylinder with axis z from z = 0 to z = height."""
    rho, d_rho = _radial(p)
    half = height / 2.0
    q_rho, q_z = rho - radius, abs(p[2] - half) - half
    d_z = np.array([0.0, 0.0, 1.0 if p[2] >= half else -1.0])
    out_rho, out_z = max(q_rho, 0.0), max(q_z, 0.0)
    norm = math.hypot(out_rho, out_z)
    if norm > 0.0:
        return norm, (out_rho * d_rho + out_z * d_z) / norm
    return (q_rho, d_rho) if q_rho >= q_z else (q_z, d_z)


def _closest_on_segment(point: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    t = min(max(float((point - a) @ ab) / float(ab @ ab), 0.0), 1.0)
    return a + t * ab


def cone_sd(p: np.ndarray, radius: float, height: float) -> tuple[float, np.ndarray]:
    """Solid cone, apex at the origin, opening along +z, radius `radius` at z = height.

    In the (rho, z) half-plane the solid is the triangle (0,0), (r,h), (0,h); its boundary there
    is the slant edge and the top edge (the axis is not a boundary)."""
    rho, d_rho = _radial(p)
    point = np.array([rho, p[2]])
    apex, rim, top = np.array([0.0, 0.0]), np.array([radius, height]), np.array([0.0, height])
    candidates = [_closest_on_segment(point, apex, rim), _closest_on_segment(point, rim, top)]
    closest = min(candidates, key=lambda c: float((point - c) @ (point - c)))
    delta = point - closest
    dist = math.sqrt(float(delta @ delta))
    inside = 0.0 <= p[2] <= height and rho * height <= radius * p[2]
    if dist < _EPS:  # on the boundary: use the outward normal of the nearer edge
        normal = np.array([height, -radius]) / math.hypot(radius, height) if p[2] < height else np.array([0.0, 1.0])
        return 0.0, normal[0] * d_rho + normal[1] * np.array([0.0, 0.0, 1.0])
    grad2 = delta / dist * (-1.0 if inside else 1.0)
    grad = grad2[0] * d_rho + grad2[1] * np.array([0.0, 0.0, 1.0])
    return (-dist if inside else dist), grad


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
    angle = math.atan2(sine, float(u @ v))
    grad = cross_vu / sine if sine > _EPS else np.zeros(3)
    return angle, grad


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
