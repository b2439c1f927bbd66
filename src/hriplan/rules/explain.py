"""Derived constraints in plain words: what each one does, and why it is there."""

from __future__ import annotations

from hriplan.planner.constraints.spec import (
    BoxConstraint,
    ConeConstraint,
    ConstraintSpec,
    CylinderConstraint,
    FrameRef,
    OrientationConstraint,
    SphereConstraint,
)
from hriplan.rules.infer import Derivation, Derived, DerivedConstraint, DerivedVelocityScale


def explain(item: Derivation | Derived) -> str:
    """A few lines per constraint: what it does, the rationale, the rules and the facts."""
    if isinstance(item, Derivation):
        parts = [explain(c) for c in item.constraints] + [explain(v) for v in item.velocity]
        parts.append(f"velocity scale for the trajectory: {item.velocity_scale:g}")
        return "\n\n".join(parts)
    if isinstance(item, DerivedConstraint):
        title = f"{item.spec.id} (arm {item.arm}): {describe(item.spec)}"
    else:
        assert isinstance(item, DerivedVelocityScale)
        title = f"velocity scale {item.value:g} while moving {item.anchor}"
    return "\n".join(
        [
            title,
            f"  kind: {item.kind}, about {item.anchor}",
            f"  why: {item.reason}",
            f"  rules: {', '.join(item.rules) or 'none'}",
            f"  facts: {'; '.join(item.facts) or 'none'}",
        ]
    )


def describe(spec: ConstraintSpec) -> str:
    """One sentence on what a planner constraint asks of the robot."""
    where = _frame(spec.frame)
    if isinstance(spec, OrientationConstraint):
        free = f", free to spin about its {'/'.join(spec.free_axes)} axis" if spec.free_axes else ""
        growth = (
            f", widening by {spec.tolerance_gradient:g} rad per metre from the goal" if spec.tolerance_gradient else ""
        )
        return (
            f"{spec.target_link} stays within {spec.tolerance:g} rad of its target orientation in {where}{free}{growth}"
        )
    if isinstance(spec, BoxConstraint):
        shape = f"a {' x '.join(f'{s:.2f}' for s in spec.size)} m box centred at {where}"
    elif isinstance(spec, SphereConstraint):
        shape = f"a sphere of radius {spec.radius:g} m centred at {where}"
    elif isinstance(spec, CylinderConstraint):
        shape = f"a cylinder of radius {spec.radius:g} m and height {spec.height:g} m standing at {where}"
    else:
        assert isinstance(spec, ConeConstraint)
        shape = f"a cone of radius {spec.radius:g} m and height {spec.height:g} m with its apex at {where}"
    links = " (and so does every robot link)" if spec.keep_out_all_links else ""
    return f"{spec.target_link} stays {spec.region} {shape}{links}"


def _frame(frame: FrameRef) -> str:
    moved = frame.offset.xyz != (0.0, 0.0, 0.0) or frame.offset.rpy is not None or frame.offset.quat_xyzw is not None
    return f"{frame.entity}{' (offset)' if moved else ''}"
