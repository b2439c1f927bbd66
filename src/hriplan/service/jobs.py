"""What a planning worker does with one request: derive, explain, plan, solve (a query worker's
job is in query_jobs.py, which imports nothing of the planner, so it starts faster).

Every job takes plain data (the validated request as JSON-able dicts) and returns the response
body as JSON text, so nothing but strings crosses the process boundary. Sessions are rebuilt
from the state the server sends with each request; a worker keeps one PlanningSession per
robot and hand postures (planner.session.worker_session), shared by its jobs, and gives it the
request's scene and constraints (rebuilding only when they changed).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from hriplan.formats.ros_trajectory import joint_trajectory_message
from hriplan.planner.problem import PlanningProblem
from hriplan.planner.session import PlanningSession, PlanResult, worker_session
from hriplan.rules.explain import explain
from hriplan.service.query_jobs import JSON, Reply, task_runner
from hriplan.service.schemas import (
    ExplainResponse,
    FeasibleRequest,
    PlanResponse,
    SessionPlanRequest,
    SessionState,
    StepExplanation,
    TaskPlanResponse,
)
from hriplan.tasks.feasibility import feasible


def derive(payload: dict[str, Any]) -> Reply:
    return task_runner(payload).run(plan=False).model_dump_json(), JSON


def explain_task(payload: dict[str, Any]) -> Reply:
    outcome = task_runner(payload).run(plan=False)
    steps = [
        StepExplanation(name=s.name, kind=s.kind, arms=s.arms, explanation=explain(s.derivation)) for s in outcome.steps
    ]
    return ExplainResponse(task=outcome.task, steps=steps).model_dump_json(), JSON


def plan_task(payload: dict[str, Any]) -> Reply:
    outcome = task_runner(payload).run(plan=True)
    ros = (
        {s.name: joint_trajectory_message(s.trajectory) for s in outcome.steps if s.trajectory is not None}
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
        leave=result.leave,
        joint_trajectory=joint_trajectory_message(result.trajectory) if ros and result.trajectory else None,
    )
    return response.model_dump_json(by_alias=True), JSON


def solve(payload: dict[str, Any]) -> Reply:
    problem = PlanningProblem.model_validate(payload["problem"])
    session = worker_session(problem.robot, problem.hands)
    session.set_scene(problem.scene)
    session.set_constraints(problem.constraints)
    session.roles = dict(problem.roles)  # the speed limits near its people (the session's default)
    return _plan_response(
        session.plan(problem.start, problem.goal, problem.options, problem.group), bool(payload.get("ros"))
    )


def _session(state: SessionState) -> PlanningSession:
    """The worker's session for the state's robot and hands, holding the state's scene,
    constraints and roles: set on every request, since other jobs plan on the same session (the scene it
    already holds is no rebuild)."""
    session = worker_session(state.robot, state.hands)
    session.set_scene(state.scene)
    session.set_constraints(state.constraints)
    session.roles = dict(state.roles)
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


def feasible_in_session(payload: dict[str, Any]) -> Reply:
    """Whether a step can be done from a state in the session's world, the robot where the request has it."""
    session = _session(SessionState.model_validate(payload["state"]))
    request = FeasibleRequest.model_validate(payload["request"])
    session.configuration = None  # where another request left the worker's session is not this robot's
    if request.configuration is not None:
        session.set_configuration(request.configuration)
    rules_dir = payload.get("rules_dir")
    answer = feasible(session, request.state, request.step, Path(rules_dir or "."), request.time_limit)
    if not payload.get("trajectories"):
        answer = answer.model_copy(update={"trajectories": []})
    return answer.model_dump_json(by_alias=True), JSON


JOBS = {
    "constraints": derive,
    "explain": explain_task,
    "plan": plan_task,
    "solve": solve,
    "session_check": check_session,
    "session_plan": plan_in_session,
    "session_feasible": feasible_in_session,
}
