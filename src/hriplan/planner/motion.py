"""Plan one constrained motion: checks, goal resolution, OMPL, dense validation.

The path from a start and a goal to a validated joint path:
bind constraints -> check the start for collision -> resolve the goal (joint values, or a tool
pose by IK; this fixes the dynamic tolerances' goal positions) -> check the start against the
constraints -> choose rows and validity for the formulation -> OMPL (and simplification) ->
validate densely -> straighten arms that need not wander -> result.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Iterator, Sequence
from typing import TYPE_CHECKING, Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from hriplan import HriplanError
from hriplan.planner.constraints.binding import BoundConstraint, bind, set_goal_positions
from hriplan.planner.constraints.evaluator import ConstraintEvaluator
from hriplan.planner.constraints.keep_out import keep_out_obstacles
from hriplan.planner.constraints.projection import project
from hriplan.planner.constraints.slack import SlackRows
from hriplan.planner.constraints.spec import Axis, ConstraintSpec
from hriplan.planner.options import PlanOptions, check_options
from hriplan.planner.outcome import Status
from hriplan.planner.search.arm_shortcut import arm_subgroups, straighten_arms
from hriplan.planner.start_zones import start_zones
from hriplan.planner.validate import VALIDATION_TOLERANCE, PathValidation, densify, validate_path
from hriplan.robots.collision import ZONE_NAMING, CollisionChecker, SeparationZones, listed_contacts
from hriplan.robots.ik import solve_ik
from hriplan.robots.kernel_switch import kernels_on
from hriplan.robots.model import JointValues, Robot
from hriplan.robots.spatial import Pose
from hriplan.safety.separation import SeparationPolicy

if TYPE_CHECKING:
    from hriplan.planner.search.cbirrt import BandProblem
    from hriplan.planner.search.result import SearchResult

# Planning keeps this much inside every band so that chords between planned states stay valid.
PLANNING_MARGIN = 2e-3
# Straightening an arm is checked on every this-many-th dense state before all of them.
SPARSE_FIRST = 16
# Dead-zone rows project this far inside a band, so a projected state is valid for planning.
BAND_OFFSET = 2 * PLANNING_MARGIN


class JointTarget(BaseModel):
    """Joint values to reach: by name (any joints; the others keep the start's), or a list in the
    planned group's order. Task files' goals (tasks/model.py) resolve to these targets."""

    model_config = ConfigDict(extra="forbid")
    type: Literal["joints"] = "joints"
    values: dict[str, float] | list[float]


class ToolTarget(BaseModel):
    """A tool pose for one arm, reached by IK (the first valid solution nearest the start)."""

    model_config = ConfigDict(extra="forbid")
    type: Literal["tool_pose"] = "tool_pose"
    arm: str
    pose: Pose
    free_axes: list[Axis] = Field(default_factory=list)


# What a motion reaches (a problem file's `goal`), chosen by its `type` field.
Target = Annotated[JointTarget | ToolTarget, Field(discriminator="type")]


class MotionResult(BaseModel):
    status: Status
    message: str = ""
    group: str
    joint_names: list[str]
    start: dict[str, float] = Field(default_factory=dict)  # every joint of the robot where the path starts
    path: list[list[float]] = Field(default_factory=list)  # validated waypoints, group order
    validation: PathValidation | None = None
    planning_time: float = 0.0
    space: str = ""
    calls: dict[str, int] = Field(default_factory=dict)
    start_moved: float = 0.0  # how far the start was projected (0 unless project_start)

    @property
    def solved(self) -> bool:
        return self.status == Status.SOLVED


class _Problem:
    """The pieces one planning call shares: evaluator, checker and the validity policy."""

    def __init__(
        self, robot: Robot, checker: CollisionChecker, bound: list[BoundConstraint], group: str, q: np.ndarray
    ):
        self.robot, self.checker, self.group = robot, checker, group
        self.evaluator = ConstraintEvaluator(robot, bound, group, q)

    def margins(self, x: np.ndarray) -> np.ndarray:
        return self.evaluator.margins(self.evaluator.full(x)) if self.evaluator.constraints else np.zeros(0)

    def describe_violations(self, x: np.ndarray) -> str:
        margins = self.margins(x)
        bad = [f"{c.id} by {m:.4f}" for c, m in zip(self.evaluator.constraints, margins) if m > VALIDATION_TOLERANCE]
        return ", ".join(bad)

    def describe_collisions(self, x: np.ndarray) -> str:
        return listed_contacts(self.checker.contacts(self.evaluator.full(x)))

    def collision_message(self, what: str, x: np.ndarray) -> str:
        """ "start is in collision: ...", or, if only people's minimum separations are entered, that."""
        contacts = self.checker.contacts(self.evaluator.full(x))
        listed = listed_contacts(contacts)
        if contacts and all(ZONE_NAMING in c.a + c.b for c in contacts):
            return f"{what} is inside a person's minimum separation of ISO/TS 15066 (the robot would have to stand still): {listed}"
        return f"{what} is in collision: {listed}"

    def validity(self, limit: float):
        """State validity for planning: collision free and every margin <= limit."""
        evaluator, checker = self.evaluator, self.checker
        has_constraints = bool(evaluator.constraints)

        def is_valid(x: np.ndarray) -> bool:
            q = evaluator.full(x)
            if has_constraints and evaluator.margins(q).max() > limit:
                return False
            return not checker.in_collision(q)

        return is_valid


@contextlib.contextmanager
def with_keep_out(
    checker: CollisionChecker, bound: list[BoundConstraint], separation: SeparationZones | None = None
) -> Iterator[None]:
    """The checker with the keep-out zones of `bound` added as obstacles and the people's
    `separation` zones (safety/zones.py), for the block's duration (one build)."""
    zones = keep_out_obstacles(bound)
    if not zones and separation is None:
        yield
        return
    scene, before = checker.scene, checker.zones
    checker.set_world(scene.model_copy(update={"obstacles": [*scene.obstacles, *zones]}), separation)
    try:
        yield
    finally:
        checker.set_world(scene, before)


def _check_group(robot: Robot, bound: list[BoundConstraint], group: str) -> None:
    planned = set(robot.group_joints(group))
    for c in bound:
        outside = [j for j in c.spec.joints if j not in planned]
        if outside:
            raise HriplanError(
                f"constraint {c.id!r} uses joints outside the planned group {group!r}: {', '.join(outside)}"
            )


def motion_group(robot: Robot, goal: Target, group: str | None) -> str:
    """The group a motion plans: the one given, else a tool goal's own arm, else the whole robot."""
    return group or (robot.arm_group(goal.arm) if isinstance(goal, ToolTarget) else robot.default_group)


def plan_motion(
    robot: Robot,
    checker: CollisionChecker,
    constraints: Sequence[ConstraintSpec],
    start: JointValues,
    goal: Target,
    options: PlanOptions | None = None,
    group: str | None = None,
    safety: SeparationPolicy | None = None,
) -> MotionResult:
    """Plan a constrained, collision-free motion of `group` from `start` to `goal`. With `safety`,
    the moving parts keep ISO/TS 15066's minimum separation from people (safety/zones.py)."""
    options = options or PlanOptions()
    group = motion_group(robot, goal, group)
    joint_names = robot.group_joints(group)
    q_start = robot.configuration(start) if isinstance(start, dict) else robot.configuration(start, group)
    check_options(options)
    bound = bind(constraints, robot, checker)
    _check_group(robot, bound, group)
    full_start = dict(zip(robot.joint_names, q_start.tolist()))

    def result(status: Status, message: str) -> MotionResult:
        return MotionResult(status=status, message=message, group=group, joint_names=joint_names, start=full_start)

    separation = start_zones(checker, robot, safety, group, q_start)
    # The joints outside the group stay at the start: the pairs they alone place are asked once.
    with with_keep_out(checker, bound, separation), checker.moving(group, q_start):
        problem = _Problem(robot, checker, bound, group, q_start)
        x_start = robot.group_values(q_start, group)
        if checker.in_collision(q_start):
            return result(Status.INVALID_START, problem.collision_message("start", x_start))
        # The goal first: it fixes p_goal, so the start is checked at its own dynamic tolerance.
        goal_or_error = _resolve_goal(problem, goal, x_start)
        if isinstance(goal_or_error, MotionResult):
            return goal_or_error.model_copy(update={"group": group, "joint_names": joint_names, "start": full_start})
        x_goal = goal_or_error
        moved = 0.0
        if problem.describe_violations(x_start):
            if not options.project_start:
                return result(
                    Status.INVALID_START,
                    f"start violates {problem.describe_violations(x_start)} (set project_start to move it onto the constraints)",
                )
            projected = project(
                x_start,
                lambda x: problem.evaluator.deadzone(x, PLANNING_MARGIN),
                lambda x: problem.evaluator.deadzone_jacobian(x, PLANNING_MARGIN),
            )
            if projected is None or checker.in_collision(problem.evaluator.full(projected)):
                return result(
                    Status.INVALID_START,
                    f"start violates {problem.describe_violations(x_start)} and cannot be projected onto the constraints",
                )
            moved, x_start = float(np.abs(projected - x_start).max()), projected
        outcome = _search(problem, options, x_start, x_goal)
        planned_start = dict(zip(robot.joint_names, problem.evaluator.full(x_start).tolist()))
        return outcome.model_copy(
            update={"group": group, "joint_names": joint_names, "start_moved": moved, "start": planned_start}
        )


def _set_goal_positions(problem: _Problem, x_goal: np.ndarray) -> None:
    set_goal_positions(problem.robot, problem.evaluator.constraints, problem.evaluator.full(x_goal))


def _resolve_goal(problem: _Problem, goal: Target, x_start: np.ndarray) -> np.ndarray | MotionResult:
    robot, group = problem.robot, problem.group
    blank = {"group": group, "joint_names": []}
    if isinstance(goal, JointTarget):
        base = problem.evaluator.full(x_start)
        q_goal = (
            robot.configuration(goal.values, base=base)
            if isinstance(goal.values, dict)
            else robot.configuration(goal.values, group, base=base)
        )
        x_goal = robot.group_values(q_goal, group)
        _set_goal_positions(problem, x_goal)
        if problem.checker.in_collision(q_goal):
            return MotionResult(status=Status.INVALID_GOAL, message=problem.collision_message("goal", x_goal), **blank)
        if problem.describe_violations(x_goal):
            return MotionResult(
                status=Status.INVALID_GOAL, message=f"goal violates {problem.describe_violations(x_goal)}", **blank
            )
        return x_goal
    arm_group = robot.arm_group(goal.arm)
    if not set(robot.group_joints(arm_group)) <= set(robot.group_joints(group)):
        raise HriplanError(f"a tool goal for the {goal.arm} arm needs its joints in the planned group {group!r}")
    base = problem.evaluator.full(x_start)

    def valid(q: np.ndarray) -> bool:
        x = robot.group_values(q, group)
        _set_goal_positions(problem, x)
        return not problem.checker.in_collision(q) and not problem.describe_violations(x)

    def why_invalid(q: np.ndarray) -> list[str]:
        x = robot.group_values(q, group)
        return [f"collides: {c.a} - {c.b}" for c in problem.checker.contacts(q)] + [
            f"violates {v.split(' by ')[0]}" for v in problem.describe_violations(x).split(", ") if v
        ]

    ik = solve_ik(
        robot,
        goal.arm,
        goal.pose.matrix(),
        free_axes=goal.free_axes,
        base_q=base,
        reference=robot.group_values(base, arm_group),
        is_valid=valid,
        why_invalid=why_invalid,
    )
    if not ik.success:
        return MotionResult(
            status=Status.UNREACHABLE_GOAL, message=f"no valid IK solution for the goal pose: {ik.message}", **blank
        )
    x_goal = robot.group_values(robot.configuration(ik.q, arm_group, base=base), group)
    _set_goal_positions(problem, x_goal)
    return x_goal


def _rows(problem: _Problem, options: PlanOptions):
    """(function, jacobian, count) for the manifold, or None to plan in the plain joint space."""
    evaluator = problem.evaluator
    if options.space == "rejection" or not evaluator.constraints:
        return None
    if options.formulation == "slack":
        return None  # the slack rows live on an augmented space: see _solve
    if options.formulation == "deadzone":
        return (
            lambda x: evaluator.deadzone(x, BAND_OFFSET),
            lambda x: evaluator.deadzone_jacobian(x, BAND_OFFSET),
            len(evaluator.constraints),
        )
    if evaluator.n_equality == 0:
        return None
    return evaluator.equality, evaluator.equality_jacobian, evaluator.n_equality


def _onto_manifold(problem: _Problem, rows, x: np.ndarray, step: float) -> np.ndarray | None:
    """Project an end onto the manifold if it is not on it; None if the move there is invalid."""
    if rows is None or np.abs(rows[0](x)).max(initial=0.0) <= 1e-6:
        return x
    projected = project(x, rows[0], rows[1])
    if projected is None:
        return None
    return projected if validate_path(problem.evaluator, problem.checker, [x, projected], step).valid else None


def _search(problem: _Problem, options: PlanOptions, x_start: np.ndarray, x_goal: np.ndarray) -> MotionResult:
    rows = _rows(problem, options)
    inside = options.space != "rejection" and (
        options.formulation in ("hybrid", "slack") or options.planner == "CBiRRT"
    )
    limit = -PLANNING_MARGIN if inside else 0.0
    is_valid = problem.validity(limit)
    blank = {"group": problem.group, "joint_names": []}
    ends = [_onto_manifold(problem, rows, x, options.validation_step) for x in (x_start, x_goal)]
    if ends[0] is None:
        return MotionResult(
            status=Status.INVALID_START,
            message="the start cannot be moved onto the constraint manifold validly",
            **blank,
        )
    if ends[1] is None:
        return MotionResult(
            status=Status.INVALID_GOAL, message="the goal cannot be moved onto the constraint manifold validly", **blank
        )
    for name, x in (("start", ends[0]), ("goal", ends[1])):
        if not is_valid(x):
            status = Status.INVALID_START if name == "start" else Status.INVALID_GOAL
            reason = (
                problem.describe_violations(x)
                or problem.describe_collisions(x)
                or f"within {PLANNING_MARGIN} of a constraint boundary"
            )
            return MotionResult(status=status, message=f"{name} is not valid for planning: {reason}", **blank)
    started = time.perf_counter()
    # Why the last attempt failed, as the code that knew it said: the search, or dense validation here.
    status, message = Status.TIMEOUT, "time limit reached"
    calls: dict[str, int] = {}
    attempt = 0
    while True:
        remaining = options.time_limit - (time.perf_counter() - started)
        if remaining <= 0.0:
            break
        run = _solve(problem, options.model_copy(update={"time_limit": remaining}), ends, is_valid, rows, attempt)
        for key, value in vars(run.counters).items():
            calls[key] = calls.get(key, 0) + value
        attempt += 1
        if not run.solved:
            status, message = run.status, run.message
            if run.status == Status.PLANNER_ERROR:
                break
            continue
        for states in [
            s for s in (run.states, run.unsimplified) if s
        ]:  # if a shortcut cut a corner: the planner's own path
            waypoints = _dedupe([x_start, *states, x_goal])
            validation = validate_path(problem.evaluator, problem.checker, waypoints, options.validation_step)
            if validation.valid:
                waypoints, validation = _straighten_arms(problem, options, waypoints, validation, limit)
                return MotionResult(
                    status=Status.SOLVED,
                    group=problem.group,
                    joint_names=[],
                    path=[w.tolist() for w in waypoints],
                    validation=validation,
                    planning_time=time.perf_counter() - started,
                    space=run.space,
                    calls=calls,
                )
            status = Status.INVALID_PATH
            message = f"planner path failed dense validation ({validation.message}); re-planning"
    if status == Status.TIMEOUT:
        message += _what_binds(problem, ends[0], ends[1], options.validation_step)
    return MotionResult(
        status=status,
        message=message,
        group=problem.group,
        joint_names=[],
        planning_time=time.perf_counter() - started,
        calls=calls,
        space=options.space,
    )


def _what_binds(problem: _Problem, x_start: np.ndarray, x_goal: np.ndarray, step: float) -> str:
    """Why a search may have found nothing, for its message: the constraints the straight joint
    line from start to goal leaves (by how much) and what it first collides with; '' if nothing."""
    check = validate_path(problem.evaluator, problem.checker, [x_start, x_goal], step)
    broken = [f"{c.id} (by {c.max_violation:.3g})" for c in check.constraints if not c.satisfied]
    what = ([f"leaves {', '.join(broken)}"] if broken else []) + (
        [f"collides ({check.collision})"] if check.collision else []
    )
    return f"; the straight joint line to the goal {' and '.join(what)}" if what else ""


def _straighten_arms(
    problem: _Problem, options: PlanOptions, waypoints: list[np.ndarray], validation: PathValidation, limit: float
) -> tuple[list[np.ndarray], PathValidation]:
    """Arm-wise shortcuts of a validated path (see arm_shortcut): an arm is straightened only if
    every dense state stays collision free with every margin <= `limit`, as planned states are."""
    arms = arm_subgroups(problem.robot, problem.group)
    if not arms or not options.simplify:
        return waypoints, validation
    is_valid = problem.validity(limit)

    def path_valid(path: list[np.ndarray]) -> bool:  # a sparse pass first: most rejections cost a few states
        dense = densify(path, options.validation_step)
        return all(is_valid(x) for x in dense[::SPARSE_FIRST]) and all(is_valid(x) for x in dense)

    straightened = straighten_arms(waypoints, arms, path_valid)
    if np.array_equal(straightened, waypoints):
        return waypoints, validation
    straightened = _dedupe(straightened)
    again = validate_path(problem.evaluator, problem.checker, straightened, options.validation_step)
    return (straightened, again) if again.valid else (waypoints, validation)


def _solve(
    problem: _Problem, options: PlanOptions, ends: list[np.ndarray], is_valid, rows, attempt: int
) -> SearchResult:
    """One search (re-plan number `attempt`) by the chosen method: hriplan's CBiRRT, OMPL on slack
    variables, or OMPL. The band planner loads only when a motion is planned, OMPL only when it
    plans one (not for CBiRRT, the default)."""
    from hriplan.planner.search.seeds import ompl_seed

    bounds = problem.robot.limits(problem.group)
    if options.planner == "CBiRRT":
        from hriplan.planner.search.cbirrt import plan_in_bands

        seed = None if options.seed is None else ompl_seed(options.seed, attempt)
        return plan_in_bands(_band_problem(problem, options), ends[0], ends[1], options.time_limit, seed)
    from hriplan.planner.search.ompl_solver import solve_with_ompl

    if options.formulation == "slack" and options.space != "rejection" and problem.evaluator.constraints:
        slack, n = SlackRows(problem.evaluator), problem.evaluator.n
        run = solve_with_ompl(
            options,
            slack.bounds(bounds),
            slack.lift(ends[0]),
            slack.lift(ends[1]),
            lambda xs: is_valid(xs[:n]),
            (slack.function, slack.jacobian, slack.k),
            attempt,
        )
        run.states = [s[:n] for s in run.states]
        run.unsimplified = [s[:n] for s in run.unsimplified]
        return run
    return solve_with_ompl(options, bounds, ends[0], ends[1], is_valid, rows, attempt)


def _band_problem(problem: _Problem, options: PlanOptions) -> BandProblem:
    from hriplan.planner.search.cbirrt import BandProblem

    evaluator, checker = problem.evaluator, problem.checker
    bounds = problem.robot.limits(problem.group)
    walker = None
    if kernels_on():  # the compiled loop where the terms and joints are compiled (band_kernels.py)
        from hriplan.planner.search.band_kernels import BandWalker

        walker = BandWalker.of(evaluator, bounds)
    return BandProblem(
        lambda x: evaluator.margins(evaluator.full(x)),
        evaluator.gradients,
        lambda x: not checker.in_collision(evaluator.full(x)),
        bounds,
        BAND_OFFSET,
        PLANNING_MARGIN,
        options.delta,
        bool(evaluator.constraints),
        walker,
        lambda x: checker.compiled_verdict(evaluator.full(x)),
    )


def _dedupe(states: Sequence[np.ndarray]) -> list[np.ndarray]:
    """`states` less each that is within 1e-9 (every joint) of the last one kept. Neighbours are
    compared in one numpy pass; a state is compared again only after one was dropped (a
    search's path repeats its start and goal: ~4 us a state compared one by one)."""
    rows = np.array(states, dtype=float)
    close = (np.abs(np.diff(rows, axis=0)).max(axis=1, initial=0.0) <= 1e-9).tolist()
    kept = [0]
    for k in range(1, len(rows)):
        last = kept[-1]
        if not (close[k - 1] if last == k - 1 else np.abs(rows[k] - rows[last]).max() <= 1e-9):
            kept.append(k)
    return list(rows[kept])
