"""Which robot part can never reach which scene shape, whatever the joints do.

Why: a collision check loops over its pairs in C++, and most of them are a robot part against a
person's capsules (16 per person) or an obstacle beyond that part's reach: 112 of a UR5 scene's
138 pairs, 528 of MADAR's 887. Such a pair can be left out of the check exactly.

A part on a chain of revolute (or spherical) joints turns about fixed points: the chain's first
joint's origin never moves, and each later origin stays as far from the one before as its
joint placement says. So the part stays inside a sphere about that first origin whose radius is
the sum of those distances plus the part's own reach from its joint (its bounding box's centre
and radius). A part on the fixed base stays inside its own bounding sphere. A chain with any
other joint (prismatic, free-flyer, planar, mimic) bounds nothing: its parts are never left out.

A scene shape is bounded by a core and a radius: a segment for capsules, cylinders and spheres
(the capsule around a cylinder holds it), an oriented box for boxes, a point for anything else
(its bounding sphere). A pair is out of reach when the sphere's centre is farther from the core
than both radii and CLEARANCE together.
"""

from __future__ import annotations

from dataclasses import dataclass

import coal
import numpy as np
import pinocchio as pin

# Beyond both radii (m): the pair is left out only this much farther than touching (float noise).
CLEARANCE = 1e-3
# Joints that turn about their own origin: the origin stays where the parent puts it.
_TURNING = {
    "JointModelRX",
    "JointModelRY",
    "JointModelRZ",
    "JointModelRevoluteUnaligned",
    "JointModelRUBX",
    "JointModelRUBY",
    "JointModelRUBZ",
    "JointModelRevoluteUnboundedUnaligned",
    "JointModelSpherical",
    "JointModelSphericalZYX",
}


def reach_sphere(model: pin.Model, part: pin.GeometryObject) -> tuple[np.ndarray, float]:
    """(centre in the world, radius) of a sphere `part` never leaves at any configuration of
    `model`; radius inf if its chain has a joint that moves its origin."""
    chain = []
    joint = part.parentJoint
    while joint:
        chain.append(joint)
        joint = model.parents[joint]
    centre, radius = bounding_sphere(part)  # in the part's joint frame
    if not chain:
        return centre, radius
    chain.reverse()
    if any(model.joints[j].shortname() not in _TURNING for j in chain):
        return np.zeros(3), np.inf
    # The first joint's parent is the world: its origin is its placement's translation.
    lever = sum(float(np.linalg.norm(model.jointPlacements[j].translation)) for j in chain[1:])
    return model.jointPlacements[chain[0]].translation.copy(), lever + float(np.linalg.norm(centre)) + radius


def bounding_sphere(shape: pin.GeometryObject) -> tuple[np.ndarray, float]:
    """Centre (in the shape's joint frame) and radius of a sphere holding the shape (coal's, about
    its local bounding box's centre)."""
    geometry = shape.geometry.clone()  # computing the box on the model's own shape would change it
    geometry.computeLocalAABB()
    return shape.placement.act(np.asarray(geometry.aabb_center, dtype=float)), float(geometry.aabb_radius)


@dataclass(frozen=True)
class ShapeBounds:
    """Scene shapes as cores and radii, in the world: segments (start, end, radius) and boxes
    (centre, rotation, half sizes); `index` says which shape each row is."""

    segment_index: np.ndarray  # (s,)
    start: np.ndarray  # (s, 3)
    end: np.ndarray  # (s, 3)
    radius: np.ndarray  # (s,)
    box_index: np.ndarray  # (b,)
    centre: np.ndarray  # (b, 3)
    rotation: np.ndarray  # (b, 3, 3)
    half: np.ndarray  # (b, 3)

    @classmethod
    def of(cls, shapes: list[pin.GeometryObject]) -> ShapeBounds:
        """The shapes where they are placed now (their placements are in the world)."""
        segments, boxes = [], []
        for k, shape in enumerate(shapes):
            geometry, placement = shape.geometry, shape.placement
            if isinstance(geometry, coal.Box):
                boxes.append((k, placement.translation, placement.rotation, np.asarray(geometry.halfSide)))
                continue
            if isinstance(geometry, (coal.Capsule, coal.Cylinder)):
                half, radius = geometry.halfLength, geometry.radius
                centre = placement.translation
            elif isinstance(geometry, coal.Sphere):
                half, radius, centre = 0.0, geometry.radius, placement.translation
            else:
                half = 0.0
                centre, radius = bounding_sphere(shape)
            axis = placement.rotation[:, 2] * half
            segments.append((k, centre - axis, centre + axis, radius))
        return cls(
            np.array([k for k, *_ in segments], dtype=int),
            np.array([s for _, s, _, _ in segments]).reshape(-1, 3),
            np.array([e for _, _, e, _ in segments]).reshape(-1, 3),
            np.array([r for *_, r in segments], dtype=float),
            np.array([k for k, *_ in boxes], dtype=int),
            np.array([c for _, c, _, _ in boxes]).reshape(-1, 3),
            np.array([r for _, _, r, _ in boxes]).reshape(-1, 3, 3),
            np.array([h for *_, h in boxes]).reshape(-1, 3),
        )


def out_of_reach(centres: np.ndarray, radii: np.ndarray, shapes: ShapeBounds, count: int) -> np.ndarray:
    """(parts, count) booleans: part i's reach sphere (centres (p, 3), radii (p,)) is farther than
    CLEARANCE from shape j (of `count` shapes in `shapes`)."""
    far = np.zeros((len(centres), count), dtype=bool)
    if shapes.segment_index.size:
        axis = shapes.end - shapes.start  # (s, 3)
        offset = centres[:, None, :] - shapes.start[None]  # (p, s, 3)
        length2 = np.einsum("sj,sj->s", axis, axis)
        t = np.clip(np.einsum("psj,sj->ps", offset, axis) / np.where(length2 > 0.0, length2, 1.0), 0.0, 1.0)
        gap = np.linalg.norm(offset - t[..., None] * axis[None], axis=2) - shapes.radius[None]
        far[:, shapes.segment_index] = gap - radii[:, None] > CLEARANCE
    if shapes.box_index.size:
        local = np.einsum("bji,pbj->pbi", shapes.rotation, centres[:, None, :] - shapes.centre[None])
        gap = np.linalg.norm(np.maximum(np.abs(local) - shapes.half[None], 0.0), axis=2)
        far[:, shapes.box_index] = gap - radii[:, None] > CLEARANCE
    return far
