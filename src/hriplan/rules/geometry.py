"""Geometry that turns a constraint kind's parameters and the scene into planner frames."""

from __future__ import annotations

import math

import numpy as np

from hriplan import HriplanError
from hriplan.robots.spatial import Pose, cross

AXES = "xyz"


def rotation_with_axis(signed_axis: str, direction: np.ndarray) -> np.ndarray:
    """A rotation whose `signed_axis` column (e.g. "+y", "-z") points along `direction`.

    The other two columns complete a right-handed frame; which completion is irrelevant since
    the constraint leaves the spin about that axis free. For +y and world up this gives the
    columns x = (-1, 0, 0), y = (0, 0, 1), z = (0, 1, 0).
    """
    i = AXES.index(signed_axis[1])
    norm = float(np.linalg.norm(direction))
    if norm < 1e-9:
        raise HriplanError("cannot orient a tool along a zero vector")
    axis = (-1.0 if signed_axis[0] == "-" else 1.0) * np.asarray(direction, dtype=float) / norm
    helper = np.array([0.0, 1.0, 0.0]) if abs(axis[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    following = helper - helper.dot(axis) * axis
    following /= np.linalg.norm(following)
    rotation = np.zeros((3, 3))
    rotation[:, i] = axis
    rotation[:, (i + 1) % 3] = following
    rotation[:, (i + 2) % 3] = cross(axis.tolist(), following.tolist())
    return rotation


def angle_between(a: np.ndarray, b: np.ndarray) -> float:
    """The angle between two non-zero vectors (rad)."""
    cos = float(np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b)))
    return math.acos(max(-1.0, min(1.0, cos)))


def rotation_pose(rotation: np.ndarray) -> Pose:
    matrix = np.eye(4)
    matrix[:3, :3] = rotation
    return Pose.from_matrix(matrix)


def bearing(person_xy: tuple[float, float], person_yaw: float, target_xy: tuple[float, float], who: str) -> float:
    """Direction of a target seen from a person, in the person's frame (0 = straight ahead)."""
    dx, dy = target_xy[0] - person_xy[0], target_xy[1] - person_xy[1]
    if math.hypot(dx, dy) < 1e-6:
        raise HriplanError(f"{who} stands on the robot's base; cannot tell which way the robot is")
    angle = math.atan2(dy, dx) - person_yaw
    return math.atan2(math.sin(angle), math.cos(angle))


def box_between(
    robot_xy: tuple[float, float],
    person_xy: tuple[float, float],
    behind_robot: float,
    before_person: float,
    width: float,
    bottom: float,
    top: float,
    who: str,
) -> tuple[Pose, tuple[float, float, float]]:
    """A box along the line from the robot's base to a person: from `behind_robot` behind the
    base to `before_person` short of the person's body axis, between heights bottom and top."""
    dx, dy = person_xy[0] - robot_xy[0], person_xy[1] - robot_xy[1]
    distance = math.hypot(dx, dy)
    length = distance - before_person + behind_robot
    if length <= 0.0 or top <= bottom:
        raise HriplanError(f"{who} stands {distance:.2f} m from the robot's base: too close for a shared workspace box")
    ux, uy = dx / distance, dy / distance
    middle = (distance - before_person - behind_robot) / 2.0
    centre = (robot_xy[0] + ux * middle, robot_xy[1] + uy * middle, (bottom + top) / 2.0)
    return Pose(xyz=centre, rpy=(0.0, 0.0, math.atan2(uy, ux))), (length, width, top - bottom)
