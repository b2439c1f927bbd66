"""Where a task's motions put things: the tools at a configuration, carried objects along a path.

The task runner asks these of the robot model between steps; they live with the planner so
that tasks reason about goals and holdings, not about the kinematics.
"""

from __future__ import annotations

import numpy as np

from hriplan.planner.motion import MotionResult
from hriplan.planner.validate import densify
from hriplan.robots.model import Robot
from hriplan.robots.spatial import Pose

# Spacing of the joint-space samples at which a carried object's path is recorded (rad).
PATH_STEP = 0.05


def tool_poses(robot: Robot, joints: dict[str, float]) -> dict[str, Pose]:
    """World pose of every arm's tool frame at the given joint values."""
    q = robot.configuration(joints)
    return {arm: Pose.from_matrix(robot.frame_pose(robot.tool_frame(arm), q)) for arm in robot.arms}


def carried_paths(
    robot: Robot, start: dict[str, float], motion: MotionResult, carries: dict[str, str]
) -> dict[str, list[tuple[float, float, float]]]:
    """Where each carried object (object -> arm) passes, its centre at its arm's tool frame, every
    PATH_STEP rad of joint motion along the planned path."""
    states = densify(list(np.array(motion.path)), PATH_STEP)
    paths: dict[str, list[tuple[float, float, float]]] = {obj: [] for obj in carries}
    base = robot.configuration(start)  # once: by name, each state cost ~10 us (~200 a re-plan)
    for x in states:
        q = robot.configuration(x, motion.group, base=base)
        for obj, arm in carries.items():
            paths[obj].append(tuple(float(v) for v in robot.frame_pose(robot.tool_frame(arm), q)[:3, 3]))
    return paths
