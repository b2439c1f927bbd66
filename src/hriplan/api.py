"""The plug-in API for higher-level systems (task planners, a motion manager on the real robot).

    from hriplan.api import PlanningSession, Scene, HumanSpec, Pose, JointTarget, ToolTarget, PlanOptions
    session = PlanningSession("madar", scene, hands={"right": "power"})   # built once
    session.pose_human(HumanSpec(name="bob", position=(0.1, 1.4), yaw=-1.57))  # perception update
    session.set_constraints(constraints)                                   # or derive them: run_task
    result = session.plan(start, ToolTarget(arm="right", pose=Pose(...)))    # validated + timed
    result.trajectory.points, result.trajectory.report                     # what to execute, why

    outcome = run_task(load_task("examples/handover_full_can.yaml"), session)  # rules decide

A `ToolTarget(arm="right")` planned without a `group` moves that arm only; a `JointTarget` without
one moves the whole robot. Named start postures: `posture("madar", "ready")` (`POSTURES` lists
them); frames a constraint can be anchored at on a person: `FrameRef(entity="bob/right_hand")`,
with `PERSON_FRAMES` the frame names every person has. Any robot from its URDF and SRDF:
`PlanningSession("robots/panda.yaml")` takes a robot file (`load_robot_file` registers it by name).

Threads: a session is not thread-safe, and neither are two sessions of the same robot in two
threads (robots are shared per description, OMPL's seed is global). Plan from one thread, or
use one process per planner (OMPL's solve holds the GIL, so threads would not run in parallel
anyway).
"""

from __future__ import annotations

from pathlib import Path

from hriplan.planner.constraints.spec import (
    BoxConstraint,
    ConeConstraint,
    ConstraintSet,
    CylinderConstraint,
    FrameRef,
    OrientationConstraint,
    SphereConstraint,
)
from hriplan.planner.motion import JointTarget, MotionResult, ToolTarget
from hriplan.planner.options import PlanOptions
from hriplan.planner.outcome import Status
from hriplan.planner.session import PlanningSession, PlanResult
from hriplan.planner.trajectory import TrajectoryFile, load_trajectory
from hriplan.robots.descriptions.registry import POSTURES, posture
from hriplan.robots.human import Human, HumanSpec
from hriplan.robots.model import load_robot
from hriplan.robots.robot_file import load_robot_file
from hriplan.robots.scene import AttachedObject, Box, Capsule, Cylinder, Obstacle, Scene, Sphere, table
from hriplan.robots.spatial import Pose
from hriplan.tasks.load import load_task
from hriplan.tasks.model import TaskFile
from hriplan.tasks.pipeline import TaskOutcome, TaskRunner

PERSON_FRAMES: tuple[str, ...] = Human.FRAMES


def run_task(
    task: TaskFile, session: PlanningSession | None = None, base_dir: str | Path = ".", *, keep_task_world: bool = False
) -> TaskOutcome:
    """Derive every step's constraints with the rules and plan it, on `session` if given.

    Planning a task plans it in the task's world: for each step the session's scene (people,
    objects, tables) and constraints are those of the task. Afterwards the session's own scene
    and constraints are put back, unless `keep_task_world` is True (then the last step's stay).
    """
    if session is None:
        return TaskRunner(task, Path(base_dir)).run(plan=True)
    scene, constraints = session.checker.scene, list(session.constraints.values())
    try:
        return TaskRunner(task, Path(base_dir), session=session).run(plan=True)
    finally:
        if not keep_task_world:
            session.set_scene(scene)
            session.set_constraints(constraints)


__all__ = [
    "AttachedObject",
    "Box",
    "BoxConstraint",
    "Capsule",
    "ConeConstraint",
    "ConstraintSet",
    "Cylinder",
    "CylinderConstraint",
    "FrameRef",
    "HumanSpec",
    "JointTarget",
    "MotionResult",
    "Obstacle",
    "OrientationConstraint",
    "PERSON_FRAMES",
    "POSTURES",
    "PlanOptions",
    "PlanResult",
    "PlanningSession",
    "Pose",
    "Scene",
    "Sphere",
    "SphereConstraint",
    "Status",
    "TaskFile",
    "TaskOutcome",
    "TaskRunner",
    "ToolTarget",
    "TrajectoryFile",
    "load_robot",
    "load_robot_file",
    "load_task",
    "load_trajectory",
    "posture",
    "run_task",
    "table",
]
