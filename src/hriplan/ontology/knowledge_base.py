"""The knowledge base of one situation: reasoned once, cached by its facts, queryable.

Building one states the situation's facts, looks them up in the cache and only on a miss builds
an owlready2 World with the ontology and the rules and runs Pellet. Afterwards the facts are
plain data (`facts`), the asserted + inferred graph exports as Turtle and answers SPARQL.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from pathlib import Path

import rdflib

from hriplan.rules.ruleset import Rule, load_rules

from .assertions import Assertion, situation_assertions
from .cache import Reasoning, ReasoningCache, default_cache, reasoning_key
from .facts import Facts
from .reasoner import InconsistentSituation, dump_ntriples, extract_facts, run_pellet
from .situation import Situation
from .sparql import QueryResult, run_query
from .vocabulary import PREFIXES, OntologySource, ontology_source
from .world import build_world


class KnowledgeBase:
    """A situation with everything the ontology and the rules conclude about it.

    rule_files: extra rule files added to the packaged ones. ontology: another ontology file
    (e.g. with changed parameters). cache: where results are kept (default: memory + the XDG
    cache directory). Raises HriplanError for bad input, InconsistentSituation for a contradiction.
    """

    def __init__(self, situation: Situation, *, rule_files: Sequence[str | Path] = (),
                 ontology: str | Path | None = None, cache: ReasoningCache | None = None) -> None:  # fmt: skip
        self.situation = situation
        self.rules: tuple[Rule, ...] = load_rules(rule_files)
        self.assertions: list[Assertion] = situation_assertions(situation)
        self._source: OntologySource = ontology_source(ontology)
        self._cache = cache if cache is not None else default_cache()
        self.key = reasoning_key(self._source.digest, self.rules, self.assertions)
        reasoning = self._cache.get(self.key) or self._reason()
        if reasoning.inconsistency is not None:
            raise InconsistentSituation(reasoning.inconsistency)
        assert reasoning.facts is not None
        self.facts: Facts = reasoning.facts

    def _reason(self) -> Reasoning:
        """Build the World, run Pellet (the JVM start) and cache what it concluded."""
        world = build_world(self._source, self.rules, self.situation, self.assertions)
        try:
            run_pellet(world)
        except InconsistentSituation as exc:
            reasoning, ntriples = Reasoning(inconsistency=str(exc)), None
        else:
            reasoning, ntriples = Reasoning(facts=extract_facts(world)), dump_ntriples(world)
        world.close()
        self._cache.put(self.key, reasoning, ntriples)
        return reasoning

    @functools.cached_property
    def graph(self) -> rdflib.Graph:
        """The asserted and inferred triples (ontology, rules, situation) as an rdflib graph."""
        ntriples = self._cache.ntriples(self.key)
        if ntriples is None:  # evicted from memory and not on disk: reason again to get it
            self._reason()
            ntriples = self._cache.ntriples(self.key)
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
        return run_query(self.graph, text)
