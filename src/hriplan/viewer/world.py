"""The planned world rebuilt from a trajectory file alone: robot, people, bound constraints, states.

A trajectory file is self-contained (robot, hand postures, start configuration, scene, resolved
constraints), so the viewer and the plots need nothing else. Constraints are bound again with the
planner's own code so that plotted margins are exactly the ones the validator computed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hriplan import HriplanError
from hriplan.planner.evaluator import ConstraintEvaluator
from hriplan.planner.resolve import BoundConstraint, bind
from hriplan.planner.trajectory import TrajectoryFile
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.model import Robot, load_robot


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
        for c in bound:
            if goals.get(c.id) is not None:
                c.p_goal = np.asarray(goals[c.id], dtype=float)
        return cls(trajectory, robot, checker, bound)

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
