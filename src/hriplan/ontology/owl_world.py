"""An owlready2 World for one situation: the ontology, the rules and the situation's facts.

Each situation gets a fresh World (never owlready2's default world), so situations never leak
into each other and a World is dropped once its facts are extracted. What a user wrote (kinds,
arms, rule predicates, extra facts) was checked against the ontology before (`checks`).
"""

from __future__ import annotations

import io
from collections.abc import Sequence

import owlready2
from owlready2 import ObjectPropertyClass

from hriplan import HriplanError
from hriplan.ontology.assertions import TYPE, Assertion
from hriplan.ontology.ruleset import Rule
from hriplan.ontology.vocabulary import (
    NAMESPACE,
    ONTOLOGY_IRI,
    RULES_NAMESPACE,
    SITUATION_NAMESPACE,
    OntologySource,
)


def build_world(source: OntologySource, rules: Sequence[Rule], assertions: Sequence[Assertion]) -> owlready2.World:
    """A World holding the ontology, the rules as SWRL and the situation's individuals."""
    world = owlready2.World()
    ontology = world.get_ontology(ONTOLOGY_IRI).load(fileobj=io.BytesIO(source.ntriples), format="ntriples")
    hp = world.get_namespace(NAMESPACE)
    situation_ontology = world.get_ontology(SITUATION_NAMESPACE)
    situation_ontology.imported_ontologies.append(ontology)
    _add_rules(rules, situation_ontology, hp)
    _add_assertions(assertions, situation_ontology, hp)
    return world


def _add_rules(rules: Sequence[Rule], ontology: owlready2.Ontology, hp: owlready2.Namespace) -> None:
    namespace = ontology.get_namespace(RULES_NAMESPACE)
    for rule in rules:
        with ontology:
            imp = owlready2.Imp(rule.name, namespace=namespace)
            try:
                imp.set_as_rule(rule.swrl(), namespaces=[hp])
            except (ValueError, AttributeError, LookupError) as exc:  # owlready2's parser errors
                raise HriplanError(f"{rule.source}: rule {rule.name!r}: {exc}") from None
            imp.label = [rule.name]
            imp.comment = [rule.rationale]


def _add_assertions(assertions: Sequence[Assertion], ontology: owlready2.Ontology, hp: owlready2.Namespace) -> None:
    own = ontology.get_namespace(SITUATION_NAMESPACE)
    with ontology:
        for subject, _, cls_name in (a for a in assertions if a[1] == TYPE):
            cls = hp[str(cls_name)]
            existing = own[subject]
            if existing is None:
                cls(subject, namespace=own)
            elif cls not in existing.is_a:
                existing.is_a.append(cls)
        for subject, prop_name, value in (a for a in assertions if a[1] != TYPE):
            prop = hp[prop_name]
            if isinstance(prop, ObjectPropertyClass):
                prop[own[subject] or hp[subject]].append(own[value] or hp[value])
            else:
                prop[own[subject] or hp[subject]].append(value)
