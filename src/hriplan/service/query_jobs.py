"""What a query worker does: a SPARQL query over the ontology or a stored task's reasoned graph.

Apart from jobs.py so that a query worker imports no planner (toppra, matplotlib): a query
worker killed at its time limit is replaced sooner, and the queries behind it wait less.
"""

from __future__ import annotations

import hashlib
import json
from collections import OrderedDict
from pathlib import Path
from typing import Any

from hriplan.ontology.knowledge_base import KnowledgeBase
from hriplan.ontology.sparql import QueryLimits, prepare_query, run_query, time_limit_message
from hriplan.service.errors import RequestError
from hriplan.service.negotiation import choose
from hriplan.service.worker_main import announce_deadline, bounded_memory
from hriplan.tasks.knowledge import _ontology_graph
from hriplan.tasks.model import TaskFile
from hriplan.tasks.pipeline import TaskRunner

Reply = tuple[str, str]  # (body, media type)
JSON = "application/json"
KILL_GRACE = 0.5  # seconds past a query's time limit before its worker is killed

_task_bases: OrderedDict[str, dict[str, KnowledgeBase]] = OrderedDict()  # recent tasks' knowledge bases


def task_runner(payload: dict[str, Any]) -> TaskRunner:
    """The runner of a request's task, its rule files read from the server's rules folder."""
    rules_dir = payload.get("rules_dir")
    return TaskRunner(TaskFile.model_validate(payload["task"]), Path(rules_dir) if rules_dir else Path("."))


def _task_graph(payload: dict[str, Any]):
    key = hashlib.sha256(json.dumps([payload["task"], payload.get("rules_dir")], sort_keys=True).encode()).hexdigest()
    if key not in _task_bases:
        runner = task_runner(payload)
        runner.run(plan=False)
        _task_bases[key] = dict(runner.knowledge_bases)
        while len(_task_bases) > 8:
            _task_bases.popitem(last=False)
    _task_bases.move_to_end(key)
    bases, step = _task_bases[key], payload.get("step")
    if step is None:
        return next(iter(bases.values())).graph
    if step not in bases:
        raise RequestError(404, f"the task has no step {step!r}; steps: {', '.join(bases)}")
    return bases[step].graph


def sparql(payload: dict[str, Any]) -> Reply:
    """A SPARQL query over the ontology alone or a task step's reasoned graph, negotiated.
    Reasoning the task's graph is not the query's time; from then on the worker is killed past
    the query's time limit and its memory is capped, whatever the query does."""
    prepare_query(payload["query"])  # refusals and syntax errors before any reasoning
    graph = _ontology_graph() if payload.get("task") is None else _task_graph(payload)
    limits = QueryLimits.model_validate(payload["limits"])
    announce_deadline(limits.time_limit + KILL_GRACE, time_limit_message(limits.time_limit))
    with bounded_memory():
        result = run_query(graph, payload["query"], limits)
        syntax, media = choose(result.graph is not None, payload.get("accept"), payload.get("format"))
        return result.serialize(syntax), media


JOBS = {"sparql": sparql}
