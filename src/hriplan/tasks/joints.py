"""Joint values a user gives (a task's start and joint goals, a problem's start and goal), checked
against the robot's joint names and limits before any reasoning or planning starts: a goal
beyond a limit can never be reached, and the planner would only find that out at its time limit."""

from __future__ import annotations

import functools
import xml.etree.ElementTree as ET
from collections.abc import Mapping

from hriplan import HriplanError
from hriplan.robots.descriptions.registry import description_of
from hriplan.tasks.model import TaskFile, step_name

LIMIT_TOLERANCE = 1e-9  # rad: values written from a limit may round just past it


@functools.cache
def joint_limits(robot: str) -> dict[str, tuple[float, float]]:
    """(lower, upper) in rad of every planning joint of `robot`, read from its URDF description."""
    description = description_of(robot)
    arm_joints = {j for arm in description.arms.values() for j in arm.joints}
    limits = {}
    for joint in ET.fromstring(description.urdf()).iter("joint"):
        limit = joint.find("limit")
        if joint.get("name") in arm_joints and limit is not None:
            limits[joint.get("name")] = (float(limit.get("lower")), float(limit.get("upper")))
    return limits


def check_joint_values(values: Mapping[str, float], robot: str, what: str) -> None:
    """Every name is a joint of `robot` and every value within its limits, else one line naming it."""
    limits = joint_limits(robot)
    for name, value in values.items():
        if name not in limits:
            raise HriplanError(f"{what}: {name!r} is not a joint of {robot}; its joints: {', '.join(limits)}")
        lower, upper = limits[name]
        if not lower - LIMIT_TOLERANCE <= value <= upper + LIMIT_TOLERANCE:
            raise HriplanError(f"{what}: {name} = {value:.4g} rad is beyond its limits [{lower:.4g}, {upper:.4g}] rad")


def check_task_joints(task: TaskFile) -> None:
    """The task's start joints and every joint goal are joints of its robot, within their limits."""
    check_joint_values(task.start.joints, task.robot, "start.joints")
    for k, step in enumerate(task.steps):
        for goal in [step.goal, *step.goals]:
            joints = getattr(goal, "joints", None)
            if joints is not None:
                check_joint_values(joints, task.robot, f"steps.{k} ({step_name(step, k)}): goal")
