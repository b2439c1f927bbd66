"""A world rebuilt from a motion (planner/replay.py) walks the controller's states once for all checks."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hriplan.formats.ros_trajectory import PlacedTrajectory
from hriplan.planner.replay import PlannedWorld
from hriplan.planner.spline import Spline
from hriplan.planner.trajectory import TrajectoryPoint
from hriplan.robots.descriptions.registry import posture
from hriplan.robots.human import HumanSpec
from hriplan.robots.model import load_robot
from hriplan.robots.scene import Scene
from hriplan.safety.policy import default_policy


@pytest.fixture(scope="module")
def motion() -> PlacedTrajectory:
    """The right arm from the ready posture, its middle point written with a velocity that makes
    the spline bulge (so spline samples are added between the points), a person nearby."""
    robot = load_robot("madar")
    start = dict(zip(robot.joint_names, robot.configuration(posture("madar", "ready")).tolist()))
    arm = robot.group_joints("right_arm")
    x0 = np.array([start[j] for j in arm])
    moves = [x0, x0 + 0.15, x0 + 0.3]
    velocities = [np.zeros(6), np.full(6, 0.8), np.zeros(6)]
    points = [
        TrajectoryPoint(time_from_start=t, positions=list(x), velocities=list(v), accelerations=[0.0] * 6)
        for t, x, v in zip((0.0, 0.5, 1.0), moves, velocities)
    ]
    person = HumanSpec(name="sam", position=(1.4, 0.6), yaw=math.pi)
    return PlacedTrajectory(
        robot="madar",
        hands={},
        joint_names=arm,
        start=start,
        scene=Scene(humans=[person]),
        points=points,
        constraints=[],
    )


def test_the_checks_walk_one_spline_and_its_states_computed_once(motion, monkeypatch):
    walks = []
    original = Spline.executed_states
    monkeypatch.setattr(Spline, "executed_states", lambda self, *a: walks.append(self) or original(self, *a))
    world = PlannedWorld.load(motion)
    world.joint_check()
    world.speed_check(default_policy("madar", motion.scene.humans, {"sam": "Supervisor"}))
    assert world.validate().valid
    assert len(walks) == 1 and walks[0] is world.spline
    # The states are the spline's, written points and the samples added where it bulges.
    times, positions, velocities = world.executed
    fresh = Spline(
        np.array([p.time_from_start for p in motion.points]),
        np.array([p.positions for p in motion.points]),
        np.array([p.velocities for p in motion.points]),
    )
    expected = original(fresh)
    assert len(times) > len(motion.points)
    for got, want in zip((times, positions, velocities), expected):
        np.testing.assert_array_equal(got, want)
    # Shared by every check, so no caller may change them in place.
    for values in (times, positions, velocities, world.times, world.positions):
        with pytest.raises(ValueError, match="read-only"):
            values[0] = 0.0
