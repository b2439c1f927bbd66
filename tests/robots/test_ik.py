"""Analytic IK: frame conventions, round trips, free axis, branch choice, failures, bad input."""

from __future__ import annotations

import numpy as np
import pytest
import ur_analytic_ik

from hriplan import HriplanError
from hriplan.robots.ik import ik_solutions, solve_ik
from hriplan.robots.model import load_robot

ARMS = [("madar", "right", "right_"), ("madar", "left", "left_"), ("ur5", "arm", "")]


@pytest.fixture(scope="module")
def robots():
    return {"madar": load_robot("madar"), "ur5": load_robot("ur5")}


def random_group_values(robot, group, rng, n):
    lower, upper = robot.limits(group)
    return rng.uniform(lower, upper, (n, len(lower)))


def tool_pose(robot, arm, values):
    return robot.frame_pose(robot.tool_frame(arm), robot.configuration(values, robot.arm_group(arm)))


def pose_error(a, b):
    return np.abs(a - b).max()


@pytest.mark.parametrize("name, arm, prefix", ARMS)
def test_library_frames_and_joints_are_ours(robots, name, arm, prefix):
    robot = robots[name]
    for values in random_group_values(robot, robot.arm_group(arm), np.random.default_rng(0), 20):
        q = robot.configuration(values, robot.arm_group(arm))
        ours = np.linalg.inv(robot.frame_pose(f"{prefix}base_link", q)) @ robot.frame_pose(f"{prefix}wrist_3_link", q)
        assert pose_error(ours, ur_analytic_ik.ur5.forward_kinematics(*values)) < 1e-9


@pytest.mark.parametrize("name, arm, prefix", ARMS)
def test_round_trip_200_random_configurations(robots, name, arm, prefix):
    robot = robots[name]
    failures, worst = 0, 0.0
    for values in random_group_values(robot, robot.arm_group(arm), np.random.default_rng(1), 200):
        target = tool_pose(robot, arm, values)
        result = solve_ik(robot, arm, target)
        if not result.success:
            failures += 1
            continue
        lower, upper = robot.limits(robot.arm_group(arm))
        assert np.all(np.array(result.q) >= lower) and np.all(np.array(result.q) <= upper)
        worst = max(worst, pose_error(tool_pose(robot, arm, result.q), target))
        assert result.position_error < 1e-6 and result.orientation_error < 1e-6
    assert failures == 0
    assert worst < 1e-6


def test_reference_on_the_original_configuration_returns_it(robots):
    robot = robots["madar"]
    for values in random_group_values(robot, "right_arm", np.random.default_rng(2), 50):
        result = solve_ik(robot, "right", tool_pose(robot, "right", values), reference=values)
        assert np.abs(np.array(result.q) - values).max() < 1e-6


def test_reference_picks_the_nearest_branch(robots):
    robot = robots["madar"]
    values = np.array([0.3, -1.2, 1.4, -0.9, 1.1, 0.4])
    target = tool_pose(robot, "right", values)
    branches = ik_solutions(robot, "right", target)
    assert len(branches) == 8
    rng = np.random.default_rng(3)
    for branch in branches:
        result = solve_ik(robot, "right", target, reference=branch + rng.normal(0.0, 0.05, 6))
        assert np.abs(np.array(result.q) - branch).max() < 1e-6


def test_solutions_are_shifted_nearest_the_reference_within_limits(robots):
    robot = robots["madar"]
    values = np.array([0.3, -1.2, 1.4, -0.9, 1.1, 0.4])
    target = tool_pose(robot, "right", values)
    shifted = values + np.array([-2 * np.pi, 2 * np.pi, 0.0, 2 * np.pi, 0.0, -2 * np.pi])
    nearest = ik_solutions(robot, "right", target, reference=shifted)[0]
    assert np.abs(nearest - shifted).max() < 1e-9
    # 0.3 + 2*pi is past the +2*pi limit: the joint stays at 0.3, the nearest value within limits.
    branches = ik_solutions(robot, "right", target, reference=values + [2 * np.pi, 0, 0, 0, 0, 0])
    assert min(np.abs(branch - values).max() for branch in branches) < 1e-9


def test_free_z_axis_keeps_the_approach_direction(robots):
    robot = robots["madar"]
    values = np.array([0.3, -1.2, 1.4, -0.9, 1.1, 0.4])
    target = tool_pose(robot, "right", values)
    reference = values + np.array([0.0, 0.0, 0.0, 0.0, 0.0, 1.0])
    result = solve_ik(robot, "right", target, free_axes=("z",), reference=reference)
    assert result.success
    pose = tool_pose(robot, "right", result.q)
    assert np.abs(pose[:3, 3] - target[:3, 3]).max() < 1e-6
    assert np.abs(pose[:3, 2] - target[:3, 2]).max() < 1e-6
    assert result.orientation_error < 1e-6
    # Spinning about z is free: the result is nearer the spun reference than the exact pose is.
    assert np.linalg.norm(np.array(result.q) - reference) < np.linalg.norm(values - reference)
    assert np.abs(pose[:3, 0] - target[:3, 0]).max() > 0.1


def test_every_solution_about_a_free_axis_keeps_that_axis_whichever_was_asked_before(robots):
    robot = robots["madar"]
    target = tool_pose(robot, "right", np.array([0.3, -1.2, 1.4, -0.9, 1.1, 0.4]))
    for axis, column in (("z", 2), ("x", 0), ("y", 1), ("z", 2)):  # the turns about each are made once
        poses = [tool_pose(robot, "right", q) for q in ik_solutions(robot, "right", target, (axis,))]
        assert len(poses) > 8  # spun: more than the 8 branches of one pose
        assert max(np.abs(p[:3, 3] - target[:3, 3]).max() for p in poses) < 1e-6
        assert max(np.abs(p[:3, column] - target[:3, column]).max() for p in poses) < 1e-6
        assert max(np.abs(p[:3, (column + 1) % 3] - target[:3, (column + 1) % 3]).max() for p in poses) > 0.5


def test_unreachable_target_fails_with_the_distance(robots):
    target = np.eye(4)
    target[:3, 3] = (5.0, 0.0, 1.3)
    result = solve_ik(robots["madar"], "right", target)
    assert not result.success and result.q is None
    assert "out of reach of the right arm" in result.message and "m from the shoulder" in result.message


def test_rejecting_every_solution_fails(robots):
    robot = robots["madar"]
    target = tool_pose(robot, "right", np.array([0.3, -1.2, 1.4, -0.9, 1.1, 0.4]))
    calls = []
    result = solve_ik(robot, "right", target, is_valid=lambda q: calls.append(q.shape) is not None)
    assert not result.success and result.q is None
    assert result.message == f"all {len(calls)} solutions are rejected by is_valid"
    assert calls and all(shape == (robot.model.nq,) for shape in calls)


def test_is_valid_chooses_the_next_nearest_solution(robots):
    robot = robots["madar"]
    values = np.array([0.3, -1.2, 1.4, -0.9, 1.1, 0.4])
    target = tool_pose(robot, "right", values)
    idx = robot.group_indices("right_arm")
    result = solve_ik(robot, "right", target, reference=values, is_valid=lambda q: abs(q[idx][0] - 0.3) > 1e-3)
    assert result.success and abs(result.q[0] - 0.3) > 1e-3
    assert pose_error(tool_pose(robot, "right", result.q), target) < 1e-6


def test_other_joints_come_from_base_q(robots):
    robot = robots["madar"]
    base_q = robot.configuration(np.full(6, 0.7), "left_arm")
    seen = []
    target = tool_pose(robot, "right", np.array([0.3, -1.2, 1.4, -0.9, 1.1, 0.4]))
    solve_ik(robot, "right", target, base_q=base_q, is_valid=lambda q: seen.append(q) is None)
    left = robot.group_indices("left_arm")
    assert np.allclose(seen[0][left], 0.7)


def test_a_last_row_within_rounding_of_0_0_0_1_is_accepted(robots):
    target = np.eye(4)
    target[3] = (5e-9, 0.0, -5e-9, 1.0 + 9e-6)  # within 1e-8 of each 0 and 1e-5 (relative) of the 1
    assert solve_ik(robots["madar"], "right", target).message.startswith("target is out of reach")  # not refused


@pytest.mark.parametrize(
    "target, kwargs, match",
    [
        (np.eye(3), {}, "4x4"),
        (np.full((4, 4), np.nan), {}, "NaN"),
        (np.diag([1.0, 1.0, 2.0, 1.0]), {}, "orthonormal"),
        (np.diag([1.0, 1.0, 1.0, 1.0 + 2e-5]), {}, "last row must be"),
        (np.vstack([np.eye(4)[:3], [2e-8, 0.0, 0.0, 1.0]]), {}, "last row must be"),
        (np.diag([1.0, 1.0, -1.0, 1.0]), {}, "orthonormal"),
        (np.eye(4), {"arm": "middle"}, "no arm 'middle'"),
        (np.eye(4), {"free_axes": ("w",)}, "unknown free axis 'w'"),
        (np.eye(4), {"free_axes": ("x", "z")}, "at most one free axis"),
        (np.eye(4), {"reference": np.zeros(5)}, "reference must be 6 finite numbers"),
        (np.eye(4), {"tolerance": 0.0}, "tolerance must be positive"),
    ],
)
def test_bad_input_raises(robots, target, kwargs, match):
    arm = kwargs.pop("arm", "right")
    with pytest.raises(HriplanError, match=match):
        solve_ik(robots["madar"], arm, target, **kwargs)


def test_ik_solutions_rejects_bad_input(robots):
    with pytest.raises(HriplanError, match="unknown free axis"):
        ik_solutions(robots["madar"], "right", np.eye(4), free_axes=("q",))
