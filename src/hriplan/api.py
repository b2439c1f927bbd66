"""The plug-in API for higher-level systems (task planners, a motion manager on the real robot).

    from hriplan.api import PlanningSession, Scene, HumanSpec, Pose, JointGoal, ToolGoal, PlanOptions
    session = PlanningSession("madar", scene, hands={"right": "power"})   # built once
    session.pose_human(HumanSpec(name="bob", position=(0.1, 1.4), yaw=-1.57))  # perception update
    session.set_constraints(constraints)                                   # or derive them: run_task
    result = session.plan(start, ToolGoal(arm="right", pose=Pose(...)))    # validated + timed
    result.trajectory.points, result.trajectory.report                     # what to execute, why

    outcome = run_task(load_task("examples/handover_full_can.yaml"), session)  # rules decide

Threads: a session is not thread-safe, and neither are two sessions of the same robot in two
threads (robots are shared per description, OMPL's seed is global). Plan from one thread, or
use one process per planner (OMPL's solve holds the GIL, so threads would not run in parallel
anyway).
"""

from __future__ import annotations

from pathlib import Path

from hriplan.planner.motion import JointGoal, MotionResult, ToolGoal
from hriplan.planner.options import PlanOptions
from hriplan.planner.session import PlanningSession, PlanResult
from hriplan.planner.spec import (BoxConstraint, ConeConstraint, ConstraintSet, CylinderConstraint, FrameRef,
                                  OrientationConstraint, SphereConstraint)  # fmt: skip
from hriplan.planner.trajectory import TrajectoryFile, load_trajectory
from hriplan.robots.human import HumanSpec
from hriplan.robots.model import load_robot
from hriplan.robots.scene import AttachedObject, Box, Capsule, Cylinder, Obstacle, Scene, Sphere, table
from hriplan.robots.spatial import Pose
from hriplan.tasks.load import load_task
from hriplan.tasks.model import TaskFile
from hriplan.tasks.pipeline import TaskOutcome, TaskRunner


def run_task(task: TaskFile, session: PlanningSession | None = None, base_dir: str | Path = ".") -> TaskOutcome:
    """Derive every step's constraints with the rules and plan it, on `session` if given."""
    return TaskRunner(task, Path(base_dir), session=session).run(plan=True)


__all__ = [
    "AttachedObject", "Box", "BoxConstraint", "Capsule", "ConeConstraint", "ConstraintSet", "Cylinder",
    "CylinderConstraint", "FrameRef", "HumanSpec", "JointGoal", "MotionResult", "Obstacle", "OrientationConstraint",
    "PlanOptions", "PlanResult", "PlanningSession", "Pose", "Scene", "Sphere", "SphereConstraint", "TaskFile",
    "TaskOutcome", "TaskRunner", "ToolGoal", "TrajectoryFile", "load_robot", "load_task", "load_trajectory",
    "run_task", "table",
]  # fmt: skip
