"""Conservative primitives that contain a point cloud (mesh vertices): capsules and boxes.

Collision checks on capsules are several times faster than on meshes, and distances about a
hundred times faster (a UR5's pairs: 4.8 us on capsules, 1.2 ms on meshes); meshes stay for display.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from hriplan.robots.spatial import cross


def frame_with_z(axis: np.ndarray) -> np.ndarray:
    """A rotation whose z column is `axis` (unit)."""
    z = axis / np.linalg.norm(axis)
    helper = (1.0, 0.0, 0.0) if abs(z[0]) < 0.9 else (0.0, 1.0, 0.0)
    x = np.array(cross(helper, z.tolist()))
    x /= np.linalg.norm(x)
    return np.column_stack([x, cross(z.tolist(), x.tolist()), z])


def _capsule_along(
    pts: np.ndarray, centre: np.ndarray, axis: np.ndarray, padding: float
) -> tuple[float, float, pin.SE3]:
    rot = frame_with_z(axis)
    local = (pts - centre) @ rot
    across = (local[:, :2].min(axis=0) + local[:, :2].max(axis=0)) / 2.0
    local[:, :2] -= across
    rho = np.linalg.norm(local[:, :2], axis=1)
    radius = float(rho.max()) + padding
    reach = np.sqrt(np.maximum(radius**2 - rho**2, 0.0))
    # Every point must lie within `radius` of the segment [bottom, top] on the axis.
    low, high = float((local[:, 2] - reach).max()), float((local[:, 2] + reach).min())
    bottom, top = min(high, low), max(high, low)
    offset = centre + rot @ np.array([across[0], across[1], (bottom + top) / 2.0])
    return radius, top - bottom, pin.SE3(rot, offset)


def fit_capsule(points: np.ndarray, padding: float = 0.0) -> tuple[float, float, pin.SE3]:
    """(radius, cylinder length, placement with z along the axis) of a capsule containing `points`.

    Tries the three principal directions of the points as the axis (through the centre of the
    bounding rectangle across it) and keeps the capsule of least volume."""
    pts = np.asarray(points, dtype=float)
    centre = pts.mean(axis=0)
    _, _, vt = np.linalg.svd(pts - centre, full_matrices=False)
    candidates = [_capsule_along(pts, centre, axis, padding) for axis in vt]
    return min(candidates, key=lambda c: np.pi * c[0] ** 2 * (c[1] + 4.0 * c[0] / 3.0))


def fit_box(points: np.ndarray, padding: float = 0.0) -> tuple[np.ndarray, pin.SE3]:
    """(size, placement) of the axis-aligned box (in the points' frame) containing `points`."""
    pts = np.asarray(points, dtype=float)
    low, high = pts.min(axis=0) - padding, pts.max(axis=0) + padding
    return high - low, pin.SE3(np.eye(3), (low + high) / 2.0)


def capsule_contains(radius: float, length: float, placement: pin.SE3, points: np.ndarray) -> np.ndarray:
    """Per point: inside the capsule (used by tests and by fit checks)."""
    local = (np.asarray(points) - placement.translation) @ placement.rotation
    z = np.clip(local[:, 2], -length / 2.0, length / 2.0)
    return np.linalg.norm(local - np.column_stack([np.zeros_like(z), np.zeros_like(z), z]), axis=1) <= radius + 1e-9
