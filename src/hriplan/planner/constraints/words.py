"""A planner constraint in words: one sentence on what it asks of the robot, and a short label.

The one wording shared by `hriplan derive`/`explain` (rules/explain.py, cli/summary.py) and the
viewer's legend and plot titles (when a constraint carries no reason from the rules).
"""

from __future__ import annotations

from collections.abc import Callable

from hriplan.planner.constraints.spec import ConstraintSpec, FrameRef

# A volume's shape in words, by its `type`, given the words for its frame.
SHAPES: dict[str, Callable[[ConstraintSpec, str], str]] = {
    "box": lambda spec, where: f"a {' x '.join(f'{s:.2f}' for s in spec.size)} m box centred at {where}",
    "sphere": lambda spec, where: f"a sphere of radius {spec.radius:g} m centred at {where}",
    "cylinder": lambda spec, where: (
        f"a cylinder of radius {spec.radius:g} m and height {spec.height:g} m standing at {where}"
    ),
    "cone": lambda spec, where: (
        f"a cone of radius {spec.radius:g} m and height {spec.height:g} m with its apex at {where}"
    ),
}


def describe(spec: ConstraintSpec) -> str:
    """One sentence on what a planner constraint asks of the robot."""
    where = _frame(spec.frame)
    if spec.type == "orientation":
        free = f", free to spin about its {'/'.join(spec.free_axes)} axis" if spec.free_axes else ""
        growth = (
            f", widening by {spec.tolerance_gradient:g} rad per metre from the goal" if spec.tolerance_gradient else ""
        )
        return (
            f"{spec.target_link} stays within {spec.tolerance:g} rad of its target orientation in {where}{free}{growth}"
        )
    shape = SHAPES[spec.type](spec, where)
    links = " (and so does every robot link)" if spec.keep_out_all_links else ""
    return f"{spec.target_link} stays {spec.region} {shape}{links}"


def kind(spec: ConstraintSpec) -> str:
    """Short type label: `orientation`, `box inside`, `cylinder keep-out`, ..."""
    if spec.type == "orientation":
        return "orientation"
    region = "keep-out" if spec.keep_out_all_links else spec.region
    return f"{spec.type} {region}"


def _frame(frame: FrameRef) -> str:
    moved = frame.offset.xyz != (0.0, 0.0, 0.0) or frame.offset.rpy is not None or frame.offset.quat_xyzw is not None
    return f"{frame.entity}{' (offset)' if moved else ''}"
