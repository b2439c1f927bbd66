"""A plain-text description of a loaded robot (for `hriplan robot info`)."""

from __future__ import annotations

import collections

import numpy as np

from hriplan.robots.acm import MESH, load_acm
from hriplan.robots.model import Robot
from hriplan.robots.robot_geometry import robot_parts


def describe(robot: Robot) -> str:
    lines = [f"robot {robot.name}: {robot.model.nq} planning joints"]
    if robot.hand_postures:
        lines.append("hands: " + ", ".join(f"{side} {posture}" for side, posture in robot.hand_postures.items()))
    for group, joints in robot.groups.items():
        lines.append(f"group {group} ({len(joints)} joints)")
    lower, upper = robot.limits()
    velocity = robot.velocity_limit()
    lines.append(f"{'joint':28s} {'lower':>8s} {'upper':>8s} {'vel':>6s}")
    for name, lo, hi, v in zip(robot.group_joints(), lower, upper, velocity):
        lines.append(f"{name:28s} {lo:8.3f} {hi:8.3f} {v:6.2f}")
    for arm, (_, tool) in robot.arms.items():
        pose = robot.frame_pose(tool, np.zeros(len(robot.group_joints())))
        lines.append(f"arm {arm}: tool frame {tool} at {np.round(pose[:3, 3], 4).tolist()} (all joints 0)")
    parts = robot_parts(robot)
    kinds = collections.Counter(type(p.geometry).__name__ for p in parts)
    lines.append(f"collision parts: {len(parts)} ({', '.join(f'{n} {k}' for k, n in sorted(kinds.items()))})")
    acm = collections.Counter(load_acm(robot, parts).values())
    meshes = acm.pop(MESH, 0)
    pairs = len(parts) * (len(parts) - 1) // 2
    lines.append(
        f"self-collision pairs: {pairs - sum(acm.values()) - meshes} checked on parts and {meshes} on meshes of {pairs} "
        f"(not checked: {', '.join(f'{n} {k}' for k, n in sorted(acm.items()))})"
    )
    return "\n".join(lines)
