"""Planning sessions: build the robot and collision structures once, then re-plan.

The motion-manager workflow of the seed framework: perception moves objects and people, the
task changes constraints and goals, and each `plan` reuses the robot model and collision
geometry. A session is safe by default: near people a motion is timed to ISO/TS 15066 with the
ontology's policy for them (their `roles`, else bystanders) unless the caller passes its own
policy or `safety=None`. It remembers where the robot is (`configuration`: set by perception or
by the end of the last solved plan), so a task can be continued from there. A session is not thread-safe, and neither are two sessions of one robot in two threads
(pinocchio data of a loaded robot and OMPL's global seed are shared): plan in parallel with
processes.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from time import perf_counter
from typing import Literal

import numpy as np
from pydantic import BaseModel, model_validator

from hriplan import HriplanError
from hriplan.collector import freeze_after_first_plan
from hriplan.planner.constraints.binding import BoundConstraint, bind, resolve_frame, set_goal_positions
from hriplan.planner.constraints.evaluator import ConstraintEvaluator
from hriplan.planner.constraints.spec import ConstraintSet, ConstraintSpec, OrientationConstraint
from hriplan.planner.leave import leave_path
from hriplan.planner.motion import (
    JointTarget,
    MotionResult,
    Target,
    ToolTarget,
    motion_group,
    plan_motion,
    with_keep_out,
)
from hriplan.planner.options import PlanOptions
from hriplan.planner.outcome import Status
from hriplan.planner.replay import MotionSetting
from hriplan.planner.search.seeds import ompl_seed
from hriplan.planner.timing import TimedPath, at_rest, joined, time_parameterize
from hriplan.planner.trajectory import ResolvedConstraint, TrajectoryFile, TrajectoryReport, timed_points
from hriplan.planner.validate import PathValidation, densify, validate_path
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.descriptions.registry import DEFAULT_ROBOT, robot_name
from hriplan.robots.human import HumanSpec
from hriplan.robots.ik import solve_two_arms
from hriplan.robots.model import JointValues, Robot, load_robot
from hriplan.robots.scene import Scene
from hriplan.robots.spatial import Pose, Transform
from hriplan.safety.approach import ApproachMonitor
from hriplan.safety.policy import default_policy
from hriplan.safety.report import separation_report
from hriplan.safety.separation import SeparationPolicy

# Knot spacing handed to the time parameteriser, then a denser retry if re-validation fails.
TIMING_STEPS = (0.05, 0.01)
# Where the timed motion still leaves the validated path (its spline rounds a corner into an
# obstacle or out of a band), it comes to rest at the waypoint nearest where it left: the motions
# on either side are timed apart, so no spline crosses that corner. At most this many such rests,
# then a rest at every corner: each piece is then a straight line of the validated path.
RESTS = 4
ALREADY_THERE = "already there: the start is the goal (a trajectory of one point, at rest)"
# Re-plans (within the time limit) when a valid path cannot be timed: its shortcuts can graze an
# obstacle so closely that the smooth timed motion, which rounds their corners, touches it.
TIMING_RETRIES = 2
# `safety=` default of `plan` and `time`: the ontology's ISO/TS 15066 policy for the scene's people.
ONTOLOGY = "ontology"
Safety = SeparationPolicy | Literal["ontology"] | None


def _retry_seed(seed: int | None, retry: int) -> int | None:
    """A re-plan's seed: reproducible from the run's seed, and not another run's first seed."""
    return None if seed is None else -ompl_seed(seed, retry) - 2**31


class PlanResult(BaseModel):
    """A planned motion and, only when solved, its validated timed trajectory; before it, the
    leave phase that first moved the start out of a keep-out volume or a person's S_0, if any."""

    status: Status
    motion: MotionResult
    trajectory: TrajectoryFile | None = None
    message: str = ""
    leave: TrajectoryFile | None = None

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
        self,
        robot: str | Robot = DEFAULT_ROBOT,
        scene: Scene | None = None,
        hands: dict[str, str] | None = None,
        roles: Mapping[str, str] | None = None,
    ) -> None:
        self.robot = robot if isinstance(robot, Robot) else load_robot(robot_name(robot), hands)
        self.checker = CollisionChecker(self.robot, scene or Scene())
        self.constraints: dict[str, ConstraintSpec] = {}
        # Each person's role (ontology: Receiver, Giver, ...): their ISO/TS 15066 values; others are bystanders.
        self.roles: dict[str, str] = dict(roles or {})
        # Where the robot is (every joint): perceived, or where the last solved plan ends; None: unknown.
        self.configuration: dict[str, float] | None = None

    # -- perception and task updates (no rebuild) ------------------------------------------
    def move_obstacle(self, name: str, pose: Pose) -> None:
        self.checker.move_obstacle(name, pose)

    def pose_human(self, spec: HumanSpec) -> None:
        self.checker.pose_human(spec)

    def set_scene(self, scene: Scene) -> None:
        self.checker.set_scene(scene)

    def set_configuration(self, values: Mapping[str, float]) -> None:
        """Where the robot is now (perceived joint values on top of the last known, or of the
        robot's neutral values): a task continued on this session starts there."""
        known = None if self.configuration is None else self.robot.configuration(self.configuration)
        q = self.robot.configuration(dict(values), base=known)  # names and values checked
        self.configuration = dict(zip(self.robot.joint_names, q.tolist()))

    def policy(self, safety: Safety = ONTOLOGY) -> SeparationPolicy | None:
        """The ISO/TS 15066 policy a plan is timed with: `safety` itself if given (None: no speed
        limit), by default the ontology's for the scene's people (by `roles`; none without people)."""
        if safety != ONTOLOGY:
            return safety
        humans = self.checker.scene.humans
        if not humans:
            return None
        names = {h.name for h in humans}
        return default_policy(self.robot.name, humans, {n: r for n, r in self.roles.items() if n in names})

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

    def check_people_clear(self, start: JointValues) -> None:
        """A person placed in the robot (a position typed wrong) is a mistake in the input, not
        something to plan around: one line naming the person and the part they overlap (the
        deepest pair), and how many pairs do."""
        q = self.robot.configuration(start)
        for person in self.checker.humans:
            pairs = self.checker.person_distances(q, person)
            overlapping = np.flatnonzero(pairs.distance <= 0.0)
            if overlapping.size:
                k = overlapping[np.argmin(pairs.distance[overlapping])]
                others = f" (and {overlapping.size - 1} more pairs)" if overlapping.size > 1 else ""
                raise HriplanError(
                    f"{person} overlaps the robot at the start: their {pairs.capsules[k]} is inside "
                    f"{pairs.parts[k]}{others}; place {person} farther from the robot"
                )

    def resolve(self, constraints: Iterable[ConstraintSpec]) -> list[ResolvedConstraint]:
        """The enabled constraints with their frames placed in the session's scene (a person's
        hand, an obstacle), as a trajectory planned here would record them."""
        return _resolved(bind(list(constraints), self.robot, self.checker))

    def setting(
        self,
        start: JointValues,
        velocity_scale: float = 1.0,
        safety: Safety = ONTOLOGY,
        unknown_start: frozenset[str] = frozenset(),
    ) -> MotionSetting:
        """Where a motion made elsewhere (a ROS JointTrajectory) is checked as one planned here
        would be: from `start` (joints not given at the robot's neutral values, as `plan`), in
        the session's scene, under its constraints and its ISO/TS 15066 policy by `safety`."""
        q = self.robot.configuration(start)
        return MotionSetting(
            robot=self.robot.name,
            hands=self.robot.hand_postures,
            start=dict(zip(self.robot.joint_names, q.tolist())),
            scene=self.checker.scene,
            constraints=self.resolve(self.constraints.values()),
            policy=self.policy(safety),
            velocity_scale=velocity_scale,
            unknown_start=unknown_start,
        )

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
        safety: Safety = ONTOLOGY,
    ) -> PlanResult:
        """Plan, validate densely, time-parameterise and re-validate the timed path; a solved
        plan's end becomes the session's `configuration`.

        The motion keeps ISO/TS 15066 speed and separation from the scene's people (and fails,
        with the reason, where it cannot): by default with the ontology's policy (`policy()`),
        else with the `safety` policy given; `safety=None` turns the speed limits off. A start
        inside a keep-out volume or a person's S_0 first gets its leave phase (`leave`), and the
        motion starts where that ends."""
        options = options or PlanOptions()
        safety = self.policy(safety)
        group = motion_group(self.robot, goal, group)
        result = self._planned(start, goal, options, group, safety)
        if result.status != Status.INVALID_START:
            return result
        leave = self.leave(start, options, group, safety)  # only here: a valid start costs nothing more
        if leave is None:
            return result
        if not leave.solved:
            return leave
        end = leave.trajectory.start | dict(zip(leave.trajectory.joint_names, leave.trajectory.points[-1].positions))
        return self._planned(end, goal, options, group, safety).model_copy(update={"leave": leave.trajectory})

    def _planned(
        self, start: JointValues, goal: Target, options: PlanOptions, group: str, safety: SeparationPolicy | None
    ) -> PlanResult:
        """Plan and time from `start`, re-planned (within the time limit) while it cannot be timed."""
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
        if result.solved:
            last = result.trajectory.points[-1].positions
            self.configuration = dict(result.trajectory.start) | dict(zip(result.trajectory.joint_names, last))
        return result

    def leave(
        self,
        start: JointValues,
        options: PlanOptions | None = None,
        group: str | None = None,
        safety: Safety = ONTOLOGY,
    ) -> PlanResult | None:
        """The leave phase of `group` from `start` (planner/leave.py): None when the start lies in
        no keep-out volume and no person's S_0; else the motion out, timed and validated under
        the session's constraints but the keep-outs it leaves, every timed point re-checked to
        come no closer to anyone, or the one-line reason why there is no way out."""
        options, group = options or PlanOptions(), group or self.robot.default_group
        safety = self.policy(safety)
        q0 = self.robot.configuration(start) if isinstance(start, dict) else self.robot.configuration(start, group)
        bound = bind(list(self.constraints.values()), self.robot, self.checker)
        started = perf_counter()
        found = leave_path(self.robot, self.checker, bound, group, q0, safety)
        if found is None:
            return None
        motion = MotionResult(
            planning_time=perf_counter() - started,
            status=Status.SOLVED if found.path else Status.INVALID_START,
            message=found.message,
            group=group,
            joint_names=self.robot.group_joints(group),
            start=dict(zip(self.robot.joint_names, q0.tolist())),
            path=[x.tolist() for x in found.path or []],
        )
        if found.path is None:
            return PlanResult(status=Status.INVALID_START, motion=motion, message=found.message)
        everything = self.constraints
        self.constraints = {i: c for i, c in everything.items() if i not in found.left}
        try:  # timed to ISO/TS 15066's own S_0: the padding keeps motions towards people off it,
            # and the leave, checked below to come closer to no one, starts inside it
            result = self.time(motion, options, _without_padding(safety))
        finally:
            self.constraints = everything
        if not result.solved:
            return result.model_copy(update={"message": f"the leave phase could not be timed: {result.message}"})
        timed = [p.positions for p in result.trajectory.points]
        breach = found.receding(timed, 0.0 if safety is None else safety.margin.padding)
        if breach:
            message = f"the timed leave phase comes closer {breach}"
            return PlanResult(status=Status.TIMING_FAILED, motion=motion, message=message)
        return result

    def time(self, motion: MotionResult, options: PlanOptions | None = None, safety: Safety = ONTOLOGY) -> PlanResult:
        """Time a planned motion and validate the timed samples against the session's constraints
        and scene, every joint outside the planned group at the motion's start. The timing keeps
        ISO/TS 15066 speed and separation from the scene's people by `safety` as in `plan`."""
        options = options or PlanOptions()
        safety = self.policy(safety)
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
            # A path made outside the planner (a lift, a retreat) is validated first, as the planner's are.
            given = None if motion.validation else validate_path(evaluator, self.checker, path, options.validation_step)
            if given is not None and not given.valid:
                return PlanResult(status=Status.INVALID_PATH, motion=motion, message=f"the path breaks {given.message}")
            timed, check, message = self._time_and_check(path, evaluator, motion.group, options, monitor)
        if timed is None:
            return PlanResult(status=Status.TIMING_FAILED, motion=motion, message=message)
        trajectory = self._file(motion, path, bound, timed, check, options, evaluator.full(path[0]))
        if monitor is not None:
            report = trajectory.report.model_copy(
                update={
                    "separation": separation_report(monitor, timed.positions, timed.velocities),
                    "safety_margin": safety.margin,
                }
            )
            trajectory = trajectory.model_copy(update={"report": report})
        # The process's robot, kernels and caches are made: once, out of full collections (collector.py).
        freeze_after_first_plan()
        # Not validated again: its motion and file are models already, and validating a file as a
        # field re-runs its check of every point (~0.09 ms a timing; tests/planner/test_timed_built.py).
        return PlanResult.model_construct(
            status=Status.SOLVED,
            motion=motion,
            trajectory=trajectory,
            message=ALREADY_THERE if len(timed.times) == 1 else "",
        )

    def _time_and_check(
        self,
        path: np.ndarray,
        evaluator: ConstraintEvaluator,
        group: str,
        options: PlanOptions,
        monitor: ApproachMonitor | None = None,
    ) -> tuple[TimedPath | None, PathValidation | None, str]:
        """TOPP-RA on the validated path (slowed near people by `monitor`), then dense validation;
        where the timed motion leaves the path, again with rests at its corners (RESTS). A path
        that does not move (start equal to goal) is one state at rest, validated like any other."""

        velocity = self.robot.velocity_limit(group)
        known = self.robot.description.acceleration_limits
        acceleration = np.array([known.get(j, options.acceleration_limit) for j in self.robot.group_joints(group)])

        def timed_with(step: float, rests: list[int]) -> TimedPath:
            ends = [0, *rests, len(path) - 1]
            return joined(
                [
                    time_parameterize(
                        densify(path[a : b + 1], step),
                        velocity,
                        acceleration,
                        velocity_scale=options.velocity_scale,
                        speed_scale=None if monitor is None else monitor.speed_scale,
                    )
                    for a, b in zip(ends, ends[1:])
                ]
            )

        def checked(timed: TimedPath) -> PathValidation:
            positions = np.array(timed.positions)
            return validate_path(evaluator, self.checker, positions, options.validation_step, human_distance=True)

        path = path[np.concatenate([[True], np.abs(np.diff(path, axis=0)).max(axis=1, initial=0.0) > 1e-9])]
        if len(path) == 1:
            check = checked(at_rest(path[0]))
            return (
                (at_rest(path[0]), check, "") if check.valid else (None, None, f"the start is invalid: {check.message}")
            )
        message, check = "", None
        for step in TIMING_STEPS:
            try:
                timed = timed_with(step, [])
            except HriplanError as exc:
                message = str(exc)
                continue
            check = checked(timed)
            if check.valid:
                return timed, check, ""
            message = f"the timed trajectory left the validated path: {check.message}"
        rests: list[int] = []
        while check is not None and not check.valid:
            more = _corners(path) if len(rests) >= RESTS else _rest_near(path, rests, check.failed_state)
            if more == rests:
                break
            rests = more
            try:
                timed = timed_with(TIMING_STEPS[-1], rests)
            except HriplanError as exc:
                return None, None, str(exc)
            check = checked(timed)
            if check.valid:
                return timed, check, ""
            message = (
                f"the timed trajectory left the validated path even at rest at {len(rests)} of its waypoints: "
                f"{check.message}"
            )
        return None, None, message

    def _file(self, motion, path, bound, timed, check, options, q0) -> TrajectoryFile:
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
            rests=timed.rests,
        )
        points = timed_points(timed.times, timed.positions, timed.velocities, timed.accelerations)
        fields = {
            "robot": self.robot.name,
            "robot_file": self.robot.description.source,
            "hands": dict(self.robot.hand_postures),  # the file's own, as validation copies them
            "joint_names": list(motion.joint_names),
            "start": dict(zip(self.robot.joint_names, q0.tolist())),
            "scene": self.checker.scene,
            "points": points,
            "constraints": _resolved(bound),
            "report": report,
        }
        # Every number finite (checked where the TimedPath was made) and a value per joint named: not
        # validated again, the session's own models and samples timed from rest to rest (times
        # from 0 increasing); validation re-reads every point (~0.07 ms a UR5 motion;
        # tests/planner/test_timed_built.py). Else it refuses the file, with the first fault.
        if points and len(points[0].positions) == len(motion.joint_names):
            return TrajectoryFile.model_construct(**fields)
        return TrajectoryFile(**fields)


def _resolved(bound: Iterable[BoundConstraint]) -> list[ResolvedConstraint]:
    """Bound constraints as a trajectory records them: each frame's pose in the world."""
    return [
        ResolvedConstraint(
            spec=c.spec,
            frame_in_world=Pose.from_se3(c.frame),
            goal_position=None if c.p_goal is None else c.p_goal.tolist(),
        )
        for c in bound
    ]


def _without_padding(safety: SeparationPolicy | None) -> SeparationPolicy | None:
    """`safety` with no padding on S_0 (its speed factor kept)."""
    if safety is None:
        return None
    return safety.model_copy(update={"margin": safety.margin.model_copy(update={"padding": 0.0})})


def _corners(path: np.ndarray) -> list[int]:
    """The waypoints inside `path` where its direction changes."""
    d = np.diff(path, axis=0)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return [int(i) + 1 for i in np.flatnonzero(np.einsum("ij,ij->i", d[:-1], d[1:]) < 1.0 - 1e-9)]


def _rest_near(path: np.ndarray, rests: list[int], state: list[float] | None) -> list[int]:
    """`rests` and the waypoint inside `path` (not yet a rest) nearest `state`, where the timed
    motion left the validated path."""
    free = [i for i in range(1, len(path) - 1) if i not in rests]
    if state is None or not free:
        return rests
    nearest = min(free, key=lambda i: float(np.abs(path[i] - np.asarray(state)).max()))
    return sorted([*rests, nearest])


_WORKER_SESSIONS: dict[tuple[str, tuple[tuple[str, str], ...]], PlanningSession] = {}


def worker_session(robot: str, hands: Mapping[str, str] | None = None) -> PlanningSession:
    """This process's session for `robot` with `hands`, built on first use, so that a worker (a
    sweep's, the service's, a task runner) loads a robot and its collision model once, not once per
    request. It holds the scene and constraints its last user set: set both before planning."""
    key = (robot, tuple(sorted((hands or {}).items())))
    if key not in _WORKER_SESSIONS:
        _WORKER_SESSIONS[key] = PlanningSession(robot, hands=dict(hands) if hands else None)
    return _WORKER_SESSIONS[key]
