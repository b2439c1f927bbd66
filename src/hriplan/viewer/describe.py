"""One line per constraint for legends and plot titles: the rules' reason, else what the spec says.

The reason says why a constraint is there; when a constraint did not come from the rules it has
none, and the fallback states the geometry in words so that the legend is never empty.
"""

from __future__ import annotations

import math

import numpy as np

from hriplan.planner.constraints.spec import (
    BoxConstraint,
    ConeConstraint,
    CylinderConstraint,
    OrientationConstraint,
    SphereConstraint,
)
from hriplan.planner.trajectory import ResolvedConstraint


def kind(spec: object) -> str:
    """Short type label: `orientation`, `box inside`, `cylinder keep-out`, ..."""
    if isinstance(spec, OrientationConstraint):
        return "orientation"
    region = "keep-out" if spec.keep_out_all_links else spec.region
    return f"{spec.type} {region}"


def describe(constraint: ResolvedConstraint) -> str:
    return constraint.reason.strip() or _from_spec(constraint)


def _from_spec(constraint: ResolvedConstraint) -> str:
    spec = constraint.spec
    where = spec.frame.entity
    if isinstance(spec, OrientationConstraint):
        return _orientation(constraint)
    shape = _shape(spec)
    if spec.keep_out_all_links:
        return f"keeps every robot link out of {shape} in the {where} frame"
    verb = "inside" if spec.region == "inside" else "out of"
    return f"keeps {spec.target_link} {verb} {shape} in the {where} frame"


def _shape(spec: object) -> str:
    if isinstance(spec, BoxConstraint):
        return "a {:.2f} x {:.2f} x {:.2f} m box".format(*spec.size)
    if isinstance(spec, SphereConstraint):
        return f"a sphere of radius {spec.radius:.2f} m"
    if isinstance(spec, CylinderConstraint):
        return f"a cylinder of radius {spec.radius:.2f} m and height {spec.height:.2f} m"
    if isinstance(spec, ConeConstraint):
        return f"a cone (apex at the frame, radius {spec.radius:.2f} m at {spec.height:.2f} m)"
    raise TypeError(type(spec).__name__)


def _orientation(constraint: ResolvedConstraint) -> str:
    spec = constraint.spec
    tol = f"{math.degrees(spec.tolerance):.1f} deg"
    widening = ""
    if spec.tolerance_gradient > 0:
        widening = f", {math.degrees(spec.tolerance_gradient) / 100:.2f} deg more per cm from the goal"
    target = constraint.frame_in_world.rotation() @ spec.target.rotation()
    free = spec.free_axes
    link = spec.target_link
    if not free:
        return f"keeps {link}'s orientation within {tol} of its target{widening}"
    if len(free) == 1:
        direction = ", ".join(f"{v:+.2f}" for v in np.round(target[:, "xyz".index(free[0])], 2) + 0.0)
        return (
            f"keeps {link}'s {free[0]} axis within {tol} of ({direction}) in the world{widening}; spin about it is free"
        )
    (restricted,) = sorted(set("xyz") - set(free))
    return f"limits {link}'s twist about its {restricted} axis to {tol}{widening}"
