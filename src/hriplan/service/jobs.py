"""What a worker process does with one request: derive, explain, plan, solve, query.

Every job takes plain data (the validated request as JSON-able dicts) and returns the response
body as JSON text, so nothing but strings crosses the process boundary. Sessions are rebuilt
from the state the server sends with each request; a worker keeps one PlanningSession per
robot and hand postures (planner.session.worker_session), shared by its jobs, and gives it the
request's scene and constraints (rebuilding only when they changed).
"""

from __future__ import annotations

import hashlib
import json
from collections import OrderedDict
from pathlib import Path
from typing import Any

from hriplan.ontology.knowledge_base import KnowledgeBase
from hriplan.ontology.sparql import QueryLimits, prepare_query, run_query, time_limit_message
from hriplan.planner.problem import PlanningProblem
from hriplan.planner.session import PlanningSession, PlanResult, worker_session
from hriplan.rules.explain import explain
from hriplan.service.errors import RequestError
from hriplan.service.negotiation import choose
from hriplan.service.ros import joint_trajectory
from hriplan.service.schemas import (
    ExplainResponse,
    PlanResponse,
    SessionPlanRequest,
    SessionState,
    StepExplanation,
    TaskPlanResponse,
)
from hriplan.service.worker_main import announce_deadline, bounded_memory
from hriplan.tasks.knowledge import _ontology_graph
from hriplan.tasks.model import TaskFile
from hriplan.tasks.pipeline import TaskRunner

Reply = tuple[str, str]  # (body, media type)
JSON = "application/json"
KILL_GRACE = 0.5  # seconds past a query's time limit before its worker is killed

_task_bases: OrderedDict[str, dict[str, KnowledgeBase]] = OrderedDict()  # recent tasks' knowledge bases


def _runner(payload: dict[str, Any]) -> TaskRunner:
    rules_dir = payload.get("rules_dir")
    return TaskRunner(TaskFile.model_validate(payload["task"]), Path(rules_dir) if rules_dir else Path("."))


def derive(payload: dict[str, Any]) -> Reply:
    return _runner(payload).run(plan=False).model_dump_json(), JSON


def explain_task(payload: dict[str, Any]) -> Reply:
    outcome = _runner(payload).run(plan=False)
    steps = [
        StepExplanation(name=s.name, kind=s.kind, arms=s.arms, explanation=explain(s.derivation)) for s in outcome.steps
    ]
    return ExplainResponse(task=outcome.task, steps=steps).model_dump_json(), JSON


def plan_task(payload: dict[str, Any]) -> Reply:
    outcome = _runner(payload).run(plan=True)
    ros = (
        {s.name: joint_trajectory(s.trajectory) for s in outcome.steps if s.trajectory is not None}
        if payload.get("ros")
        else {}
    )
    response = TaskPlanResponse(task=outcome.task, steps=outcome.steps, solved=outcome.solved, joint_trajectories=ros)
    return response.model_dump_json(by_alias=True), JSON


def _plan_response(result: PlanResult, ros: bool) -> Reply:
    message = "" if result.solved else f"planning failed ({result.status}): {result.message}"
    response = PlanResponse(
        solved=result.solved,
        status=result.status,
        message=message,
        trajectory=result.trajectory,
        joint_trajectory=joint_trajectory(result.trajectory) if ros and result.trajectory else None,
    )
    return response.model_dump_json(by_alias=True), JSON


def solve(payload: dict[str, Any]) -> Reply:
    problem = PlanningProblem.model_validate(payload["problem"])
    session = worker_session(problem.robot, problem.hands)
    session.set_scene(problem.scene)
    session.set_constraints(problem.constraints)
    return _plan_response(
        session.plan(problem.start, problem.goal, problem.options, problem.group), bool(payload.get("ros"))
    )


def _session(state: SessionState) -> PlanningSession:
    """The worker's session for the state's robot and hands, holding the state's scene and
    constraints: set on every request, since other jobs plan on the same session (the scene it
    already holds is no rebuild)."""
    session = worker_session(state.robot, state.hands)
    session.set_scene(state.scene)
    session.set_constraints(state.constraints)
    return session


def check_session(payload: dict[str, Any]) -> Reply:
    _session(SessionState.model_validate(payload["state"]))
    return "{}", JSON


def plan_in_session(payload: dict[str, Any]) -> Reply:
    session = _session(SessionState.model_validate(payload["state"]))
    request = SessionPlanRequest.model_validate(payload["request"])
    return _plan_response(
        session.plan(request.start, request.goal, request.options, request.group), bool(payload.get("ros"))
    )


def _task_graph(payload: dict[str, Any]):
    key = hashlib.sha256(json.dumps([payload["task"], payload.get("rules_dir")], sort_keys=True).encode()).hexdigest()
    if key not in _task_bases:
        runner = _runner(payload)
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


JOBS = {
    "constraints": derive,
    "explain": explain_task,
    "plan": plan_task,
    "solve": solve,
    "session_check": check_session,
    "session_plan": plan_in_session,
    "sparql": sparql,
}
