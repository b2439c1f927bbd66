"""Derived constraints in plain words: what each one does, and why it is there (from a
derivation, or read back from a trajectory file, which keeps each constraint's origin)."""

from __future__ import annotations

from hriplan.planner.constraints.words import describe
from hriplan.planner.trajectory import ConstraintOrigin, ResolvedConstraint, TrajectoryFile
from hriplan.rules.infer import Derivation, DerivedConstraint, DerivedVelocityScale


def explain(item: Derivation | TrajectoryFile | ConstraintOrigin) -> str:
    """A few lines per constraint: what it does, the rationale, the rules and the facts."""
    if isinstance(item, Derivation):
        parts = [explain(c) for c in item.constraints] + [explain(v) for v in item.velocity]
        parts.append(f"velocity scale for the trajectory: {item.velocity_scale:g}")
        return "\n\n".join(parts)
    if isinstance(item, TrajectoryFile):
        parts = [explain(c) for c in item.constraints]
        parts.append(f"velocity scale for the trajectory: {item.report.velocity_scale:g}")
        return "\n\n".join(parts)
    if isinstance(item, DerivedConstraint):
        title = f"{item.spec.id} (arm {item.arm}): {describe(item.spec)}"
    elif isinstance(item, ResolvedConstraint):
        title = f"{item.spec.id}: {describe(item.spec)}"
        if not item.kind:
            return f"{title}\n  no rule made it (a planning problem's constraint)"
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
