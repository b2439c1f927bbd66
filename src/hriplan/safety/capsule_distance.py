"""Capsule-capsule distances and closest points for many pairs at once, in numpy.

Why: the speed and separation monitor needs every robot capsule against every person capsule at
every point of a path (tens of thousands of pairs per timing call). coal answers one pair per
call and reading its results from Python costs far more than the geometry, so the capsule pairs
are computed here in one vectorised pass; other shapes still go through coal. The numbers are
coal's: the signed distance between the capsules (negative when they overlap) and the witness
points on each surface, along the line joining the closest points of the two axes.
"""

from __future__ import annotations

import numpy as np

# Below this squared length (m^2) a capsule's axis is a point (a sphere).
_POINT = 1e-18
# Below this distance (m) between the axes they cross: the direction between them is rounding noise.
_CROSSING = 1e-12
# Relative size of a x e - b^2 below which two axes count as parallel (any closest pair will do).
_PARALLEL = 1e-12


def segment_parameters(d1: np.ndarray, d2: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closest points of segments p1 + s d1 and p2 + t d2, s, t in [0, 1], with r = p1 - p2 (all
    (..., 3)): returns (s, t). Ericson, Real-Time Collision Detection 5.1.9, branch-free; parallel
    and zero-length segments get one of their closest pairs (a zero-length first segment has
    b = c = 0, so the general branches already give s = 0)."""
    a, e = _dot(d1, d1), _dot(d2, d2)
    b, c, f = _dot(d1, d2), _dot(d1, r), _dot(d2, r)
    point1, point2 = a <= _POINT, e <= _POINT
    safe_a, safe_e = np.where(point1, 1.0, a), np.where(point2, 1.0, e)
    denom = a * e - b * b
    parallel = denom <= _PARALLEL * a * e
    s = np.where(parallel, 0.0, np.clip((b * f - c * e) / np.where(parallel, 1.0, denom), 0.0, 1.0))
    t = (b * s + f) / safe_e
    s = np.where(t < 0.0, np.clip(-c / safe_a, 0.0, 1.0), np.where(t > 1.0, np.clip((b - c) / safe_a, 0.0, 1.0), s))
    t = np.clip(t, 0.0, 1.0)
    # The second segment a point (b = f = 0): the first's parameter alone decides.
    s = np.where(point2, np.clip(-c / safe_a, 0.0, 1.0), s)
    return s, t


def capsule_distances(
    centre1: np.ndarray,
    axis1: np.ndarray,
    half1: np.ndarray,
    radius1: np.ndarray,
    centre2: np.ndarray,
    axis2: np.ndarray,
    half2: np.ndarray,
    radius2: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Capsules given by centre and unit axis (..., 3), half length and radius (...), broadcast
    against each other: (signed distance (...), witness point on capsule 1, on capsule 2 (..., 3))."""
    half1, half2 = np.asarray(half1, dtype=float)[..., None], np.asarray(half2, dtype=float)[..., None]
    start1, start2 = centre1 - half1 * axis1, centre2 - half2 * axis2
    d1, d2 = 2.0 * half1 * axis1, 2.0 * half2 * axis2
    s, t = segment_parameters(d1, d2, start1 - start2)
    on1, on2 = start1 + s[..., None] * d1, start2 + t[..., None] * d2
    gap = on2 - on1
    length = np.sqrt(_dot(gap, gap))
    apart = length > _CROSSING
    normal = gap / np.where(apart, length, 1.0)[..., None]
    if not apart.all():  # only crossing axes need a normal of their own (rare: computed for them alone)
        crossing = ~apart
        normal[crossing] = _across(
            np.broadcast_to(axis1, gap.shape)[crossing], np.broadcast_to(axis2, gap.shape)[crossing]
        )
    radius1, radius2 = np.asarray(radius1, dtype=float), np.asarray(radius2, dtype=float)
    return length - radius1 - radius2, on1 + radius1[..., None] * normal, on2 - radius2[..., None] * normal


def _across(axis1: np.ndarray, axis2: np.ndarray) -> np.ndarray:
    """For axes that cross (no direction between them): a unit vector normal to both, so the
    witness points stay on both surfaces (normal to the first if the axes are parallel)."""
    normal = np.cross(axis1, axis2)
    helper = np.where(np.abs(axis1[..., :1]) < 0.9, np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
    normal = np.where(_dot(normal, normal)[..., None] > 1e-12, normal, np.cross(axis1, helper))
    return normal / np.sqrt(_dot(normal, normal))[..., None]


def _dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.einsum("...i,...i->...", u, v)
