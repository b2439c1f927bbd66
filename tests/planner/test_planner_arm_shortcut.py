"""Arm-wise straightening on synthetic paths: what changes, what must not."""

import numpy as np

from hriplan.planner.search.arm_shortcut import arm_subgroups, straighten_arms
from hriplan.robots.model import load_robot


def test_arm_subgroups_come_from_the_robot_description(madar):
    left, right = sorted(arm_subgroups(madar, "both_arms"), key=lambda idx: idx[0])
    names = madar.group_joints("both_arms")
    assert [names[i] for i in left] == madar.group_joints("left_arm")
    assert [names[i] for i in right] == madar.group_joints("right_arm")
    assert arm_subgroups(madar, "right_arm") == [] and arm_subgroups(load_robot("ur5"), "arm") == []


def test_a_wandering_arm_is_straightened_only_where_the_path_stays_valid():
    t = np.linspace(0.0, 1.0, 21)[:, None]
    mover = np.hstack([t, 2 * t])  # arm A moves straight
    wanderer = np.hstack([np.sin(np.pi * t), np.zeros_like(t)])  # arm B leaves and comes back
    path = list(np.hstack([mover, wanderer]))
    arms = [np.array([0, 1]), np.array([2, 3])]
    seen = []
    out = np.array(straighten_arms(path, arms, lambda p: seen.append(p) or True))
    assert len(seen) == 1  # arm A was already straight: not even tried
    assert np.allclose(out[:, :2], mover) and np.abs(out[:, 2:]).max() < 1e-12
    kept = np.array(straighten_arms(path, arms, lambda p: False))
    assert np.allclose(kept, np.array(path))
