"""Constraints as things to see: volumes in their frames and orientation glyphs at the link.

Geometry follows `planner/constraints/spec.py` exactly: box and sphere centred on the frame, cylinder from
z = 0 to z = h, cone with its apex at the frame origin opening along +z. An orientation
constraint is drawn at its link, oriented like its target: a shaft along each constrained axis
with its tolerance cone (widening with the distance to the goal for a dynamic tolerance), or a
wedge of +-tolerance for a limited twist; the link's own axes move with it.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence

import meshcat.geometry as mg
import numpy as np
import pinocchio as pin

from hriplan.planner.constraints.spec import (
    BoxConstraint,
    ConeConstraint,
    CylinderConstraint,
    OrientationConstraint,
    SphereConstraint,
)
from hriplan.planner.trajectory import ResolvedConstraint
from hriplan.viewer.drawing import Drawing, material
from hriplan.viewer.shapes import Y_TO_Z, Frustum, Part, translation

# Per region a few shades, so that overlapping volumes of one kind stay apart.
INSIDE = (0x2CA02C, 0x17BECF, 0x9ACD32)
OUTSIDE = (0xFF7F0E, 0xFFB000, 0xE377C2)
KEEP_OUT = (0xD62728, 0xA0144A, 0xFF5A36)
ORIENTATION, LINK_AXIS = 0xE6B800, 0x2747D8
GLYPH_LENGTH = 0.15  # m
MAX_CONE_ANGLE = math.radians(80)  # wider tolerance cones are drawn at this angle


def colors(constraints: Sequence[ResolvedConstraint]) -> dict[str, int]:
    """The colour each constraint is drawn in (the legend uses them too)."""
    used: Counter[tuple[int, ...]] = Counter()
    out = {}
    for c in constraints:
        spec = c.spec
        if isinstance(spec, OrientationConstraint):
            out[spec.id] = ORIENTATION
            continue
        shades = INSIDE if spec.region == "inside" else KEEP_OUT if spec.keep_out_all_links else OUTSIDE
        out[spec.id] = shades[used[shades] % len(shades)]
        used[shades] += 1
    return out


def draw_volume(drawing: Drawing, path: str, constraint: ResolvedConstraint, color: int) -> None:
    spec = constraint.spec
    drawing.place(path, constraint.frame_in_world.se3())
    opacity = 0.2 if spec.region == "inside" else 0.3
    drawing.draw(path, [_volume_part(spec)], material(color, opacity))


def _volume_part(spec: object) -> Part:
    if isinstance(spec, BoxConstraint):
        return Part(mg.Box(list(spec.size)), np.eye(4))
    if isinstance(spec, SphereConstraint):
        return Part(mg.Sphere(spec.radius), np.eye(4))
    upright = translation((0.0, 0.0, spec.height / 2)) @ Y_TO_Z  # from z = 0 to z = h
    if isinstance(spec, CylinderConstraint):
        return Part(Frustum(spec.height, spec.radius, spec.radius), upright)
    if isinstance(spec, ConeConstraint):
        return Part(Frustum(spec.height, spec.radius, 0.0), upright)  # radius 0 at the apex (z = 0)
    raise TypeError(type(spec).__name__)


def _along(axis: int) -> np.ndarray:
    """Rotation taking three.js's y (a cylinder's axis) to `axis`, and z to the next axis."""
    e = np.eye(3)
    rotation = np.eye(4)
    rotation[:3, :3] = np.column_stack([e[(axis + 2) % 3], e[axis], e[(axis + 1) % 3]])
    return rotation


def constrained_axes(spec: OrientationConstraint) -> list[int]:
    """The axes whose direction the glyph shows: the free axis, all three, or (two free axes) the
    one next to the restricted axis, whose turn about it measures the twist."""
    free = ["xyz".index(a) for a in spec.free_axes]
    if len(free) == 2:
        (restricted,) = {0, 1, 2} - set(free)
        return [(restricted + 1) % 3]
    return free or [0, 1, 2]


def draw_orientation(
    drawing: Drawing,
    path: str,
    constraint: ResolvedConstraint,
    link_poses: Sequence[pin.SE3],
    tolerances: Sequence[float],
) -> None:
    """The glyph at the link in every animation frame; `tolerances` per frame (dynamic tolerance)."""
    spec = constraint.spec
    target = pin.SE3(constraint.frame_in_world.rotation() @ spec.target.rotation(), link_poses[0].translation)
    drawing.place(path, target)
    if len(link_poses) > 1:
        drawing.animate(path, "position", [pose.translation for pose in link_poses])
    angles = np.minimum(np.asarray(tolerances, dtype=float), MAX_CONE_ANGLE)
    widest = max(float(angles.max()), 1e-3)  # cones are drawn at this angle and scaled down per frame
    glyph = material(ORIENTATION, 0.35)
    shaft = material(ORIENTATION)
    length = GLYPH_LENGTH
    for axis in constrained_axes(spec):
        drawing.draw(f"{path}/{'xyz'[axis]}/shaft", [_shaft(axis, length)], shaft)
        if len(spec.free_axes) == 2:  # a wedge of +-tolerance about the restricted axis
            wedge = Frustum(0.004, length, length, theta_start=-angles[0], theta_length=2 * angles[0])
            drawing.draw(f"{path}/twist", [Part(wedge, _along((axis + 2) % 3))], glyph)
            continue
        along = translation(np.eye(3)[axis] * length / 2) @ _along(axis)
        cone = f"{path}/{'xyz'[axis]}/cone"
        drawing.draw(cone, [Part(Frustum(length, length * math.tan(widest), 0.0), along)], glyph)
        if len(link_poses) > 1 and spec.tolerance_gradient > 0:
            scale = np.tan(angles) / math.tan(widest)
            drawing.animate(f"{cone}/0", "scale", [(s, 1.0, s) for s in scale])


def _shaft(axis: int, length: float) -> Part:
    """A thin rod from the origin along `axis`."""
    return Part(Frustum(length, 0.004, 0.004, segments=12), translation(np.eye(3)[axis] * length / 2) @ _along(axis))


def link_axes(drawing: Drawing, path: str, spec: OrientationConstraint, link_poses: Sequence[pin.SE3]) -> None:
    """The link's own constrained axes, moving with it: they stay in the target's cones."""
    drawing.place(path, link_poses[0])
    if len(link_poses) > 1:
        drawing.animate_poses(path, link_poses)
    for axis in constrained_axes(spec):
        drawing.draw(f"{path}/{'xyz'[axis]}", [_shaft(axis, GLYPH_LENGTH * 1.1)], material(LINK_AXIS))
