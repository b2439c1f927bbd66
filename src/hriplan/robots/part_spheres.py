"""Bounding spheres of a geometry model's parts, placed at many robot states at once, and lower
bounds on their distances to capsules.

Why: a figure over a whole path (the closest approach to a person, `CollisionChecker.
closest_human`) or every pair at every point (the ISO/TS 15066 monitor, `safety/person_distance.
py`) needs coal only where a cheap bound cannot rule a pair out: a part lies inside its sphere,
and a sphere's distance to a capsule is its centre's distance to the capsule's axis less both
radii, computed for every state, part and capsule in a few numpy products.
"""

from __future__ import annotations

from collections.abc import Sequence

import coal
import numpy as np
import pinocchio as pin

from hriplan.recent import MadeFor
from hriplan.robots.batch_kinematics import BatchKinematics

# A lower bound is lowered by this (m) to stay below coal's (and rounding's) answer: its GJK stops when the squared
# distance is within 1e-6, ~1e-5 m at 2 cm (the same pair differs by 9e-6 m from another start).
BOUND_TOLERANCE = 1e-4


class PartSpheres:
    """Bounding spheres of some parts of a geometry model, placed at many states at once. Why:
    the closest approach over a path (`CollisionChecker.closest_human`) is one number; a lower
    bound per state rules out most states without measuring any pair of them through coal."""

    @classmethod
    def of(cls, robot_model: pin.Model, model: pin.GeometryModel, parts: Sequence[int]) -> PartSpheres:
        """The one made last for these models and parts, else a new one (~0.3 ms to make)."""
        return _SPHERES.made((robot_model, model), lambda: cls(robot_model, model, parts), tuple(parts))

    def __init__(self, robot_model: pin.Model, model: pin.GeometryModel, parts: Sequence[int]) -> None:
        self.robot_model, self.model = robot_model, model
        objects = model.geometryObjects
        joints = sorted({objects[a].parentJoint for a in parts})
        self._kinematics = BatchKinematics(robot_model, joints)
        self._frame = np.array([joints.index(objects[a].parentJoint) for a in parts], dtype=int)
        spheres = [bounding_sphere(objects[a]) for a in parts]
        self._centre = np.array([c for c, _ in spheres]).reshape(-1, 3, 1)
        self._radius = np.array([r for _, r in spheres])

    def floors(
        self, qs: np.ndarray, centre: np.ndarray, axis: np.ndarray, half: np.ndarray, radius: np.ndarray
    ) -> np.ndarray:
        """Per configuration of `qs` (N, nq), part and capsule (N, P, S): a lower bound on their
        signed distance, the capsules given by centre and unit axis (S, 3), half length and
        radius (S,); less coal's tolerance, so below coal's answer too. A part lies inside its
        sphere, so none of its points is nearer a capsule than the sphere's centre's gap to the
        capsule's axis less both radii; inside a capsule as well (a negative bound)."""
        rotation, origin = self._kinematics.placements(qs)
        placed = (rotation[:, self._frame] @ self._centre)[..., 0] + origin[:, self._frame]
        return axis_gaps(placed, centre, axis, half) - self._radius[:, None] - radius - BOUND_TOLERANCE


_SPHERES: MadeFor[PartSpheres] = MadeFor(8)


def axis_gaps(centre: np.ndarray, p: np.ndarray, a: np.ndarray, half: np.ndarray) -> np.ndarray:
    """Distances (N, P, S) from points `centre` (N, P, 3) to segments of centre `p`, unit axis `a`
    (S, 3) and half length `half` (S,), as products of (N, P, 3) by (3, S), not per pair: the
    squared gaps lose ~1e-15 m^2 to rounding, ~3e-8 m at contact (callers' tolerance is 1e-4)."""
    # With o = c - p and t = clip(o.a, -h, h), the squared gap is |o|^2 - t (2 o.a - t).
    along = centre @ a.T - np.einsum("sj,sj->s", p, a)
    t = np.clip(along, -half, half)
    squared = np.einsum("npj,npj->np", centre, centre)[..., None] + np.einsum("sj,sj->s", p, p)
    squared -= 2.0 * (centre @ p.T) + t * (2.0 * along - t)
    return np.sqrt(np.maximum(squared, 0.0))


def bounding_sphere(part: pin.GeometryObject) -> tuple[np.ndarray, float]:
    """A sphere holding the part's shape (about its local bounding box): centre in the part's
    joint frame, radius."""
    if isinstance(part.geometry, coal.Capsule):  # its own sphere is tighter than its box's
        return part.placement.translation.copy(), float(part.geometry.halfLength + part.geometry.radius)
    centre, radius = box_sphere(part.geometry)
    return part.placement.act(centre), radius


def box_sphere(shape: coal.CollisionGeometry) -> tuple[np.ndarray, float]:
    """A sphere holding `shape` about its local bounding box: centre in the shape's own frame,
    radius. Computed on a copy: computing the box on the model's own shape would change it."""
    shape = shape.clone()
    shape.computeLocalAABB()
    return np.asarray(shape.aabb_center, dtype=float), float(shape.aabb_radius)
