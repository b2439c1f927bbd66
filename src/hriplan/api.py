"""The plug-in API for higher-level systems (task planners, a motion manager on the real robot).

    from hriplan.api import PlanningSession, Scene, HumanSpec, Pose, JointTarget, ToolTarget, PlanOptions
    session = PlanningSession("madar", scene, hands={"right": "power"}, roles={"alice": "Giver"})  # once
    session.pose_human(HumanSpec(name="alice", position=(0.1, 1.4), yaw=-1.57))  # perception update
    session.set_constraints(constraints)                                   # or derive them: run_task
    result = session.plan(start, ToolTarget(arm="right", pose=Pose(...)))    # validated + timed
    result.trajectory.points, result.trajectory.report                     # what to execute, why

    outcome = run_task(load_task("examples/handover_full_can.yaml"), session)  # rules decide
    rest = run_task(task, session, from_step="place_can")                  # continue where it stopped
    feasible(session, task, "place_can").ok                                # a task planner's question

Safe by default: near people `session.plan` is timed to ISO/TS 15066 with the ontology's policy
for them (`session.policy()`: by `session.roles`, else bystanders; `default_policy` and
`SeparationPolicy` for one of your own); `safety=None` turns the speed limits off.

A task runs in the session's world: the task's people and objects where the session perceives
them (else where the file says), plus whatever else it perceives (obstacles, people, held
objects). Afterwards (`advance=True`) the session is where the solved steps leave it: objects
moved, what the robot holds, its `configuration`; `from_step` continues the task from there.

A `ToolTarget(arm="right")` planned without a `group` moves that arm only; a `JointTarget` without
one moves the whole robot. Named start postures: `posture("madar", "ready")` (`POSTURES` lists
them); frames a constraint can be anchored at on a person: `FrameRef(entity="alice/right_hand")`,
with `PERSON_FRAMES` the frame names every person has. Any robot from its URDF and SRDF:
`PlanningSession("robots/panda.yaml")` takes a robot file (`load_robot_file` registers it by name).

A long-running process (a motion manager re-planning as people move): `load_kernels()` once at
start plans with the compiled kernels (numba, the `fast` extra): ~1 s then, the ISO/TS 15066
monitor x0.44-0.47 and constrained solves x0.59-0.86 after (`hriplan serve` does it; a seed then
reproduces with them on only). After the process's first timed motion a session freezes what
exists, once (`gc.freeze()`, hriplan/collector.py): full garbage collections then skip the
robots', kernels' and ontology's objects, out of the re-plans' time (docs/api.md).

BLAS: importing this module before numpy asks one BLAS thread (`blas_threads.py`, as the
command line does), unless the environment names a number (OPENBLAS_NUM_THREADS and the like).
TOPP-RA's set-up multiplies (gridpoints x 2n) by (2n x 4n) matrices; for MADAR's two arms
OpenBLAS threads them, and a timing cost 2-3 times the CPU on two busy cores
(`benchmarks/bench_toppra.py` with OPENBLAS_NUM_THREADS=2 against 1).

Threads: a session is not thread-safe, and neither are two sessions of the same robot in two
threads (robots are shared per description, OMPL's seed is global). Plan from one thread, or
use one process per planner (OMPL's solve holds the GIL, so threads would not run in parallel
anyway).
"""

from __future__ import annotations

from hriplan.blas_threads import single_threaded_blas

single_threaded_blas()  # before numpy loads (see the docstring)

from pathlib import Path

from hriplan import HriplanError
from hriplan.planner.constraints.spec import (
    BoxConstraint,
    ConeConstraint,
    ConstraintSet,
    CylinderConstraint,
    FrameRef,
    OrientationConstraint,
    SphereConstraint,
)
from hriplan.planner.kernels import load_kernels
from hriplan.planner.motion import JointTarget, MotionResult, ToolTarget
from hriplan.planner.options import PlanOptions
from hriplan.planner.outcome import Status
from hriplan.planner.session import PlanningSession, PlanResult
from hriplan.planner.trajectory import TrajectoryFile, load_trajectory
from hriplan.robots.descriptions.registry import POSTURES, load_robot_file, posture
from hriplan.robots.human import Human, HumanSpec
from hriplan.robots.model import load_robot
from hriplan.robots.scene import AttachedObject, Box, Capsule, Cylinder, Obstacle, Scene, Sphere, table
from hriplan.robots.spatial import Pose
from hriplan.safety.policy import default_policy
from hriplan.safety.separation import SeparationPolicy
from hriplan.tasks.feasibility import Feasibility, feasible
from hriplan.tasks.in_session import run_in_session
from hriplan.tasks.load import load_task
from hriplan.tasks.model import Step, TaskFile
from hriplan.tasks.pipeline import TaskOutcome, TaskRunner

PERSON_FRAMES: tuple[str, ...] = Human.FRAMES


def run_task(
    task: TaskFile,
    session: PlanningSession | None = None,
    base_dir: str | Path = ".",
    *,
    from_step: str | None = None,
    advance: bool = True,
) -> TaskOutcome:
    """Derive every step's constraints with the rules and plan it, on `session` if given: in
    the session's world, continued `from_step` where its robot is, the session advanced to
    where the solved steps leave it (`tasks/in_session.py` says how)."""
    if session is None:
        if from_step is not None:
            raise HriplanError("continuing a task (from_step) needs the session whose state it continues")
        return TaskRunner(task, Path(base_dir)).run(plan=True)
    return run_in_session(task, session, base_dir, from_step=from_step, advance=advance)


__all__ = [
    "AttachedObject",
    "Box",
    "BoxConstraint",
    "Capsule",
    "ConeConstraint",
    "ConstraintSet",
    "Cylinder",
    "CylinderConstraint",
    "Feasibility",
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
    "SeparationPolicy",
    "Sphere",
    "SphereConstraint",
    "Status",
    "Step",
    "TaskFile",
    "TaskOutcome",
    "TaskRunner",
    "ToolTarget",
    "TrajectoryFile",
    "default_policy",
    "feasible",
    "load_kernels",
    "load_robot",
    "load_robot_file",
    "load_task",
    "load_trajectory",
    "posture",
    "run_task",
    "table",
]
