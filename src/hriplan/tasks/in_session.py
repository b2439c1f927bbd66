"""A task planned on a planning session: in the session's perceived world, optionally continued
from where the session's robot is, and the session left as the solved steps leave it (or as it
was). One home for `api.run_task` and `feasible`, which both plan a task this way."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from hriplan import HriplanError
from hriplan.tasks.model import TaskFile
from hriplan.tasks.pipeline import TaskOutcome, TaskRunner
from hriplan.tasks.world import continued, in_world

if TYPE_CHECKING:
    from hriplan.planner.session import PlanningSession


def run_in_session(
    task: TaskFile,
    session: PlanningSession,
    base_dir: str | Path = ".",
    *,
    from_step: str | None = None,
    advance: bool = True,
) -> TaskOutcome:
    """Plan `task` in the session's world (`tasks/world.py`): the task's people and objects as
    the file places them unless the session perceives them elsewhere, plus everything else the
    session perceives (obstacles, people, what the robot holds). `from_step` continues the task
    from that step, the robot where the session's `configuration` has it, holding what the
    session's scene has it hold. The session's own constraints are put back afterwards; with
    `advance` its scene, configuration and roles become what the solved steps leave (as if
    executed), so the task can be continued; without, its scene is put back too."""
    world, constraints = session.checker.scene, list(session.constraints.values())
    placed, grasps = in_world(task, world, session.roles)
    if from_step is not None:
        if session.configuration is None:
            raise HriplanError(
                "the session does not know where the robot is: plan on it, run a task or set_configuration first"
            )
        placed = continued(placed, from_step, session.configuration)
    try:
        outcome = TaskRunner(placed, Path(base_dir), session=session).run(plan=True, grasps=grasps)
    finally:
        session.set_scene(world)
        session.set_constraints(constraints)
    if advance:
        session.set_scene(outcome.world)
        session.configuration = outcome.end
        session.roles |= {h.name: h.role for h in task.humans}
    return outcome
