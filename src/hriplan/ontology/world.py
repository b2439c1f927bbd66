"""An owlready2 World for one situation: the ontology, the rules and the situation's facts.

Each situation gets a fresh World (never owlready2's default world), so situations never leak
into each other and a World is dropped once its facts are extracted. Everything a user wrote
(kinds, arms, rule predicates, extra facts) is checked against the ontology here, with one-line
errors, before the reasoner sees it.
"""

from __future__ import annotations

import io
from collections.abc import Sequence

import owlready2
from owlready2 import DataPropertyClass, ObjectPropertyClass, ThingClass

from hriplan import HriplanError
from hriplan.rules.ruleset import Name, Rule

from .assertions import TYPE, Assertion, arm_individual
from .situation import Situation
from .vocabulary import (
    NAMESPACE,
    ONTOLOGY_IRI,
    RULES_NAMESPACE,
    SITUATION_NAMESPACE,
    OntologySource,
)


def build_world(source: OntologySource, rules: Sequence[Rule], situation: Situation,
                assertions: Sequence[Assertion]) -> owlready2.World:  # fmt: skip
    """A World holding the ontology, the rules as SWRL and the situation's individuals."""
    world = owlready2.World()
    ontology = world.get_ontology(ONTOLOGY_IRI).load(fileobj=io.BytesIO(source.ntriples), format="ntriples")
    hp = world.get_namespace(NAMESPACE)
    situation_ontology = world.get_ontology(SITUATION_NAMESPACE)
    situation_ontology.imported_ontologies.append(ontology)
    _check_situation(situation, hp)
    _add_rules(rules, situation_ontology, hp)
    _add_assertions(assertions, situation_ontology, hp)
    return world


def _check_situation(situation: Situation, hp: owlready2.Namespace) -> None:
    robot, robots = hp[situation.robot], list(hp.Robot.instances())
    if robot not in robots:
        raise HriplanError(f"unknown robot {situation.robot!r}; the ontology knows: {', '.join(sorted(r.name for r in robots))}")
    arms = sorted(str(a.hasArmName) for a in robot.hasArm)
    for arm in situation.task.arms:
        if hp[arm_individual(situation.robot, arm)] not in robot.hasArm:
            raise HriplanError(f"robot {situation.robot!r} has no arm {arm!r}; arms: {', '.join(arms)}")
    _check_kind("task", situation.task.name, situation.task.kind, hp.Task, hp)
    for obj in situation.objects:
        _check_kind("object", obj.name, obj.kind, hp.PhysicalObject, hp)
    individuals = [situation.task.name, *(o.name for o in situation.objects), *(h.name for h in situation.humans)]
    for name in individuals:
        if hp[name] is not None:
            raise HriplanError(f"the name {name!r} is a term of the ontology; give the situation's {name!r} another name")


def _check_kind(what: str, name: str, kind: str, root: ThingClass, hp: owlready2.Namespace) -> None:
    cls = hp[kind]
    if not (isinstance(cls, ThingClass) and issubclass(cls, root)):
        known = sorted(c.name for c in root.descendants() if c is not root)
        raise HriplanError(f"{what} {name!r} has kind {kind!r}, not a {root.name} class of the ontology; known: {', '.join(known)}")


def _add_rules(rules: Sequence[Rule], ontology: owlready2.Ontology, hp: owlready2.Namespace) -> None:
    namespace = ontology.get_namespace(RULES_NAMESPACE)
    for rule in rules:
        _check_rule(rule, hp)
        with ontology:
            imp = owlready2.Imp(rule.name, namespace=namespace)
            try:
                imp.set_as_rule(rule.swrl(), namespaces=[hp])
            except (ValueError, AttributeError, LookupError) as exc:  # owlready2's parser errors
                raise HriplanError(f"{rule.source}: rule {rule.name!r}: {exc}") from None
            imp.label = [rule.name]
            imp.comment = [rule.rationale]


def _check_rule(rule: Rule, hp: owlready2.Namespace) -> None:
    where = f"{rule.source}: rule {rule.name!r}"
    for atom in (*rule.body, *rule.head):
        for arg in atom.args:
            if isinstance(arg, Name) and not isinstance(hp[arg.name], owlready2.Thing):
                raise HriplanError(f"{where}: {arg.name!r} is not an individual of the hriplan ontology")
        if atom.builtin:
            continue
        entity = hp[atom.predicate]
        if isinstance(entity, ThingClass):
            expected = 1
        elif isinstance(entity, ObjectPropertyClass | DataPropertyClass):
            expected = 2
        else:
            raise HriplanError(f"{where}: {atom.predicate!r} is not a class or property of the hriplan ontology")
        if len(atom.args) != expected:
            raise HriplanError(f"{where}: {atom.predicate} takes {expected} argument(s), got {len(atom.args)}")


def _add_assertions(assertions: Sequence[Assertion], ontology: owlready2.Ontology, hp: owlready2.Namespace) -> None:
    own = ontology.get_namespace(SITUATION_NAMESPACE)
    with ontology:
        for subject, _, cls_name in (a for a in assertions if a[1] == TYPE):
            cls = hp[str(cls_name)]
            if not isinstance(cls, ThingClass):
                raise HriplanError(f"fact ({subject}, a, {cls_name}): {cls_name!r} is not a class of the ontology")
            existing = own[subject]
            if existing is None:
                cls(subject, namespace=own)
            elif cls not in existing.is_a:
                existing.is_a.append(cls)
        for fact in (a for a in assertions if a[1] != TYPE):
            subject, prop_name, value = fact
            prop = hp[prop_name]
            if isinstance(prop, ObjectPropertyClass):
                prop[_individual(subject, fact, own, hp)].append(_individual(value, fact, own, hp))
            elif isinstance(prop, DataPropertyClass):
                prop[_individual(subject, fact, own, hp)].append(value)
            else:
                raise HriplanError(f"fact {fact}: {prop_name!r} is not a property of the ontology")


def _individual(name: object, fact: Assertion, own: owlready2.Namespace, hp: owlready2.Namespace) -> owlready2.Thing:
    found = (own[name] or hp[name]) if isinstance(name, str) else None
    if not isinstance(found, owlready2.Thing):
        raise HriplanError(f"fact {fact}: {name!r} is neither in the situation nor an individual of the ontology")
    return found
