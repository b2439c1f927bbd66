"""Trajectory files: a validated, time-parameterised motion plus what it had to respect.

JointTrajectory-like points, the constraints resolved in the world frame (their semantics are
in `spec.py`), and a report: planning time, path length, worst margin per constraint, minimum
robot-human distance. The schema is versioned.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from hriplan.files import load_model, write_atomically
from hriplan.planner.constraints.spec import ConstraintSpec
from hriplan.planner.outcome import Status
from hriplan.robots.scene import Scene
from hriplan.robots.spatial import Pose
from hriplan.safety.report import SeparationTrace

SCHEMA = "hriplan.trajectory"
SCHEMA_VERSION = 1


Finite = Annotated[float, Field(allow_inf_nan=False)]


class TrajectoryPoint(BaseModel):
    time_from_start: Finite
    positions: list[Finite]
    velocities: list[Finite]
    accelerations: list[Finite]


class ResolvedConstraint(BaseModel):
    """A constraint as planned: its specification and its frame's pose in the world."""

    spec: ConstraintSpec
    frame_in_world: Pose
    goal_position: list[float] | None = None  # target link at the goal (dynamic tolerance)
    reason: str = ""  # one line: why this constraint is there (from the rules, when they made it)


class TrajectoryReport(BaseModel):
    status: Status  # a trajectory is written for solved motions only
    planner: str
    space: str
    planning_time: float
    duration: float
    path_length: float  # joint-space length of the validated path, rad
    straight_length: float | None = None  # joint-space distance from start to goal, rad (the shortest path)
    states_checked: int
    max_violation: dict[str, float]  # worst margin per constraint over the timed path (<= 0: kept)
    min_human_distance: float | None = None
    closest_pair: tuple[str, str] | None = None
    velocity_scale: float = 1.0
    calls: dict[str, int] = Field(default_factory=dict)
    separation: list[SeparationTrace] = Field(default_factory=list)  # per person, when timed for people


class TrajectoryFile(BaseModel):
    model_config = ConfigDict(extra="forbid")

    schema_name: Literal["hriplan.trajectory"] = Field(default=SCHEMA, alias="schema")
    schema_version: Literal[1] = SCHEMA_VERSION
    robot: str
    task: str = ""  # the task file's name and the step this motion is (empty for a bare problem)
    step: str = ""
    hands: dict[str, str] = Field(default_factory=dict)
    joint_names: list[str]
    start: dict[str, float] = Field(default_factory=dict)  # every joint of the robot at the start
    scene: Scene = Field(default_factory=Scene)  # what the motion was checked against
    points: list[TrajectoryPoint]
    constraints: list[ResolvedConstraint]
    report: TrajectoryReport

    @model_validator(mode="after")
    def _a_motion(self) -> TrajectoryFile:
        """At least two points, one value per joint each, times from 0 strictly increasing."""
        if len(self.points) < 2:
            raise ValueError(f"a trajectory needs at least 2 points, got {len(self.points)}")
        n = len(self.joint_names)
        for k, p in enumerate(self.points):
            if not len(p.positions) == len(p.velocities) == len(p.accelerations) == n:
                raise ValueError(f"points.{k}: positions, velocities and accelerations need one value per joint ({n})")
        if self.points[0].time_from_start != 0.0:
            raise ValueError(f"points.0: time_from_start is {self.points[0].time_from_start}, a trajectory starts at 0")
        for k in range(1, len(self.points)):
            if self.points[k].time_from_start <= self.points[k - 1].time_from_start:
                raise ValueError(
                    f"points.{k}: time_from_start {self.points[k].time_from_start} does not come after "
                    f"{self.points[k - 1].time_from_start} (times must increase)"
                )
        return self

    def text(self) -> str:
        """The trajectory file's content (what `save` writes)."""
        return self.model_dump_json(indent=1, by_alias=True)

    def save(self, path: str | Path) -> None:
        """Write atomically: a partly written trajectory never replaces a good one."""
        write_atomically(path, self.text())


def load_trajectory(path: str | Path) -> TrajectoryFile:
    return load_model(path, TrajectoryFile)
