"""The planned world rebuilt from a trajectory file alone: robot, people, bound constraints, states.

A trajectory file is self-contained (robot, hand postures, start configuration, scene, resolved
constraints), so the viewer, the plots and `hriplan validate` need nothing else; a motion made
elsewhere (a ROS JointTrajectory placed in a task step: formats/ros_trajectory.py) has the same
parts. Constraints are bound again with the planner's own code so that margins are exactly the
ones the validator computes. What is checked is what a controller executes: the spline through
the written points (planner/spline.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Protocol

import numpy as np

from hriplan import HriplanError
from hriplan.planner.constraints.binding import BoundConstraint, bind, set_goal_positions
from hriplan.planner.constraints.evaluator import ConstraintEvaluator
from hriplan.planner.motion import with_keep_out
from hriplan.planner.spline import Spline
from hriplan.planner.trajectory import ResolvedConstraint, TrajectoryPoint
from hriplan.planner.validate import PathValidation, validate_path
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.model import Robot, load_robot
from hriplan.robots.scene import Scene
from hriplan.safety.approach import ApproachMonitor
from hriplan.safety.separation import SPEED_LIMIT_SLACK, SeparationPolicy


class Motion(Protocol):
    """What a re-check needs of a motion: a trajectory file (`TrajectoryFile`) has it, and so has
    a ROS JointTrajectory placed in a task step or a problem (`PlacedTrajectory`)."""

    robot: str
    hands: dict[str, str]
    joint_names: list[str]
    start: dict[str, float]  # every joint of the robot at the start
    scene: Scene
    points: list[TrajectoryPoint]
    constraints: list[ResolvedConstraint]


@dataclass(frozen=True)
class MotionSetting:
    """Where a motion made elsewhere is checked, as a planned one would be: the robot (every joint
    at the start), the scene, the constraints placed in it, the ISO/TS 15066 policy (None: no
    one to keep a speed from) and the velocity scale the joint speed limits are taken at.
    `unknown_start` names the joints whose start is not known (an earlier task step moves them,
    and nothing is planned to find where it leaves them): a motion must give them itself."""

    robot: str
    hands: dict[str, str]
    start: dict[str, float]
    scene: Scene
    constraints: list[ResolvedConstraint]
    policy: SeparationPolicy | None
    velocity_scale: float = 1.0
    unknown_start: frozenset[str] = frozenset()


@dataclass(frozen=True)
class SpeedCheck:
    kept: bool
    message: str


@dataclass(frozen=True)
class PlannedWorld:
    """A motion in its world. Frozen, so what is derived from the motion (its times, positions,
    the controller's spline and the states it passes) is computed once, and read-only."""

    trajectory: Motion
    robot: Robot
    checker: CollisionChecker
    constraints: list[BoundConstraint]

    @classmethod
    def load(cls, trajectory: Motion) -> PlannedWorld:
        if not trajectory.points:
            raise HriplanError("the trajectory has no points")
        robot = load_robot(trajectory.robot, trajectory.hands or None)
        unknown = [j for j in [*trajectory.joint_names, *trajectory.start] if j not in robot.joint_names]
        if unknown:
            raise HriplanError(f"robot {robot.name!r} has no arm joint {unknown[0]!r} (named by the trajectory)")
        checker = CollisionChecker(robot, trajectory.scene)
        bound = bind([c.spec for c in trajectory.constraints], robot, checker)
        goals = {c.spec.id: c.goal_position for c in trajectory.constraints}
        world = cls(trajectory, robot, checker, bound)
        set_goal_positions(robot, bound, world.planning_q(world.positions[-1]), goals)  # else where the motion ends
        return world

    # -- time --------------------------------------------------------------------------------
    @cached_property
    def times(self) -> np.ndarray:
        return _read_only(np.array([p.time_from_start for p in self.trajectory.points]))

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    @cached_property
    def positions(self) -> np.ndarray:
        """Planned joint values at the trajectory's points (rows), in `joint_names` order."""
        return _read_only(np.array([p.positions for p in self.trajectory.points]))

    @cached_property
    def spline(self) -> Spline:
        """The path a controller follows through the written points (positions and velocities)."""
        velocities = np.array([p.velocities for p in self.trajectory.points])
        return Spline(self.times, self.positions, _read_only(velocities.reshape(self.positions.shape)))

    @cached_property
    def executed(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Times, positions and velocities of the states the controller passes (`Spline.
        executed_states`), which the speed, joint and dense checks all walk."""
        times, positions, velocities = self.spline.executed_states()
        return _read_only(times), _read_only(positions), _read_only(velocities)

    def positions_at(self, times: np.ndarray) -> np.ndarray:
        """Planned joint values at any times (linear between the timed points, which are dense)."""
        return np.column_stack([np.interp(times, self.times, column) for column in self.positions.T])

    # -- configurations ----------------------------------------------------------------------
    def joint_values(self, row: np.ndarray) -> dict[str, float]:
        """Every arm joint: the planned ones from `row`, the others at the start."""
        return {**self.trajectory.start, **dict(zip(self.trajectory.joint_names, map(float, row)))}

    def planning_q(self, row: np.ndarray) -> np.ndarray:
        return self.robot.configuration(self.joint_values(row))

    def full_q(self, row: np.ndarray) -> np.ndarray:
        """Configuration of the full display model (fingers at their postures)."""
        return self.robot.full_configuration(self.joint_values(row))

    # -- what the validator measures ----------------------------------------------------------
    def margins(self) -> np.ndarray:
        """Margin of every constraint (columns) at every timed point (rows): <= 0 kept."""
        q0 = self.planning_q(self.positions[0])
        evaluator = ConstraintEvaluator(self.robot, self.constraints, self.robot.default_group, q0)
        return evaluator.margins_many(np.array([self.planning_q(row) for row in self.positions]))

    def human_distances(self) -> list[tuple[float, str, str]]:
        """(distance, robot part, person part) of the closest robot-person pair at every point."""
        return self.checker.human_distances(np.array([self.planning_q(row) for row in self.positions]))

    def group(self) -> str:
        group = next((g for g in self.robot.groups if self.robot.group_joints(g) == self.trajectory.joint_names), None)
        if group is None:
            raise HriplanError(f"the trajectory's joints are not a joint group of {self.robot.name!r}")
        return group

    def speed_check(self, policy: SeparationPolicy) -> SpeedCheck:
        """ISO/TS 15066 speed and separation at every written point and spline sample (the states a
        controller passes, with their velocities), for `policy`."""
        monitor = ApproachMonitor(self.robot, self.checker, policy, self.group(), self.planning_q(self.positions[0]))
        times, positions, velocities = self.executed
        try:
            scales = monitor.speed_scale(positions, velocities)
        except HriplanError as exc:  # a moving part inside a person's S_0
            return SpeedCheck(kept=False, message=str(exc))
        k = int(np.argmin(scales))
        if scales[k] >= 1.0 - SPEED_LIMIT_SLACK:
            return SpeedCheck(
                kept=True,
                message=f"at most {1 / scales[k]:.0%} of the speed allowed towards anyone"
                if np.isfinite(scales[k])
                else "no moving part approaches a person",
            )
        sample = min(monitor.samples(positions[k], velocities[k]), key=lambda s: s.scale)  # the person who binds
        return SpeedCheck(
            kept=False,
            message=(
                f"{1 / scales[k]:.2f}x the speed allowed towards {sample.capsule} ({sample.part}, {sample.separation:.3f} m away) "
                f"at t={times[k]:.2f} s"
            ),
        )

    def joint_check(self, velocity_scale: float = 1.0) -> SpeedCheck:
        """Every joint within its position limits and, between every two points, within its speed
        limit times `velocity_scale` (the rules' or the problem's): the mean speed the positions
        imply, then the peak of the controller's spline (SPEED_LIMIT_SLACK allowed, as timing)."""
        group = self.group()
        lower, upper = self.robot.limits(group)
        limit = self.robot.velocity_limit(group) * velocity_scale
        names, spline = self.trajectory.joint_names, self.spline
        times, positions, _ = self.executed
        beyond = np.maximum(lower - positions, positions - upper)
        if beyond.max() > 1e-9:
            k, j = np.unravel_index(np.argmax(beyond), beyond.shape)
            return SpeedCheck(
                False,
                f"{names[j]} at {positions[k, j]:.4f} rad is beyond its limits [{lower[j]:.4g}, {upper[j]:.4g}] rad "
                f"at t={times[k]:.3f} s",
            )
        if len(self.times) == 1:
            return SpeedCheck(True, "positions within their limits, at rest")
        allowed = limit * (1.0 + SPEED_LIMIT_SLACK)
        mean, peak = spline.mean_speeds(), spline.peak_speeds()
        for speeds, what in (
            (mean, "the positions imply"),
            (peak, "the spline through positions and velocities reaches"),
        ):
            if (speeds > allowed).any():
                k, j = np.unravel_index(np.argmax(speeds / limit), speeds.shape)
                t0, t1 = self.times[k], self.times[k + 1]
                moved = self.positions[k + 1, j] - self.positions[k, j]
                return SpeedCheck(
                    False,
                    f"{names[j]} moves {moved:+.4f} rad in {t1 - t0:.4f} s from t={t0:.3f} s: {what} "
                    f"{speeds[k, j]:.3f} rad/s, {speeds[k, j] / limit[j]:.2f}x its limit {limit[j]:.3f} rad/s"
                    + ("" if velocity_scale == 1.0 else f" (velocity scale {velocity_scale:g})"),
                )
        bulge, added = float(spline.bulges().max()), len(times) - len(self.times)
        return SpeedCheck(
            True,
            f"positions within their limits, speeds at most {(peak / limit).max():.0%} of their limits at velocity scale "
            f"{velocity_scale:g}; the controller's spline leaves the straight segments by at most {bulge:.1e} rad"
            + (f" ({added} spline samples checked between the points)" if added else ""),
        )

    def validate(self, step: float = 0.01) -> PathValidation:
        """Dense validation of the path the controller follows (straight between the executed
        states: the written points, plus spline samples where it bulges), as the planner
        validated its path."""
        group = self.group()
        evaluator = ConstraintEvaluator(self.robot, self.constraints, group, self.planning_q(self.positions[0]))
        _, states, _ = self.executed
        with with_keep_out(self.checker, self.constraints):
            return validate_path(evaluator, self.checker, list(states), step)


def _read_only(values: np.ndarray) -> np.ndarray:
    """`values`, which no caller may change in place: a world computes them once for all."""
    values.setflags(write=False)
    return values
