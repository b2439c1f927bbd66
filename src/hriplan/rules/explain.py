"""Derived constraints in plain words: what each one does, and why it is there."""

from __future__ import annotations

from hriplan.planner.constraints.words import describe
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
