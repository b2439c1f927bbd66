"""Arm-wise shortcuts: straighten one arm's joints over a stretch of the path, the others unchanged.

OMPL's shortcuts move all joints at once or one joint at a time. When two arms are planned
together, a random tree swings the arm that need not move (its goal is its start) by a radian
and more, and no all-joint shortcut removes that while the other arm needs its detour. Here
each arm group inside the planned group (from the robot's description) gets its joints replaced
by the straight line between the ends of a stretch, first the whole path, then random stretches,
kept only where the changed stretch stays densely valid.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

import numpy as np

from hriplan.robots.model import Robot

# Random stretches tried per arm after the whole path (each costs one dense validation).
STRETCH_TRIES = 8

Accept = Callable[[list[np.ndarray]], bool]


def arm_subgroups(robot: Robot, group: str) -> list[np.ndarray]:
    """Positions, in the group's vector, of each smaller joint group contained in `group`."""
    joints = robot.group_joints(group)
    out = []
    for name in robot.groups:
        members = robot.group_joints(name)
        if len(members) < len(joints) and set(members) <= set(joints):
            out.append(np.array([joints.index(j) for j in members]))
    return out


def _straightened(path: np.ndarray, arm: np.ndarray, i: int, j: int) -> np.ndarray | None:
    """`path` with the `arm` joints of waypoints i..j on the line between their values at i and j,
    advancing with the path's own progress (its joint-space arc length)."""
    lengths = np.linalg.norm(np.diff(path[i : j + 1], axis=0), axis=1)
    total = lengths.sum()
    if total <= 1e-12:
        return None
    fraction = np.concatenate([[0.0], np.cumsum(lengths) / total])
    out = path.copy()
    out[i : j + 1, arm] = path[i, arm] + fraction[:, None] * (path[j, arm] - path[i, arm])
    return out


def shortcut_arms(
    path: Sequence[np.ndarray], arms: list[np.ndarray], stretch_valid: Accept, deadline: float, rng: np.random.Generator
) -> list[np.ndarray]:
    """The path with arm-wise shortcuts applied wherever `stretch_valid` accepts the changed
    stretch (a list of waypoints); stops at `deadline`."""
    current = np.array(path, dtype=float)
    m = len(current)
    for arm in arms:
        stretches = [(0, m - 1)] + [tuple(sorted(rng.choice(m, 2, replace=False))) for _ in range(STRETCH_TRIES if m > 2 else 0)]
        for i, j in stretches:
            if time.perf_counter() > deadline:
                return list(current)
            candidate = _straightened(current, arm, i, j)
            if candidate is None or np.abs(candidate[i : j + 1, arm] - current[i : j + 1, arm]).max() < 1e-9:
                continue
            if stretch_valid(list(candidate[i : j + 1])):
                current = candidate
    return list(current)
