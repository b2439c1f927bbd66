"""Arm-wise shortcuts: straighten one arm's joints along the whole path, the other joints unchanged.

OMPL's shortcuts move all joints at once or one joint at a time. When two arms are planned
together, a random tree swings the arm that need not move (its goal is its start) by a radian
and more, and no all-joint shortcut removes that while the other arm needs its detour. Here
each arm group inside the planned group (from the robot's description) gets its joints put on
the straight line from their start to their goal values, kept only if the path stays valid.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from hriplan.robots.model import Robot

# An arm whose travel is within this fraction of its straight line is left as it is.
STRAIGHT_ENOUGH = 0.01


def arm_subgroups(robot: Robot, group: str) -> list[np.ndarray]:
    """Positions, in the group's vector, of each smaller joint group contained in `group`."""
    joints = robot.group_joints(group)
    out = []
    for name in robot.groups:
        members = robot.group_joints(name)
        if len(members) < len(joints) and set(members) <= set(joints):
            out.append(np.array([joints.index(j) for j in members]))
    return out


def _travel(values: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(values, axis=0), axis=1).sum())


def _straightened(path: np.ndarray, arm: np.ndarray) -> np.ndarray | None:
    """`path` with the `arm` joints on the line between their first and last values, advancing
    with the path's own progress (its joint-space arc length)."""
    lengths = np.linalg.norm(np.diff(path, axis=0), axis=1)
    total = float(lengths.sum())
    if total <= 1e-12:
        return None
    fraction = np.concatenate([[0.0], np.cumsum(lengths) / total])
    out = path.copy()
    out[:, arm] = path[0, arm] + fraction[:, None] * (path[-1, arm] - path[0, arm])
    return out


def straighten_arms(
    path: Sequence[np.ndarray], arms: list[np.ndarray], path_valid: Callable[[list[np.ndarray]], bool]
) -> list[np.ndarray]:
    """The path with each arm straightened where `path_valid` accepts the result."""
    current = np.array(path, dtype=float)
    for arm in arms:
        if (
            _travel(current[:, arm])
            <= (1.0 + STRAIGHT_ENOUGH) * np.linalg.norm(current[-1, arm] - current[0, arm]) + 1e-9
        ):
            continue  # already (nearly) straight: nothing to gain
        candidate = _straightened(current, arm)
        if candidate is not None and path_valid(list(candidate)):
            current = candidate
    return list(current)
