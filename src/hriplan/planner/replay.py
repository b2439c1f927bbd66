"""The planned world rebuilt from a trajectory file alone: robot, people, bound constraints, states.

A trajectory file is self-contained (robot, hand postures, start configuration, scene, resolved
constraints), so the viewer, the plots and `hriplan validate` need nothing else. Constraints are
bound again with the planner's own code so that margins are exactly the ones the validator
computes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hriplan import HriplanError
from hriplan.planner.constraints.binding import BoundConstraint, bind, set_goal_positions
from hriplan.planner.constraints.evaluator import ConstraintEvaluator
from hriplan.planner.motion import with_keep_out
from hriplan.planner.trajectory import TrajectoryFile
from hriplan.planner.validate import PathValidation, validate_path
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.model import Robot, load_robot
from hriplan.safety.approach import ApproachMonitor
from hriplan.safety.separation import SPEED_LIMIT_SLACK, SeparationPolicy


@dataclass(frozen=True)
class SpeedCheck:
    kept: bool
    message: str


@dataclass
class PlannedWorld:
    trajectory: TrajectoryFile
    robot: Robot
    checker: CollisionChecker
    constraints: list[BoundConstraint]

    @classmethod
    def load(cls, trajectory: TrajectoryFile) -> PlannedWorld:
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
    @property
    def times(self) -> np.ndarray:
        return np.array([p.time_from_start for p in self.trajectory.points])

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    @property
    def positions(self) -> np.ndarray:
        """Planned joint values at the trajectory's points (rows), in `joint_names` order."""
        return np.array([p.positions for p in self.trajectory.points])

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
        return np.array([evaluator.margins(self.planning_q(row)) for row in self.positions]).reshape(
            len(self.trajectory.points), len(self.constraints)
        )

    def human_distances(self) -> list[tuple[float, str, str]]:
        """(distance, robot part, person part) of the closest robot-person pair at every point."""
        return [self.checker.human_distance(self.planning_q(row)) for row in self.positions]

    def group(self) -> str:
        group = next((g for g in self.robot.groups if self.robot.group_joints(g) == self.trajectory.joint_names), None)
        if group is None:
            raise HriplanError(f"the trajectory's joints are not a joint group of {self.robot.name!r}")
        return group

    def speed_check(self, policy: SeparationPolicy) -> SpeedCheck:
        """ISO/TS 15066 speed and separation at every written point and velocity, for `policy`."""
        monitor = ApproachMonitor(self.robot, self.checker, policy, self.group(), self.planning_q(self.positions[0]))
        velocities = np.array([p.velocities for p in self.trajectory.points])
        try:
            scales = monitor.speed_scale(self.positions, velocities)
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
        sample = min(monitor.samples(self.positions[k], velocities[k]), key=lambda s: s.scale)  # the person who binds
        return SpeedCheck(
            kept=False,
            message=(
                f"{1 / scales[k]:.2f}x the speed allowed towards {sample.capsule} ({sample.part}, {sample.separation:.3f} m away) "
                f"at t={self.times[k]:.2f} s"
            ),
        )

    def validate(self, step: float = 0.01) -> PathValidation:
        """Dense validation of the timed points, as the planner validated its path."""
        group = self.group()
        evaluator = ConstraintEvaluator(self.robot, self.constraints, group, self.planning_q(self.positions[0]))
        with with_keep_out(self.checker, self.constraints):
            return validate_path(evaluator, self.checker, list(self.positions), step)
