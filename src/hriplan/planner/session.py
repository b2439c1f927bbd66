"""Planning sessions: build the robot and collision structures once, then re-plan.

The motion-manager workflow of the seed framework: perception moves objects and people, the
task changes constraints and goals, and each `plan` reuses the robot model and collision
geometry. A session is not thread-safe, and neither are two sessions of one robot in two threads
(pinocchio data of a loaded robot and OMPL's global seed are shared): plan in parallel with
processes.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
from pydantic import BaseModel

from hriplan import HriplanError
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.human import HumanSpec
from hriplan.robots.model import JointValues, Robot, load_robot
from hriplan.robots.scene import Scene
from hriplan.robots.spatial import Pose

from .approach import ApproachMonitor
from .evaluator import ConstraintEvaluator
from .motion import Goal, MotionResult, plan_motion, with_keep_out
from .options import PlanOptions
from .resolve import bind, set_goal_positions
from .separation import SeparationPolicy
from .separation_report import separation_report
from .spec import ConstraintSet, ConstraintSpec
from .timing import time_parameterize
from .trajectory import ResolvedConstraint, TrajectoryFile, TrajectoryPoint, TrajectoryReport
from .validate import densify, validate_path

# Knot spacing handed to the time parameteriser, then a denser retry if re-validation fails.
TIMING_STEPS = (0.05, 0.01)


class PlanResult(BaseModel):
    motion: MotionResult
    trajectory: TrajectoryFile | None = None
    message: str = ""

    @property
    def solved(self) -> bool:
        return self.trajectory is not None

    @property
    def status(self) -> str:
        """The motion's status, or `untimed` for a path that could not be timed (e.g. too near a person)."""
        return "solved" if self.solved else "untimed" if self.motion.solved else self.motion.status


class PlanningSession:
    """A robot in a scene, ready to plan constrained motions again and again."""

    def __init__(self, robot: str | Robot = "madar", scene: Scene | None = None, hands: dict[str, str] | None = None) -> None:
        self.robot = robot if isinstance(robot, Robot) else load_robot(robot, hands)
        self.checker = CollisionChecker(self.robot, scene or Scene())
        self.constraints: dict[str, ConstraintSpec] = {}

    # -- perception and task updates (no rebuild) ------------------------------------------
    def move_obstacle(self, name: str, pose: Pose) -> None:
        self.checker.move_obstacle(name, pose)
        self.checker.scene = self.checker.scene.model_copy(update={"obstacles": [
            o.model_copy(update={"pose": pose}) if o.name == name else o for o in self.checker.scene.obstacles]})  # fmt: skip

    def pose_human(self, spec: HumanSpec) -> None:
        self.checker.pose_human(spec)
        self.checker.scene = self.checker.scene.model_copy(update={"humans": [
            spec if h.name == spec.name else h for h in self.checker.scene.humans]})  # fmt: skip

    def set_scene(self, scene: Scene) -> None:
        self.checker.set_scene(scene)

    def set_constraints(self, constraints: ConstraintSet | Iterable[ConstraintSpec]) -> None:
        specs = constraints.constraints if isinstance(constraints, ConstraintSet) else list(constraints)
        ConstraintSet(constraints=specs)  # unique ids
        self.constraints = {c.id: c for c in specs}

    def update_constraint(self, constraint_id: str, **changes: object) -> None:
        """Change a constraint's fields (enabled, target, frame, tolerance, size, ...)."""
        if constraint_id not in self.constraints:
            raise HriplanError(f"the session has no constraint {constraint_id!r}")
        spec = self.constraints[constraint_id]
        self.constraints[constraint_id] = type(spec).model_validate({**spec.model_dump(), **changes})

    # -- planning ------------------------------------------------------------------------
    def plan(self, start: JointValues, goal: Goal, options: PlanOptions | None = None, group: str | None = None,
             safety: SeparationPolicy | None = None) -> PlanResult:  # fmt: skip
        """Plan, validate densely, time-parameterise and re-validate the timed path.

        With `safety`, the motion is timed to keep ISO/TS 15066 speed and separation from the
        scene's people (and fails, with the reason, where it cannot)."""
        options = options or PlanOptions()
        specs = list(self.constraints.values())
        motion = plan_motion(self.robot, self.checker, specs, start, goal, options, group)
        if not motion.solved:
            return PlanResult(motion=motion, message=motion.message)
        return self._timed(motion, specs, options, safety)

    def _timed(self, motion: MotionResult, specs: list[ConstraintSpec], options: PlanOptions,
               safety: SeparationPolicy | None = None) -> PlanResult:  # fmt: skip
        bound = bind(specs, self.robot, self.checker)
        path = np.array(motion.path)
        q0 = self.robot.configuration(dict(zip(motion.joint_names, path[0])))
        evaluator = ConstraintEvaluator(self.robot, bound, motion.group, q0)
        set_goal_positions(self.robot, bound, evaluator.full(path[-1]))
        scene = self.checker.scene
        monitor = None if safety is None or not scene.humans else ApproachMonitor(self.robot, self.checker, safety, motion.group, q0)
        with with_keep_out(self.checker, bound):
            timed, check, message = self._time_and_check(path, evaluator, motion.group, options, monitor)
        if timed is None:
            return PlanResult(motion=motion, message=message)
        trajectory = self._file(motion, bound, timed, check, options, scene, q0)
        if monitor is not None:
            report = trajectory.report.model_copy(update={"separation": separation_report(monitor, timed)})
            trajectory = trajectory.model_copy(update={"report": report})
        return PlanResult(motion=motion, trajectory=trajectory)

    def _time_and_check(self, path: np.ndarray, evaluator: ConstraintEvaluator, group: str, options: PlanOptions,
                        monitor: ApproachMonitor | None = None):  # noqa: ANN202 fmt: skip
        """TOPP-RA on the validated path (slowed near people by `monitor`), then dense validation."""
        velocity = self.robot.velocity_limit(group)
        acceleration = np.full(len(velocity), options.acceleration_limit)
        message = ""
        for step in TIMING_STEPS:
            knots = densify(list(path), step)
            try:
                timed = time_parameterize(knots, velocity, acceleration, velocity_scale=options.velocity_scale,
                                          speed_scale=None if monitor is None else monitor.speed_scale)  # fmt: skip
            except HriplanError as exc:
                message = str(exc)
                continue
            check = validate_path(evaluator, self.checker, np.array(timed.positions), options.validation_step)
            if check.valid:
                return timed, check, ""
            message = f"the timed trajectory left the validated path: {check.message}"
        return None, None, message

    def _file(self, motion, bound, timed, check, options, scene, q0) -> TrajectoryFile:  # noqa: ANN001
        path = np.array(motion.path)
        report = TrajectoryReport(
            status="solved",
            planner=options.planner,
            space=motion.space,
            planning_time=motion.planning_time,
            duration=timed.times[-1],
            path_length=float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum()),
            states_checked=check.states_checked,
            max_violation={c.id: c.max_violation for c in check.constraints},
            min_human_distance=check.min_human_distance,
            closest_pair=check.closest_pair,
            velocity_scale=options.velocity_scale,
            calls=motion.calls,
        )
        points = [
            TrajectoryPoint(time_from_start=t, positions=p, velocities=v, accelerations=a)
            for t, p, v, a in zip(timed.times, timed.positions, timed.velocities, timed.accelerations)
        ]
        constraints = [
            ResolvedConstraint(spec=c.spec, frame_in_world=Pose.from_se3(c.frame),
                               goal_position=None if c.p_goal is None else c.p_goal.tolist())  # fmt: skip
            for c in bound
        ]
        start = dict(zip(self.robot.joint_names, q0.tolist()))
        return TrajectoryFile(robot=self.robot.name, hands=self.robot.hand_postures, joint_names=motion.joint_names, start=start,
                              scene=self.checker.scene, points=points, constraints=constraints, report=report)  # fmt: skip
