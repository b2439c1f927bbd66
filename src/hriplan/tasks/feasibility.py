"""Can this step be done from this state, at what cost, under which constraints, and why not: the
cheap question a symbolic task planner asks of each grounded action before (or while) it plans.

The answer is never a guess: the step is derived with the rules and planned, validated and timed
exactly as a task's step (tasks/pipeline.py, with its leave, preparatory, lift and retreat
motions), only with a short planning budget, in the session's perceived world (tasks/world.py).
Answers are kept per session for each (state, step, perceived world, robot configuration): a task
planner asks the same grounded action many times while it searches.
"""

from __future__ import annotations

import json
import weakref
from collections import OrderedDict
from pathlib import Path
from typing import TYPE_CHECKING

from pydantic import BaseModel, Field, ValidationError

from hriplan import HriplanError
from hriplan.files import validation_message
from hriplan.planner.outcome import Status
from hriplan.planner.trajectory import TrajectoryFile
from hriplan.rules.infer import DerivedConstraint
from hriplan.tasks.in_session import run_in_session
from hriplan.tasks.model import Step, TaskFile, step_name
from hriplan.tasks.pipeline import StepOutcome

if TYPE_CHECKING:
    from hriplan.planner.session import PlanningSession

# The planning budget of one answer (s): enough for a handover's constrained motion on MADAR
# (they solve in 0.05 s or less), short enough that a task planner can ask for every action.
TIME_LIMIT = 1.0
KEPT_ANSWERS = 256  # per session, the most recently asked (an answer holds its motions)
_ANSWERS: weakref.WeakKeyDictionary[PlanningSession, OrderedDict[str, Feasibility]] = weakref.WeakKeyDictionary()


class Feasibility(BaseModel):
    """Whether the step can be done from the state: ok only with a planned, validated and timed
    motion for each of its motions; else the status and the reason, one line."""

    step: str
    ok: bool
    status: Status
    cost: float | None = Field(
        default=None,
        description="Seconds: the duration of the step's motions timed for ISO/TS 15066 (slowed near people), "
        "summed; None when not ok.",
    )
    constraints: list[DerivedConstraint] = Field(
        default_factory=list, description="What the rules derived for the step: each constraint and why (its rules)."
    )
    reason: str = ""
    motions: list[str] = Field(default_factory=list, description="The motions planned: the step and those added.")
    trajectories: list[TrajectoryFile] = Field(
        default_factory=list, description="When ok: the validated, timed motions, in order, as a task's plan has them."
    )


def feasible(
    session: PlanningSession,
    state: TaskFile,
    step: Step | str,
    base_dir: str | Path = ".",
    time_limit: float = TIME_LIMIT,
) -> Feasibility:
    """Whether `step` (a step as a task file writes one, or the name of one of `state`'s) can be
    done now. `state` is the world as a task file states it (objects and who holds them, people
    and their roles, tables, the start posture), placed in what `session` perceives (people,
    obstacles, what the robot holds; tasks/world.py); the robot starts at the session's
    `configuration` when it knows it, else at the state's start. The session's scene and
    constraints are put back: asking changes nothing."""
    task = _one_step(state, step, time_limit)
    world = session.checker.scene
    key = json.dumps(
        [
            task.model_dump(mode="json", by_alias=True),
            world.model_dump(mode="json"),
            session.configuration,
            session.roles,
            str(Path(base_dir).resolve()),
        ],
        sort_keys=True,
    )
    answers = _ANSWERS.setdefault(session, OrderedDict())
    if key in answers:
        answers.move_to_end(key)
        return answers[key]
    name = step_name(task.steps[0], 0)
    start = name if session.configuration is not None else None  # else the state's start posture
    outcome = run_in_session(task, session, base_dir, from_step=start, advance=False)
    answer = answers[key] = _answer(name, outcome.steps)
    while len(answers) > KEPT_ANSWERS:
        answers.popitem(last=False)
    return answer


def _one_step(state: TaskFile, step: Step | str, time_limit: float) -> TaskFile:
    """The state with `step` as its one step, planned within `time_limit` seconds."""
    if isinstance(step, str):
        named = {step_name(s, k): s for k, s in enumerate(state.steps)}
        if step not in named:
            raise HriplanError(f"task {state.name!r} has no step {step!r}; steps: {', '.join(named)}")
        step = named[step].model_copy(update={"name": step})
    data = state.model_dump(by_alias=True) | {"steps": [step.model_dump(by_alias=True)]}
    data["planning"] |= {"time_limit": min(time_limit, state.planning.time_limit)}
    try:
        return TaskFile.model_validate(data)
    except ValidationError as exc:
        raise HriplanError(f"step in task {state.name!r}: {validation_message(exc)}") from None


def _answer(name: str, steps: list[StepOutcome]) -> Feasibility:
    """The answer from the step's outcomes (its own motion and those the pipeline added)."""
    main = next((s for s in steps if s.name == name), steps[-1])
    constraints = main.derivation.constraints
    motions = [s.name for s in steps]
    failed = next((s for s in steps if s.status != Status.SOLVED), None)
    if failed is not None:
        return Feasibility(
            step=name,
            ok=False,
            status=failed.status,
            constraints=constraints,
            reason=f"{failed.name}: {failed.message}" if failed.name != name else failed.message,
            motions=motions,
        )
    trajectories = [s.trajectory for s in steps if s.trajectory is not None]
    return Feasibility(
        step=name,
        ok=True,
        status=Status.SOLVED,
        cost=sum(t.points[-1].time_from_start for t in trajectories),
        constraints=constraints,
        motions=motions,
        trajectories=trajectories,
    )
