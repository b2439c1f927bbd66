"""Situation in, planner constraints out, each with the rules and facts that required it.

The knowledge base says which constraint kinds apply about which object or person
(`isConstrainedBy`); `instantiate` turns each into the planner's specification and
`provenance` says why. Velocity scaling kinds become a velocity scale, the smallest one
required wins.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from pydantic import BaseModel, Field, ValidationError

from hriplan import HriplanError
from hriplan.ontology.cache import ReasoningCache
from hriplan.ontology.knowledge_base import KnowledgeBase
from hriplan.ontology.situation import Situation
from hriplan.planner.constraints.spec import ConstraintSet, ConstraintSpec
from hriplan.planner.trajectory import ConstraintOrigin
from hriplan.rules.instantiate import Arm, Context, Form, anchored_arms, form_of
from hriplan.rules.provenance import Provenance
from hriplan.safety.policy import situation_policy
from hriplan.safety.separation import SeparationPolicy

CONSTRAINED_BY = "isConstrainedBy"


class Derived(ConstraintOrigin):
    """Something the rules derived, with why (the kind required, what it is about, the rules and
    facts: the origin a trajectory keeps of each of its constraints)."""


class DerivedConstraint(Derived):
    arm: str
    spec: ConstraintSpec


class DerivedVelocityScale(Derived):
    value: float = Field(gt=0.0, le=1.0)


class Derivation(BaseModel):
    """Everything the rules derived for one situation (this is what goes into output JSON)."""

    constraints: list[DerivedConstraint] = Field(default_factory=list)
    velocity: list[DerivedVelocityScale] = Field(default_factory=list)
    separation: SeparationPolicy | None = None  # ISO/TS 15066 speed and separation near people

    @property
    def velocity_scale(self) -> float:
        """The trajectory's velocity scale: the smallest one required, 1 if none."""
        return min((v.value for v in self.velocity), default=1.0)

    def constraint_set(self) -> ConstraintSet:
        return ConstraintSet(constraints=[c.spec for c in self.constraints])


def derive(kb: KnowledgeBase) -> Derivation:
    """Turn every (anchor, kind) the knowledge base concluded into planner terms."""
    ctx = Context(kb.situation, kb.facts)
    provenance = Provenance(kb.rules, kb.facts, kb.assertions, kb.relations, kb.key)
    rationale = {r.name: r.rationale for r in kb.rules}
    several_arms = len(kb.situation.task.arms) > 1
    derivation = Derivation(separation=situation_policy(kb.facts, kb.situation))
    owners: dict[str, str] = {}
    for anchor, kind in _requirements(kb):
        support = provenance.why(anchor, CONSTRAINED_BY, kind)
        why = {
            "kind": kind,
            "anchor": anchor,
            "rules": support.rules,
            "facts": support.facts,
            "reason": " ".join(rationale[r] for r in support.direct) or f"{kind} applies to {anchor}",
        }
        form = form_of(kb.facts, kind)
        if form is None:
            scale = ctx.param(kind, "hasVelocityScale")
            if not 0.0 < scale <= 1.0:
                raise HriplanError(f"{kind} has velocity scale {scale:g} in the ontology; it must be in (0, 1]")
            derivation.velocity.append(DerivedVelocityScale(value=scale, **why))
            continue
        for arm in anchored_arms(ctx, form, kind, anchor):
            cid = f"{kb.facts.one(kind, 'hasIdPrefix')}_{anchor}"
            cid = f"{arm.name}_{cid}" if several_arms else cid
            if cid in owners:
                raise HriplanError(
                    f"{owners[cid]} and {kind} both make constraint {cid!r} for {anchor}; "
                    "the rules require two kinds of the same constraint on one thing"
                )
            owners[cid] = kind
            derivation.constraints.append(
                DerivedConstraint(arm=arm.name, spec=_make(form, ctx, kind, anchor, arm, cid), **why)
            )
    derivation.constraints.sort(key=lambda c: c.spec.id)
    return derivation


def _make(form: Form, ctx: Context, kind: str, anchor: str, arm: Arm, cid: str) -> ConstraintSpec:
    """The planner constraint; parameters the planner refuses (a negative radius) name the kind."""
    try:
        return form.make(ctx, kind, anchor, arm, cid)
    except ValidationError as exc:
        first = exc.errors()[0]
        raise HriplanError(
            f"constraint kind {kind}: {'.'.join(str(p) for p in first['loc'])}: {first['msg']} "
            "(check its parameters in the ontology)"
        ) from None


def _requirements(kb: KnowledgeBase) -> list[tuple[str, str]]:
    situation = kb.situation
    anchors = [situation.task.name, *(o.name for o in situation.objects), *(h.name for h in situation.humans)]
    return [(a, str(kind)) for a in anchors for kind in kb.facts.get(a, CONSTRAINED_BY)]


def infer_constraints(
    situation: Situation,
    *,
    rule_files: Sequence[str | Path] = (),
    ontology: str | Path | None = None,
    cache: ReasoningCache | None = None,
) -> list[DerivedConstraint]:
    """The planner constraints a situation requires, with their provenance."""
    return derive(KnowledgeBase(situation, rule_files=rule_files, ontology=ontology, cache=cache)).constraints
