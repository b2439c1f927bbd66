"""The retreat after a release (planner/lift.py) reuses its collision checkers across re-plans:
given the new scene, a reused checker answers as a new one built for it would."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hriplan.planner.lift import _checker
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.descriptions.registry import posture
from hriplan.robots.human import HumanSpec
from hriplan.robots.model import load_robot
from hriplan.robots.scene import Box, Obstacle, Scene
from hriplan.robots.spatial import Pose


def _scene(can_at: tuple[float, float, float], person_x: float) -> Scene:
    """A released can where the hand let it go, and the person it was handed to."""
    can = Obstacle(name="can", shape=Box(size=(0.07, 0.07, 0.12)), pose=Pose(xyz=can_at))
    person = HumanSpec(name="bob", position=(person_x, 1.4), yaw=-math.pi / 2)
    return Scene(obstacles=[can], humans=[person])


@pytest.fixture(scope="module")
def states() -> tuple[object, np.ndarray]:
    """The right arm swept from the ready posture towards the front, 120 states."""
    robot = load_robot("madar", {"right": "open"})
    q0 = robot.configuration(posture("madar", "ready"))
    x0 = robot.group_values(q0, "right_arm")
    xs = np.linspace(x0, x0 + np.array([0.9, -0.5, 0.6, 0.3, -0.2, 0.5]), 120)
    return robot, np.array([robot.configuration(x, "right_arm", base=q0) for x in xs])


def _answers(checker: CollisionChecker, qs: np.ndarray) -> list[tuple]:
    closest = checker.human_distances(qs)
    return [(checker.in_collision(q), checker.touches(q, "can"), round(d, 9)) for q, (d, _, _) in zip(qs, closest)]


def test_a_reused_checker_answers_for_the_scene_it_was_given(states):
    robot, qs = states
    first, moved = _scene((0.37, 0.64, 1.06), 0.0), _scene((0.63, 0.63, 1.18), 0.15)
    checker = _checker(robot, first, "free")
    before = _answers(checker, qs)
    assert before == _answers(CollisionChecker(robot, first), qs)
    again = _checker(robot, moved, "free")  # the next re-plan: the can and the person elsewhere
    assert again is checker
    after = _answers(again, qs)
    assert after == _answers(CollisionChecker(robot, moved), qs)
    assert after != before  # the scenes differ where the arm passes
    assert any(a[1] for a in after) and any(a[0] for a in after)  # it reaches the can
    # Another kind of scene, or another robot (another hand posture), has a checker of its own.
    assert _checker(robot, moved, "touching") is not checker
    closed = load_robot("madar", {"right": "power"})
    assert _checker(closed, moved, "free") is not checker
