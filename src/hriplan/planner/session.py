"""Planning sessions: build the robot and collision structures once, then re-plan.

The motion-manager workflow of the seed framework: perception moves objects and people, the
task changes constraints and goals, and each `plan` reuses the robot model and collision
geometry. A session is not thread-safe, and neither are two sessions of one robot in two threads
(pinocchio data of a loaded robot and OMPL's global seed are shared): plan in parallel with
processes.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from time import perf_counter

import numpy as np
from pydantic import BaseModel, model_validator

from hriplan import HriplanError
from hriplan.planner.constraints.binding import bind, resolve_frame, set_goal_positions
from hriplan.planner.constraints.evaluator import ConstraintEvaluator
from hriplan.planner.constraints.spec import ConstraintSet, ConstraintSpec, OrientationConstraint
from hriplan.planner.motion import JointTarget, MotionResult, Target, ToolTarget, plan_motion, with_keep_out
from hriplan.planner.options import PlanOptions
from hriplan.planner.outcome import Status
from hriplan.planner.search.ompl_solver import ompl_seed
from hriplan.planner.timing import time_parameterize
from hriplan.planner.trajectory import ResolvedConstraint, TrajectoryFile, TrajectoryPoint, TrajectoryReport
from hriplan.planner.validate import densify, validate_path
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.descriptions.registry import DEFAULT_ROBOT
from hriplan.robots.human import HumanSpec
from hriplan.robots.ik import solve_two_arms
from hriplan.robots.model import JointValues, Robot, load_robot
from hriplan.robots.robot_file import robot_name
from hriplan.robots.scene import Scene
from hriplan.robots.spatial import Pose, Transform
from hriplan.safety.approach import ApproachMonitor
from hriplan.safety.report import separation_report
from hriplan.safety.separation import SeparationPolicy

# Knot spacing handed to the time parameteriser, then a denser retry if re-validation fails.
TIMING_STEPS = (0.05, 0.01)
# Re-plans (within the time limit) when a valid path cannot be timed: its shortcuts can graze an
# obstacle so closely that the smooth timed motion, which rounds their corners, touches it.
TIMING_RETRIES = 2


def _retry_seed(seed: int | None, retry: int) -> int | None:
    """A re-plan's seed: reproducible from the run's seed, and not another run's first seed."""
    return None if seed is None else -ompl_seed(seed, retry) - 2**31


class PlanResult(BaseModel):
    """A planned motion and, only when solved, its validated timed trajectory."""

    status: Status
    motion: MotionResult
    trajectory: TrajectoryFile | None = None
    message: str = ""

    @model_validator(mode="after")
    def _solved_means_a_trajectory(self) -> PlanResult:
        if (self.status == Status.SOLVED) != (self.trajectory is not None):
            raise ValueError("a plan result is solved exactly when it has a trajectory")
        return self

    @property
    def solved(self) -> bool:
        return self.status == Status.SOLVED


class PlanningSession:
    """A robot (loaded, its name, or a robot file) in a scene, ready to plan constrained motions
    again and again."""

    def __init__(
        self, robot: str | Robot = DEFAULT_ROBOT, scene: Scene | None = None, hands: dict[str, str] | None = None
    ) -> None:
        self.robot = robot if isinstance(robot, Robot) else load_robot(robot_name(robot), hands)
        self.checker = CollisionChecker(self.robot, scene or Scene())
        self.constraints: dict[str, ConstraintSpec] = {}

    # -- perception and task updates (no rebuild) ------------------------------------------
    def move_obstacle(self, name: str, pose: Pose) -> None:
        self.checker.move_obstacle(name, pose)

    def pose_human(self, spec: HumanSpec) -> None:
        self.checker.pose_human(spec)

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

    # -- goals in the session's scene -------------------------------------------------------
    def held_axes(
        self, start: JointValues, in_tool: dict[str, Transform], constraints: list[tuple[str, ConstraintSpec]]
    ) -> dict[str, np.ndarray]:
        """Per arm holding an object (arm -> the object's pose in its tool frame): the world
        direction the object's axis should keep: the target of an orientation constraint on that
        arm (of the (arm, constraint) pairs: a blade pointing away), else its direction at `start`."""
        q = self.robot.configuration(start)
        held = {}
        for arm, placement in in_tool.items():
            tool = Transform(self.robot.frame_pose(self.robot.tool_frame(arm), q))
            held[arm] = (tool * placement).rotation[:, 2].copy()
            for on, spec in constraints:
                if on == arm and isinstance(spec, OrientationConstraint):
                    target = resolve_frame(spec.frame, self.robot, self.checker).rotation @ spec.target.rotation()
                    held[arm] = (target @ placement.rotation)[:, 2].copy()
        return held

    def joint_goal(self, goals: list[ToolTarget], start: JointValues) -> JointTarget:
        """Two arms' tool goals as one joint goal: IK for both, clear of each other and the scene."""
        targets = [(g.arm, g.pose.matrix(), g.free_axes) for g in goals]
        q = solve_two_arms(
            self.robot,
            targets[0],
            targets[1],
            self.robot.configuration(start),
            lambda full: not self.checker.in_collision(full),
        )
        if q is None:
            raise HriplanError("no collision-free configuration puts both arms at their goals")
        return JointTarget(values=dict(zip(self.robot.joint_names, q.tolist())))

    # -- planning ------------------------------------------------------------------------
    def plan(
        self,
        start: JointValues,
        goal: Target,
        options: PlanOptions | None = None,
        group: str | None = None,
        safety: SeparationPolicy | None = None,
    ) -> PlanResult:
        """Plan, validate densely, time-parameterise and re-validate the timed path.

        With `safety`, the motion is timed to keep ISO/TS 15066 speed and separation from the
        scene's people (and fails, with the reason, where it cannot)."""
        options = options or PlanOptions()
        started = perf_counter()
        for retry in range(TIMING_RETRIES + 1):
            remaining = options.time_limit - (perf_counter() - started)
            if retry and remaining <= 0.0:
                break
            run = (
                options
                if retry == 0
                else options.model_copy(update={"time_limit": remaining, "seed": _retry_seed(options.seed, retry)})
            )
            motion = plan_motion(
                self.robot, self.checker, list(self.constraints.values()), start, goal, run, group, safety
            )
            result = self.time(motion, options, safety)
            if result.status != Status.TIMING_FAILED:
                break
        return result

    def time(
        self, motion: MotionResult, options: PlanOptions | None = None, safety: SeparationPolicy | None = None
    ) -> PlanResult:
        """Time a planned motion and validate the timed samples against the session's constraints
        and scene, every joint outside the planned group at the motion's start. With `safety`,
        the timing keeps ISO/TS 15066 speed and separation from the scene's people."""
        options = options or PlanOptions()
        if not motion.solved:
            return PlanResult(status=motion.status, motion=motion, message=motion.message)
        missing = [j for j in self.robot.joint_names if j not in motion.start]
        if missing:
            raise HriplanError(
                f"the motion's start does not give every joint of {self.robot.name!r} (missing {missing[0]!r})"
            )
        bound = bind(list(self.constraints.values()), self.robot, self.checker)
        path = np.array(motion.path)
        q0 = self.robot.configuration(motion.start)
        evaluator = ConstraintEvaluator(self.robot, bound, motion.group, q0)
        set_goal_positions(self.robot, bound, evaluator.full(path[-1]))
        scene = self.checker.scene
        monitor = (
            None
            if safety is None or not scene.humans
            else ApproachMonitor(self.robot, self.checker, safety, motion.group, q0)
        )
        with with_keep_out(self.checker, bound):
            timed, check, message = self._time_and_check(path, evaluator, motion.group, options, monitor)
        if timed is None:
            return PlanResult(status=Status.TIMING_FAILED, motion=motion, message=message)
        trajectory = self._file(motion, bound, timed, check, options, scene, evaluator.full(path[0]))
        if monitor is not None:
            report = trajectory.report.model_copy(
                update={"separation": separation_report(monitor, timed.positions, timed.velocities)}
            )
            trajectory = trajectory.model_copy(update={"report": report})
        return PlanResult(status=Status.SOLVED, motion=motion, trajectory=trajectory)

    def _time_and_check(
        self,
        path: np.ndarray,
        evaluator: ConstraintEvaluator,
        group: str,
        options: PlanOptions,
        monitor: ApproachMonitor | None = None,
    ):
        """TOPP-RA on the validated path (slowed near people by `monitor`), then dense validation."""
        velocity = self.robot.velocity_limit(group)
        known = self.robot.description.acceleration_limits
        acceleration = np.array([known.get(j, options.acceleration_limit) for j in self.robot.group_joints(group)])
        message = ""
        for step in TIMING_STEPS:
            knots = densify(list(path), step)
            try:
                timed = time_parameterize(
                    knots,
                    velocity,
                    acceleration,
                    velocity_scale=options.velocity_scale,
                    speed_scale=None if monitor is None else monitor.speed_scale,
                )
            except HriplanError as exc:
                message = str(exc)
                continue
            check = validate_path(
                evaluator, self.checker, np.array(timed.positions), options.validation_step, human_distance=True
            )
            if check.valid:
                return timed, check, ""
            message = f"the timed trajectory left the validated path: {check.message}"
        return None, None, message

    def _file(self, motion, bound, timed, check, options, scene, q0) -> TrajectoryFile:
        path = np.array(motion.path)
        report = TrajectoryReport(
            status=Status.SOLVED,
            planner=options.planner,
            space=motion.space,
            planning_time=motion.planning_time,
            duration=timed.times[-1],
            path_length=float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum()),
            straight_length=float(np.linalg.norm(path[-1] - path[0])),
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
            ResolvedConstraint(
                spec=c.spec,
                frame_in_world=Pose.from_se3(c.frame),
                goal_position=None if c.p_goal is None else c.p_goal.tolist(),
            )
            for c in bound
        ]
        start = dict(zip(self.robot.joint_names, q0.tolist()))
        return TrajectoryFile(
            robot=self.robot.name,
            robot_file=self.robot.description.source,
            hands=self.robot.hand_postures,
            joint_names=motion.joint_names,
            start=start,
            scene=self.checker.scene,
            points=points,
            constraints=constraints,
            report=report,
        )


_WORKER_SESSIONS: dict[tuple[str, tuple[tuple[str, str], ...]], PlanningSession] = {}


def worker_session(robot: str, hands: Mapping[str, str] | None = None) -> PlanningSession:
    """This process's session for `robot` with `hands`, built on first use, so that a worker (a
    sweep's, the service's, a task runner) loads a robot and its collision model once, not once per
    request. It holds the scene and constraints its last user set: set both before planning."""
    key = (robot, tuple(sorted((hands or {}).items())))
    if key not in _WORKER_SESSIONS:
        _WORKER_SESSIONS[key] = PlanningSession(robot, hands=dict(hands) if hands else None)
    return _WORKER_SESSIONS[key]
