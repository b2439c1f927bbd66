"""The knowledge base of one situation: reasoned once per qualitative situation, cached, queryable.

Building one computes the relations that depend on numbers (`relations`: near a person, with
thresholds from the ontology), states the situation's qualitative facts, looks them up in the
cache and only on a miss reasons: in process by default (`rule_engine`, no JVM), or with Pellet
(`reasoner="pellet"`, the reference). The cache key holds no coordinate no rule reads, so a
person who moves without crossing a threshold gets the cached conclusions; what depends on the
current geometry (the measurements in the provenance, the constraints' frames) is not cached.
Afterwards the facts are plain data (`facts`); the asserted + inferred graph (always Pellet's)
exports as Turtle and answers SPARQL.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from hriplan.ontology.assertions import Assertion, situation_assertions
from hriplan.ontology.cache import Reasoning, ReasoningCache, default_cache, reasoning_key
from hriplan.ontology.checks import check_input
from hriplan.ontology.facts import Facts
from hriplan.ontology.reasoners import InconsistentSituation, Reasoner, default_reasoner
from hriplan.ontology.relations import RELATIONS, ComputedRelation, RelationKind, compute_relations
from hriplan.ontology.rule_engine import reason
from hriplan.ontology.ruleset import Rule, load_rules, read_predicates
from hriplan.ontology.schema import Schema, load_schema
from hriplan.ontology.situation import Situation
from hriplan.ontology.vocabulary import PREFIXES, OntologySource, ontology_source

if TYPE_CHECKING:  # rdflib's SPARQL engine and owlready2 load only when used
    import rdflib

    from hriplan.ontology.sparql import QueryResult


class KnowledgeBase:
    """A situation with everything the ontology and the rules conclude about it.

    rule_files: extra rule files added to the packaged ones. ontology: another ontology file
    (e.g. with changed parameters). cache: where results are kept (default: memory + the XDG
    cache directory). reasoner: "fast" (in process) or "pellet"; default: `use_reasoner`'s.
    relations: the relations computed from the geometry (those some rule reads are asserted).
    rules: the rules as `load_rules(rule_files)` read them already (a task run reads them once for
    all its situations); given, `rule_files` is not read.
    Raises HriplanError for bad input, InconsistentSituation for a contradiction.
    """

    def __init__(
        self,
        situation: Situation,
        *,
        rule_files: Sequence[str | Path] = (),
        ontology: str | Path | None = None,
        cache: ReasoningCache | None = None,
        reasoner: Reasoner | None = None,
        relations: Sequence[RelationKind] = RELATIONS,
        rules: Sequence[Rule] | None = None,
    ) -> None:
        self.situation = situation
        self.reasoner: Reasoner = reasoner or default_reasoner()
        self.rules: tuple[Rule, ...] = tuple(rules) if rules is not None else load_rules(rule_files)
        self._source: OntologySource = ontology_source(ontology)
        self.schema: Schema = load_schema(self._source)
        read = read_predicates(self.rules)
        self.relations: list[ComputedRelation] = compute_relations(
            situation, self.schema.individuals, [k for k in relations if k.predicate in read]
        )
        assertions = situation_assertions(situation, self.rules) + [r.assertion for r in self.relations]
        self.assertions: list[Assertion] = sorted(set(assertions), key=repr)
        self._cache = cache if cache is not None else default_cache()
        self.key = reasoning_key(self._source.digest, self.rules, self.assertions, self.reasoner)
        reasoning = self._cache.get(self.key)
        if reasoning is None:
            check_input(self.schema, situation, self.rules, self.assertions)
            reasoning = self._reason_fast() if self.reasoner == "fast" else self._reason_pellet()
        if reasoning.inconsistency is not None:
            raise InconsistentSituation(reasoning.inconsistency)
        assert reasoning.facts is not None
        self.facts: Facts = reasoning.facts

    @functools.cached_property
    def _pellet_key(self) -> str:
        return reasoning_key(self._source.digest, self.rules, self.assertions, "pellet")

    def _reason_fast(self) -> Reasoning:
        """The rules in process; what it cannot settle (a contradiction) goes to Pellet."""
        facts = reason(self.schema, self.rules, self.assertions)
        reasoning = (
            Reasoning(facts=facts) if facts is not None else self._cache.get(self._pellet_key) or self._reason_pellet()
        )
        self._cache.put(self.key, reasoning)
        return reasoning

    def _reason_pellet(self) -> Reasoning:
        """Build the World, run Pellet (the JVM start) and cache what it concluded."""
        from hriplan.ontology.owl_world import build_world
        from hriplan.ontology.pellet import dump_ntriples, extract_facts, run_pellet

        world = build_world(self._source, self.rules, self.assertions)
        try:
            run_pellet(world)
        except InconsistentSituation as exc:
            reasoning, ntriples = Reasoning(inconsistency=str(exc)), None
        else:
            reasoning, ntriples = Reasoning(facts=extract_facts(world)), dump_ntriples(world)
        world.close()
        self._cache.put(self._pellet_key, reasoning, ntriples)
        return reasoning

    @functools.cached_property
    def graph(self) -> rdflib.Graph:
        """The asserted and inferred triples (ontology, rules, situation) as an rdflib graph (Pellet's)."""
        import rdflib

        ntriples = self._cache.ntriples(self._pellet_key)
        if ntriples is None:  # reasoned in process, evicted from memory or not on disk: ask Pellet
            self._reason_pellet()
            ntriples = self._cache.ntriples(self._pellet_key)
        graph = rdflib.Graph()
        graph.parse(data=ntriples, format="nt")
        for prefix, namespace in PREFIXES.items():
            graph.bind(prefix, namespace)
        return graph

    def turtle(self) -> str:
        """The asserted + inferred graph as Turtle, with the ontology's prefixes."""
        return self.graph.serialize(format="turtle")

    def query(self, text: str) -> QueryResult:
        """Answer a SPARQL 1.1 query over the asserted + inferred graph."""
        from hriplan.ontology.sparql import run_query

        return run_query(self.graph, text)
