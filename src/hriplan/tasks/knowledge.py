"""The knowledge base behind a task step, for SPARQL queries."""

from __future__ import annotations

import functools

import rdflib

from hriplan import HriplanError
from hriplan.ontology.knowledge_base import KnowledgeBase
from hriplan.ontology.sparql import QueryResult, run_query
from hriplan.ontology.vocabulary import PREFIXES, ontology_source

from .pipeline import TaskRunner


def knowledge_base_for(runner: TaskRunner, step: str | None) -> KnowledgeBase:
    """The reasoned knowledge base of a task's step (the facts as they are at that step)."""
    runner.run(plan=False)
    bases = runner.knowledge_bases
    if step is None:
        return next(iter(bases.values()))
    if step not in bases:
        raise HriplanError(f"the task has no step {step!r}; steps: {', '.join(bases)}")
    return bases[step]


@functools.cache
def _ontology_graph() -> rdflib.Graph:
    graph = rdflib.Graph()
    graph.parse(data=ontology_source(None).ntriples, format="nt")
    for prefix, namespace in PREFIXES.items():
        graph.bind(prefix, namespace)
    return graph


def ontology_graph_query(text: str) -> QueryResult:
    """A query over the ontology alone (classes, properties, constraint kinds and parameters)."""
    return run_query(_ontology_graph(), text)
