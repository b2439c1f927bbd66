"""`CollisionChecker.moving` (robots/still_pairs.py): within a motion of some joints, the pairs it
cannot move are asked once, at the base, and every answer stays the full check's.

On random states of a group (MADAR's arms, the UR5's wrist or whole arm) in scenes with people
and obstacles, with the kernels off and on: `in_collision`, `first_collision` and `contacts`
equal the full check's; a still pair colliding at the base makes every state collide and is
named; a state off the base is asked where it is; leaving the block (also by an exception, or
a nested block) leaves the checker as it was; a person or obstacle moved within the block is
seen where it is.
"""

from __future__ import annotations

import numpy as np
import pytest

from hriplan.robots.collision import CollisionChecker
from hriplan.robots.human import HumanSpec
from hriplan.robots.model import load_robot
from hriplan.robots.scene import Box, Cylinder, Obstacle, Scene
from hriplan.robots.spatial import Pose
from madar_states import CLEAR

STATES = 400


@pytest.fixture(scope="module")
def madar():
    return load_robot("madar", hand_postures={"right": "power"})


@pytest.fixture(scope="module")
def ur5():
    return load_robot("ur5")


def _scene(near: tuple[float, float]) -> Scene:
    """A table, a post and two people about the robot's reach."""
    x, y = near
    return Scene(
        obstacles=[
            Obstacle(name="table", shape=Box(size=(0.6, 0.8, 0.05)), pose=Pose(xyz=(x, y, 0.55))),
            Obstacle(name="post", shape=Cylinder(radius=0.05, height=0.6), pose=Pose(xyz=(-x - y, x + y, 0.9))),
        ],
        humans=[
            HumanSpec(name="bob", position=(x * 1.5, y * 1.5), yaw=np.pi),
            HumanSpec(name="kim", position=(-y * 1.4 - 0.2, x * 1.4), yaw=0.0, margin=0.05),
        ],
    )


def _states(robot, entries, base: np.ndarray, n: int, seed: int) -> np.ndarray:
    """`n` states with `entries` drawn within their limits, the rest at `base`."""
    model = robot.model
    states = np.repeat(base[None], n, axis=0)
    low, high = model.lowerPositionLimit[entries], model.upperPositionLimit[entries]
    states[:, entries] = np.random.default_rng(seed).uniform(low, high, (n, len(entries)))
    return states


def _full_answers(checker: CollisionChecker, states: np.ndarray) -> tuple[list[bool], list[int | None], list]:
    collides = [checker.in_collision(q) for q in states]
    firsts = [checker.first_collision(states[k : k + 40]) for k in range(0, len(states), 40)]
    contacts = [checker.contacts(q) for q in states[:60]]
    return collides, firsts, contacts


def _answers_in(checker, joints, base, states):
    with checker.moving(joints, base):
        return _full_answers(checker, states)


def _madar_base(robot) -> np.ndarray:
    return robot.configuration(CLEAR)


CASES = {
    "madar right arm": ("madar", "right_arm", (0.0, 1.0)),
    "madar left arm": ("madar", "left_arm", (0.0, 1.0)),
    "ur5 wrist": ("ur5", [3, 4, 5], (0.45, 0.1)),
    "ur5 arm": ("ur5", "arm", (0.45, 0.1)),
}


@pytest.mark.parametrize("case", CASES)
def test_answers_in_a_motion_are_the_full_checks(case, madar, ur5, either_route):
    """Random states of the group, at two bases (one where the still parts are clear, one
    random): the same answers as the full check, and both answers occur."""
    name, joints, near = CASES[case]
    robot = madar if name == "madar" else ur5
    checker = CollisionChecker(robot, _scene(near))
    entries = robot.group_indices(joints) if isinstance(joints, str) else np.array(joints)
    bases = [_madar_base(robot) if name == "madar" else np.array([0.0, -1.2, 1.0, 0.0, 0.0, 0.0])]
    bases.append(_states(robot, np.arange(robot.model.nq), bases[0], 1, 3)[0])
    for k, base in enumerate(bases):
        states = _states(robot, entries, base, STATES, 7 + k)
        full = _full_answers(checker, states)
        assert _answers_in(checker, joints, base, states) == full
        if k == 0:
            assert 0.05 < np.mean(full[0]) < 0.95  # both answers occur
    with checker.moving(joints, bases[0]):
        held = len(checker._view.still)
    assert held >= (100 if name == "madar" else 20)  # the people against what stays


def test_a_still_pair_colliding_at_the_base_makes_every_state_collide(madar, either_route):
    """A box on MADAR's left hand while the right arm moves: every state collides, the first
    state is the first collision, and `contacts` names the box and the hand as the full check does."""
    checker = CollisionChecker(madar, _scene((0.0, 1.0)))
    base = _madar_base(madar)
    hand = madar.frame_pose(madar.tool_frame("left"), base)[:3, 3]
    states = _states(madar, madar.group_indices("right_arm"), base, 60, 11)
    scene = checker.scene
    blocked = scene.model_copy(
        update={
            "obstacles": [
                *scene.obstacles,
                Obstacle(name="crate", shape=Box(size=(0.1, 0.1, 0.1)), pose=Pose(xyz=tuple(hand))),
            ]
        }
    )
    checker.set_scene(blocked)
    full = _full_answers(checker, states)
    assert all(full[0]) and any(c.a == "crate" or c.b == "crate" for c in full[2][0])
    assert _answers_in(checker, "right_arm", base, states) == full
    with checker.moving("right_arm", base):
        assert checker.first_collision(states) == 0
        named = checker.contacts(states[5])
    assert any("left" in c.a + c.b and "crate" in c.a + c.b for c in named)


def test_a_state_off_the_base_is_asked_where_it_is(madar, either_route):
    """Within a motion of the right arm, states whose left arm is elsewhere (a misuse): the
    base's left hand in a box, states with it out of the box are free where the full check says
    so; the base clear, a state with the left hand moved into the box collides."""
    checker = CollisionChecker(madar, Scene())
    base = _madar_base(madar)
    left = madar.group_indices("left_arm")
    states = _states(madar, madar.group_indices("right_arm"), base, 80, 12)
    away = states.copy()
    away[:, left] = _states(madar, left, base, 80, 13)[:, left]
    hand = madar.frame_pose(madar.tool_frame("left"), base)[:3, 3]
    crate = Obstacle(name="crate", shape=Box(size=(0.12, 0.12, 0.12)), pose=Pose(xyz=tuple(hand)))
    for scene in (Scene(obstacles=[crate]), Scene()):
        checker.set_scene(scene)
        mixed = np.concatenate([away[:40], states[:40], away[40:]])
        full = _full_answers(checker, mixed)
        assert _answers_in(checker, "right_arm", base, mixed) == full
    # The box where the left hand is at one off-base state: the first collision among free states at the base.
    moved = away[0].copy()
    checker.set_scene(
        Scene(
            obstacles=[
                crate.model_copy(
                    update={"pose": Pose(xyz=tuple(madar.frame_pose(madar.tool_frame("left"), moved)[:3, 3]))}
                )
            ]
        )
    )
    assert checker.in_collision(moved)
    free = states[[not checker.in_collision(q) for q in states]]
    ordered = np.concatenate([free[:10], moved[None], free[10:20]])
    full = _full_answers(checker, ordered)
    with checker.moving("right_arm", base):
        assert checker.in_collision(moved)
        assert checker.first_collision(ordered) == full[1][0] == 10
    assert _answers_in(checker, "right_arm", base, ordered) == full


def _state_of(checker: CollisionChecker) -> tuple:
    """What the per-state checks ask: active pairs, geometries in the broad phase, tables."""
    return (
        list(checker.geom_data.activeCollisionPairs),
        [g.disableCollision for g in checker.geom_model.geometryObjects],
        [table for table, _ in checker._tabled],
        checker._broadphase,
    )


def test_leaving_restores_the_checks_also_on_an_exception(madar, either_route):
    checker = CollisionChecker(madar, _scene((0.0, 1.0)))
    base = _madar_base(madar)
    states = _states(madar, madar.group_indices("right_arm"), base, 100, 14)
    full = _full_answers(checker, states)
    before = _state_of(checker)
    with checker.moving("right_arm", base):
        inside = _state_of(checker)
        assert sum(inside[0]) < sum(before[0]) and any(inside[1]) and len(inside[2]) < len(before[2])
        checker.contacts(states[0])  # asks every pair, then leaves the motion's checks as they were
        assert _state_of(checker) == inside
    assert _state_of(checker) == before
    with pytest.raises(RuntimeError), checker.moving("right_arm", base):
        checker.in_collision(states[0])
        raise RuntimeError("planning failed")
    assert _state_of(checker) == before
    with checker.moving("right_arm", base):  # nested: the inner block's leaving restores the outer's
        outer = _state_of(checker)
        with checker.moving("left_arm", base):
            assert _state_of(checker) != outer
        assert _state_of(checker) == outer
    assert _state_of(checker) == before and _full_answers(checker, states) == full


def test_a_scene_changed_within_the_block_is_where_it_is(madar, either_route):
    """A person stepping into MADAR's left arm, an obstacle moved onto it, another scene: each
    seen at once by the still pairs' answer at the base; and the build left is restored when
    asked again."""
    checker = CollisionChecker(madar, _scene((0.0, 1.0)))
    base = _madar_base(madar)
    states = _states(madar, madar.group_indices("right_arm"), base, 40, 15)
    elbow = madar.frame_pose("left_fore_arm_link", base)[:3, 3]
    with checker.moving("right_arm", base):
        assert not all(checker.in_collision(q) for q in states)
        checker.pose_human(HumanSpec(name="kim", position=(elbow[0], elbow[1]), yaw=0.0))
        assert all(checker.in_collision(q) for q in states)
        checker.pose_human(HumanSpec(name="kim", position=(3.0, 3.0), yaw=0.0))
        assert not all(checker.in_collision(q) for q in states)
        checker.move_obstacle("post", Pose(xyz=tuple(elbow)))
        assert checker.first_collision(states) == 0
        scene = checker.scene
        checker.set_scene(Scene())
        assert checker.first_collision(states) == _first(CollisionChecker(madar, Scene()), states)
        checker.set_scene(scene)
        assert checker.first_collision(states) == 0
    checker.set_scene(Scene())
    assert _full_answers(checker, states) == _full_answers(CollisionChecker(madar, Scene()), states)


def _first(checker: CollisionChecker, states: np.ndarray) -> int | None:
    return checker.first_collision(states)


def test_a_block_at_another_base_asks_the_still_pairs_there(madar, either_route):
    """The left hand in a box at one base, out of it at another: blocks at each, one after the
    other and one inside the other, answer as the full check at their own base."""
    checker = CollisionChecker(madar, Scene())
    base = _madar_base(madar)
    hand = madar.frame_pose(madar.tool_frame("left"), base)[:3, 3]
    checker.set_scene(
        Scene(obstacles=[Obstacle(name="crate", shape=Box(size=(0.1, 0.1, 0.1)), pose=Pose(xyz=tuple(hand)))])
    )
    other = base.copy()
    other[madar.group_indices("left_arm")[0]] += 0.8  # the left arm turned away from the box
    right = madar.group_indices("right_arm")
    at_base, at_other = _states(madar, right, base, 30, 16), _states(madar, right, other, 30, 16)
    full = _full_answers(checker, at_base), _full_answers(checker, at_other)
    assert all(full[0][0]) and not all(full[1][0])
    assert _answers_in(checker, "right_arm", base, at_base) == full[0]
    assert _answers_in(checker, "right_arm", other, at_other) == full[1]
    with checker.moving("right_arm", base):
        assert _answers_in(checker, "right_arm", other, at_other) == full[1]
        assert _full_answers(checker, at_base) == full[0]
