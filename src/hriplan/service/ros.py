"""Trajectories in the shape of ROS 2 `trajectory_msgs/msg/JointTrajectory` (as JSON).

Field names and types follow the message definitions, so a bridge can fill the message
field by field: `time_from_start` is a `builtin_interfaces/Duration` of whole seconds and
nanoseconds, `effort` stays empty (hriplan plans kinematics only).
"""

from __future__ import annotations

import math

from pydantic import BaseModel, Field

from hriplan.planner.trajectory import TrajectoryFile


class Duration(BaseModel):
    """builtin_interfaces/Duration (and Time): sec int32, nanosec uint32 in [0, 1e9)."""

    sec: int
    nanosec: int = Field(ge=0, lt=1_000_000_000)


class Header(BaseModel):
    stamp: Duration = Field(default_factory=lambda: Duration(sec=0, nanosec=0))
    frame_id: str = ""


class JointTrajectoryPoint(BaseModel):
    positions: list[float]
    velocities: list[float]
    accelerations: list[float]
    effort: list[float] = Field(default_factory=list)
    time_from_start: Duration


class JointTrajectory(BaseModel):
    header: Header = Field(default_factory=Header)
    joint_names: list[str]
    points: list[JointTrajectoryPoint]


def duration(seconds: float) -> Duration:
    """Seconds as whole seconds + nanoseconds, rounded to the nearest nanosecond."""
    total = round(seconds * 1e9)
    sec = math.floor(total / 1e9)
    return Duration(sec=sec, nanosec=total - sec * 1_000_000_000)


def joint_trajectory(trajectory: TrajectoryFile) -> JointTrajectory:
    """The planned group's joints and timed points; the header is left empty (stamp 0: start on receipt)."""
    points = [
        JointTrajectoryPoint(
            positions=p.positions,
            velocities=p.velocities,
            accelerations=p.accelerations,
            time_from_start=duration(p.time_from_start),
        )
        for p in trajectory.points
    ]
    return JointTrajectory(joint_names=trajectory.joint_names, points=points)
