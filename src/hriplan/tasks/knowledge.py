"""The knowledge base behind a task step, for SPARQL queries."""

from __future__ import annotations

import functools

import rdflib
from rdflib.query import Result

from hriplan import HriplanError
from hriplan.ontology.knowledge_base import KnowledgeBase
from hriplan.ontology.sparql import QueryResult, run_query
from hriplan.ontology.vocabulary import PREFIXES, ontology_source
from hriplan.tasks.pipeline import TaskRunner


def knowledge_base_for(runner: TaskRunner, step: str | None) -> KnowledgeBase:
    """The reasoned knowledge base of a task's step (the facts as they are at that step)."""
    runner.run(plan=False)
    bases = runner.knowledge_bases
    if step is None:
        return next(iter(bases.values()))
    if step not in bases:
        raise HriplanError(f"the task has no step {step!r}; steps: {', '.join(bases)}")
    return bases[step]


def query_every_step(runner: TaskRunner, text: str) -> QueryResult:
    """A SELECT query answered at every step of the task, its rows led by a `step` column
    (other query forms: the first step's answer)."""
    runner.run(plan=False)
    answers = {step: kb.query(text) for step, kb in runner.knowledge_bases.items()}
    first = next(iter(answers.values()))
    if first.form != "SELECT":
        return first
    combined = Result("SELECT")
    combined.vars = [rdflib.Variable("step"), *(rdflib.Variable(v) for v in first.variables)]
    combined.bindings = [
        {rdflib.Variable("step"): rdflib.Literal(step)}
        | {rdflib.Variable(v): term for v, term in zip(answer.variables, row) if term is not None}
        for step, answer in answers.items()
        for row in answer.rows
    ]
    return QueryResult(combined, next(iter(runner.knowledge_bases.values())).graph.namespace_manager)


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
