"""Numeric IK near the joint limits and when it fails: mirror-image arms (example-robot-data's
TIAGo Pro) solve the same poses, a joint at a limit is left out of the step that would push it
past, the restarts spread over the limits, and a failure says what is true (which limit, the
orientation, or the distance)."""

from __future__ import annotations

import itertools
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from data_robots import data_robot
from hriplan.robots import ik, numeric_ik, numeric_ik_search
from hriplan.robots.ik import solve_ik

DATA = Path(__file__).parents[1] / "data" / "robots"
FORWARD_X_UP = np.column_stack([[0.0, 0.0, 1.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])  # tool z ahead, x up

pytestmark = pytest.mark.usefixtures("module_robot_registry")


@pytest.fixture(scope="module")
def tiago_pro():
    return data_robot("tiago_pro")


@pytest.fixture(scope="module")
def panda():
    return data_robot("panda")


def ahead(x: float, y: float, z: float) -> np.ndarray:
    target = np.eye(4)
    target[:3, :3], target[:3, 3] = FORWARD_X_UP, (x, y, z)
    return target


def assert_reaches(robot, arm, target, result):
    assert result.success, result.message
    values = np.array(result.q)
    lower, upper = robot.limits(robot.arm_group(arm))
    assert np.all(values >= lower) and np.all(values <= upper)
    reached = robot.frame_pose(robot.tool_frame(arm), values, robot.arm_group(arm))
    assert np.abs(reached - target).max() < 1e-5


def test_tiago_pros_right_arm_reaches_what_its_left_arm_reaches(tiago_pro):
    # The new-user trial's pose: 0.55 m ahead at 0.9 m, every solution with the elbow (joint 4)
    # within 0.03 rad of its limit. The left arm solved it and the right arm did not.
    for arm, y in (("right", -0.2), ("left", 0.2)):
        target = ahead(0.55, y, 0.9)
        assert_reaches(tiago_pro, arm, target, solve_ik(tiago_pro, arm, target))


def test_mirror_image_arms_solve_the_same_poses(tiago_pro):
    solved = {}
    for x, y, z in itertools.product((0.45, 0.55, 0.65), (0.1, 0.2, 0.3), (0.85, 0.9, 0.95, 1.0)):
        solved[x, y, z] = [
            solve_ik(tiago_pro, arm, ahead(x, s * y, z)).success for arm, s in (("right", -1), ("left", 1))
        ]
    differ = [pose for pose, (right, left) in solved.items() if right != left]
    assert differ == [] and sum(right for right, _ in solved.values()) >= 20


def test_a_joint_at_a_limit_is_left_out_of_the_step_that_pushes_it_past(panda):
    chain = numeric_ik.Chain(panda.model, panda.data, 0, np.arange(3), np.arange(3), -np.ones(3), np.ones(3))
    jac = np.array([[1.0, 1.0, 0.0], [0.0, 1.0, 1.0]])  # three joints, two error rows: one to spare
    error = np.array([-0.1, 0.05])
    free = numeric_ik._step(chain, np.zeros(3), jac, error, 0.0)
    at_limit = numeric_ik._step(chain, np.array([-1.0, 0.0, 0.0]), jac, error, 0.0)
    assert free[0] < 0.0  # the first joint would move down ...
    assert at_limit[0] == 0.0  # ... but it sits at its lower limit: the others take its share
    assert np.abs(jac @ at_limit - error).max() < 1e-4
    pulled_in = numeric_ik._step(chain, np.array([-1.0, 0.0, 0.0]), jac, -error, 0.0)
    assert np.allclose(pulled_in, numeric_ik._step(chain, np.zeros(3), jac, -error, 0.0))  # away from it: free


def test_each_target_draws_its_own_restarts(tiago_pro, monkeypatch):
    # One draw shared by every target missed a region near the limits for one arm only; drawn
    # from the target, the same target still gives the same answer.
    chain = numeric_ik_search.chain(tiago_pro, ik._Arm(tiago_pro, "right", None))
    middle = (chain.lower + chain.upper) / 2.0
    drawn = []
    monkeypatch.setattr(numeric_ik, "_descend", lambda c, q, *rest: drawn.append(q[c.idx_q].copy()))

    def starts(target):
        drawn.clear()
        list(numeric_ik.attempts(chain, tiago_pro.q_neutral, target, None, middle, 1e-6, restarts=5))
        return np.array(drawn)

    first, again, other = (
        starts(ahead(0.55, -0.2, 0.9)),
        starts(ahead(0.55, -0.2, 0.9)),
        starts(ahead(0.55, -0.2, 0.95)),
    )
    assert first.shape == (6, 7) and np.allclose(first[0], middle)
    assert np.array_equal(first, again) and np.abs(first[1:] - other[1:]).min() > 0.0
    assert np.all((first >= chain.lower) & (first <= chain.upper))


def test_an_orientation_out_of_reach_is_named_not_the_distance(panda):
    stretched = panda.frame_pose("panda_hand_tcp", np.array([0.0, 1.5, 0.0, -0.1, 0.0, 1.6, 0.0]), "arm")
    back = stretched.copy()
    back[:3, :3] = pin.exp3(np.array([0.0, math.pi, 0.0])) @ stretched[:3, :3]  # pointing back at the base
    result = solve_ik(panda, "arm", back)
    assert not result.success
    assert result.message == (
        "no numeric solution from 31 starts: the position is within reach but not in this orientation: "
        "turn the goal, or free the tool's turn about one axis"
    )
    free_z = solve_ik(panda, "arm", back, free_axes=["z"])
    assert free_z.message.endswith(
        "the position is within reach but not with the tool's z axis this way: turn the goal"
    )


def test_a_pose_beyond_a_joint_limit_names_the_joint_and_its_limits(panda):
    target = panda.frame_pose("panda_hand_tcp", np.array([0.0, 2.2, 0.0, -0.1, 0.0, 1.6, 0.0]), "arm")
    result = solve_ik(panda, "arm", target)
    assert not result.success
    assert result.message.startswith(
        "no numeric solution from 31 starts: none within the joint limits of arm 'arm'; beyond them the pose "
        "is reached with panda_joint2 at 1.7"
    )
    assert result.message.endswith("(limits -1.763 to 1.763)")


def test_a_position_beyond_the_arms_length_says_how_far_it_reaches(panda):
    target = np.eye(4)
    target[:3, 3] = (2.0, 0.0, 0.5)
    assert solve_ik(panda, "arm", target).message == (
        "no numeric solution: the position is out of reach: 2.007 m from the shoulder of arm 'arm', "
        "which reaches at most 1.090 m"  # the Panda's links, joint to joint to the tool, added up
    )


@pytest.mark.parametrize("arm", ["right", "left"])
def test_the_arms_reach_bounds_every_configuration(tiago_pro, panda, arm):
    # the early failure's bound, against pinocchio's forward kinematics on random configurations
    for robot, name in ((tiago_pro, arm), (panda, "arm")):
        info = ik._Arm(robot, name, None)
        group, tool = robot.arm_group(name), robot.tool_frame(name)
        lower, upper = robot.limits(group)
        length = numeric_ik_search.reach(robot, info, name)
        values = np.random.default_rng(3).uniform(lower - 1.0, upper + 1.0, (500, len(lower)))
        farthest = max(float(np.linalg.norm(robot.frame_pose(tool, v, group)[:3, 3] - info.shoulder)) for v in values)
        assert farthest <= length and farthest > 0.7 * length  # a bound, and not a loose one


def test_no_reach_bound_for_joints_out_of_chain_order(panda, monkeypatch):
    # the sum of the distances between joints that are not neighbours in the chain bounds nothing
    arm = panda.description.arms["arm"]
    shuffled = replace(arm, joints=(arm.joints[0], arm.joints[2], arm.joints[1], *arm.joints[3:]))
    monkeypatch.setattr(panda, "description", replace(panda.description, arms={"arm": shuffled}))
    assert numeric_ik_search.reach(panda, ik._Arm(panda, "arm", None), "arm") is None


def test_a_target_beyond_the_arms_length_is_refused_before_any_start(panda, monkeypatch):
    info = ik._Arm(panda, "arm", None)
    length = numeric_ik_search.reach(panda, info, "arm")
    assert length == pytest.approx(1.0897, abs=1e-4)  # the Panda's links, joint to joint to the tool
    monkeypatch.setattr(numeric_ik, "attempts", lambda *a, **k: pytest.fail("a start was paid for"))
    target = np.eye(4)
    target[:3, 3] = info.shoulder + (0.0, 0.0, length + 0.0011)  # just beyond, by more than the tolerance
    assert solve_ik(panda, "arm", target, tolerance=1e-3).message == (
        "no numeric solution: the position is out of reach: 1.091 m from the shoulder of arm 'arm', "
        "which reaches at most 1.090 m"
    )
    monkeypatch.setattr(numeric_ik, "attempts", lambda *a, **k: iter([None]))  # a start that fails
    target[:3, 3] = info.shoulder + (0.0, 0.0, length + 0.0009)  # a solution within the tolerance is not excluded
    assert solve_ik(panda, "arm", target, tolerance=1e-3).message.startswith("no numeric solution from 1 start: ")


def test_a_position_out_of_reach_fails_after_the_first_start(panda, monkeypatch):
    # within the links' sum (1.090 m) but beyond where the Panda's offsets let it reach
    descents = []
    descend = numeric_ik._descend
    monkeypatch.setattr(numeric_ik, "_descend", lambda *a: descents.append(a[4]) or descend(*a))
    target = np.eye(4)
    target[:3, 3] = (1.0, 0.0, 0.4)
    result = solve_ik(panda, "arm", target)
    assert result.message == (
        "no numeric solution from 1 start: the position is out of reach: 1.002 m from the shoulder of arm 'arm'"
    )
    assert len(descents) == 1 + numeric_ik_search.DIAGNOSIS_RESTARTS + 1  # the start, the position alone's starts


def test_among_the_first_starts_the_solution_nearest_the_reference_is_tried_first(panda, monkeypatch):
    reference = np.zeros(7)
    far, near, middle, late = (np.full(7, d) for d in (0.9, 0.1, 0.5, 0.05))
    monkeypatch.setattr(numeric_ik, "attempts", lambda *a, **k: iter([far, None, near, middle, late]))
    search = numeric_ik_search.Search(panda, ik._Arm(panda, "arm", None), "arm", np.eye(4), None, reference, 1e-6)
    order = list(search.candidates())
    assert [v[0] for v in order] == [0.1, 0.5, 0.9, 0.05]  # the first four starts ranked, the rest as found
    close = np.full(7, 0.15)  # within NEAR of the reference: taken without paying for more starts
    monkeypatch.setattr(numeric_ik, "attempts", lambda *a, **k: iter([close, near, late]))
    search = numeric_ik_search.Search(panda, ik._Arm(panda, "arm", None), "arm", np.eye(4), None, reference, 1e-6)
    assert next(search.candidates())[0] == 0.15 and search.starts == 1


def test_solve_ik_returns_the_nearest_of_the_first_starts_solutions_not_the_seeds(panda):
    # a planner's start far from the goal: the seed's own descent ends 5 rad away, a restart nearer
    q = np.array([1.0, -0.7, 2.17, -1.08, -2.13, 3.17, 2.58])
    reference = np.array([2.34, 0.25, -2.05, -2.49, 2.48, 2.06, -1.85])
    target = panda.frame_pose("panda_hand_tcp", q, "arm")
    search = numeric_ik_search.Search(panda, ik._Arm(panda, "arm", None), "arm", target, None, reference, 1e-6)
    first = [v for v in itertools.islice(search.attempts(), numeric_ik_search.PREFERRED_STARTS) if v is not None]
    distances = [float(np.linalg.norm(v - reference)) for v in first]
    result = solve_ik(panda, "arm", target, reference=reference)
    assert_reaches(panda, "arm", target, result)
    assert distances[0] > 5.0 and min(distances) < 3.6  # the seed's solution, and a nearer one
    assert np.linalg.norm(np.array(result.q) - reference) == pytest.approx(min(distances), abs=1e-5)
