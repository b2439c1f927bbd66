"""Everything a user wrote, checked against the ontology before any reasoner sees it.

Kinds, robot and arms, rule predicates and the situation's assertions must be terms of the
ontology; each mistake is a one-line error naming it. Both reasoners rely on these checks.
"""

from __future__ import annotations

from collections.abc import Sequence

from hriplan import HriplanError
from hriplan.ontology.assertions import TYPE, Assertion, arm_individual
from hriplan.ontology.ruleset import Name, Rule
from hriplan.ontology.schema import Schema
from hriplan.ontology.situation import Situation


def check_input(schema: Schema, situation: Situation, rules: Sequence[Rule], assertions: Sequence[Assertion]) -> None:
    _check_situation(schema, situation)
    for rule in rules:
        _check_rule(schema, rule)
    _check_assertions(schema, assertions)


def _check_situation(schema: Schema, situation: Situation) -> None:
    robots, facts = schema.instances("Robot"), schema.individuals
    if situation.robot not in robots:
        raise HriplanError(f"unknown robot {situation.robot!r}; the ontology knows: {', '.join(robots)}")
    arms = [str(a) for a in facts.get(situation.robot, "hasArm")]
    for arm in situation.task.arms:
        if arm_individual(situation.robot, arm) not in arms:
            names = sorted(str(v) for a in arms for v in facts.get(a, "hasArmName"))
            raise HriplanError(f"robot {situation.robot!r} has no arm {arm!r}; arms: {', '.join(names)}")
    _check_kind(schema, "task", situation.task.name, situation.task.kind, "Task")
    for obj in situation.objects:
        _check_kind(schema, "object", obj.name, obj.kind, "PhysicalObject")
    for name in [situation.task.name, *(o.name for o in situation.objects), *(h.name for h in situation.humans)]:
        if name in schema.terms:
            raise HriplanError(
                f"the name {name!r} is a term of the ontology; give the situation's {name!r} another name"
            )


def _check_kind(schema: Schema, what: str, name: str, kind: str, root: str) -> None:
    if not schema.is_subclass(kind, root):
        raise HriplanError(
            f"{what} {name!r} has kind {kind!r}, not a {root} class of the ontology; "
            f"known: {', '.join(schema.descendants(root))}"
        )


def _check_rule(schema: Schema, rule: Rule) -> None:
    where = f"{rule.source}: rule {rule.name!r}"
    for atom in (*rule.body, *rule.head):
        for arg in atom.args:
            if isinstance(arg, Name) and arg.name not in schema.individuals.types:
                raise HriplanError(f"{where}: {arg.name!r} is not an individual of the hriplan ontology")
        if atom.builtin:
            continue
        if atom.predicate in schema.classes:
            expected = 1
        elif atom.predicate in schema.super_properties:
            expected = 2
        else:
            raise HriplanError(f"{where}: {atom.predicate!r} is not a class or property of the hriplan ontology")
        if len(atom.args) != expected:
            raise HriplanError(f"{where}: {atom.predicate} takes {expected} argument(s), got {len(atom.args)}")


def _check_assertions(schema: Schema, assertions: Sequence[Assertion]) -> None:
    own = {str(s) for s, p, _ in assertions if p == TYPE}
    for subject, _, cls in (a for a in assertions if a[1] == TYPE):
        if cls not in schema.classes:
            raise HriplanError(f"fact ({subject}, a, {cls}): {cls!r} is not a class of the ontology")
    for fact in (a for a in assertions if a[1] != TYPE):
        subject, prop, value = fact
        if prop not in schema.super_properties:
            raise HriplanError(f"fact {fact}: {prop!r} is not a property of the ontology")
        for name in [subject, value] if prop in schema.object_properties else [subject]:
            if not (isinstance(name, str) and (name in own or name in schema.individuals.types)):
                raise HriplanError(
                    f"fact {fact}: {name!r} is neither in the situation nor an individual of the ontology"
                )
