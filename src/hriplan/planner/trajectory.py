"""Trajectory files: a validated, time-parameterised motion plus what it had to respect.

JointTrajectory-like points, the constraints resolved in the world frame (their semantics are
in `spec.py`) with why each one is there (the rules and the facts behind it), and a report:
planning time, path length, worst margin per constraint, minimum robot-human distance. The
schema is versioned.
"""

from __future__ import annotations

import json
from operator import attrgetter, lt
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from hriplan.files import Finite, load_model, write_atomically
from hriplan.planner.constraints.spec import ConstraintSpec
from hriplan.planner.outcome import Status
from hriplan.robots.descriptions.registry import registered_robot_file
from hriplan.robots.scene import Scene
from hriplan.robots.spatial import Pose
from hriplan.safety.report import SeparationTrace
from hriplan.safety.separation import SafetyMargin

SCHEMA = "hriplan.trajectory"
SCHEMA_VERSION = 1


class TrajectoryPoint(BaseModel):
    time_from_start: Finite
    positions: list[Finite]
    velocities: list[Finite]
    accelerations: list[Finite]


_ROWS = ("positions", "velocities", "accelerations")
# The fields set of every built point, one set: setting a field adds its name, which it holds.
_POINT_FIELDS = set(TrajectoryPoint.model_fields)
_set = object.__setattr__


def timed_points(
    times: list[float], positions: list[list[float]], velocities: list[list[float]], accelerations: list[list[float]]
) -> list[TrajectoryPoint]:
    """A timed motion's samples (a `TimedPath`'s lists, finite: checked where it is made) as a file's points:
    TrajectoryPoints around those very lists, as validation would make them (`model_construct`'s
    steps) without copying the lists: a third of the objects, so half the young collections of a
    UR5 timing (~300 points)."""
    points = []
    for t, p, v, a in zip(times, positions, velocities, accelerations):
        point = object.__new__(TrajectoryPoint)
        _set(point, "__dict__", {"time_from_start": t, "positions": p, "velocities": v, "accelerations": a})
        _set(point, "__pydantic_fields_set__", _POINT_FIELDS)
        _set(point, "__pydantic_extra__", None)
        _set(point, "__pydantic_private__", None)
        points.append(point)
    return points


class ConstraintOrigin(BaseModel):
    """Why a constraint is there, as the rules derived it (rules/provenance.py): the kind they
    required, what it is about, the rules and the facts their bodies matched, and the rules'
    rationale. Kept with a trajectory so that a motion says why it was constrained; empty for a
    constraint that no rule made (a problem file's)."""

    kind: str = ""  # ontology constraint kind, e.g. UprightFull
    anchor: str = ""  # the object or person it is about
    rules: list[str] = Field(default_factory=list)  # rules that required it, then the rules behind their facts
    facts: list[str] = Field(default_factory=list)  # the matched facts, in words
    reason: str = ""  # one line: the rationale of the rules that required it


class ResolvedConstraint(ConstraintOrigin):
    """A constraint as planned: its specification, its frame's pose in the world, and its origin."""

    spec: ConstraintSpec
    frame_in_world: Pose
    goal_position: list[float] | None = None  # target link at the goal (dynamic tolerance)


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
    rests: int = 0  # waypoints where the timed motion stops so as not to round a corner off the validated path
    calls: dict[str, int] = Field(default_factory=dict)
    separation: list[SeparationTrace] = Field(default_factory=list)  # per person, when timed for people
    safety_margin: SafetyMargin | None = None  # kept beyond ISO/TS 15066's limits, when timed for people


class TrajectoryFile(BaseModel):
    model_config = ConfigDict(extra="forbid")

    schema_name: Literal["hriplan.trajectory"] = Field(default=SCHEMA, alias="schema")
    schema_version: Literal[1] = SCHEMA_VERSION
    robot: str
    robot_file: str = ""  # the robot file the robot was loaded from ("" for a built-in robot)
    task: str = ""  # the task file's name and the step this motion is (empty for a bare problem)
    step: str = ""
    hands: dict[str, str] = Field(default_factory=dict)
    joint_names: list[str]
    start: dict[str, float] = Field(default_factory=dict)  # every joint of the robot at the start
    scene: Scene = Field(default_factory=Scene)  # what the motion was checked against
    # A task step's grasps: each object held (or closed on) -> the ontology grasp it is held by.
    grasps: dict[str, str] = Field(default_factory=dict)
    points: list[TrajectoryPoint]
    constraints: list[ResolvedConstraint]
    report: TrajectoryReport

    @model_validator(mode="before")
    @classmethod
    def _robot_file_loaded(cls, data: object) -> object:
        return registered_robot_file(data)

    @model_validator(mode="after")
    def _a_motion(self) -> TrajectoryFile:
        """At least one point (one alone: a motion whose start is its goal), one value per joint
        each, times from 0 strictly increasing."""
        if not self.points:
            raise ValueError("a trajectory needs at least 1 point, got 0")
        if len(self.points) == 1 and any(self.points[0].velocities + self.points[0].accelerations):
            raise ValueError("points.0: a trajectory of one point (its start is its goal) is at rest")
        n, points = len(self.joint_names), self.points
        if any(set(map(len, map(attrgetter(name), points))) != {n} for name in _ROWS):
            k = next(k for k, p in enumerate(points) if any(len(row) != n for row in attrgetter(*_ROWS)(p)))
            raise ValueError(f"points.{k}: positions, velocities and accelerations need one value per joint ({n})")
        times = list(map(attrgetter("time_from_start"), points))
        if times[0] != 0.0:
            raise ValueError(f"points.0: time_from_start is {times[0]}, a trajectory starts at 0")
        if not all(map(lt, times, times[1:])):
            k = next(k for k in range(1, len(times)) if times[k] <= times[k - 1])
            raise ValueError(
                f"points.{k}: time_from_start {times[k]} does not come after {times[k - 1]} (times must increase)"
            )
        return self

    def text(self) -> str:
        """The trajectory file's content (what `save` writes)."""
        return self.model_dump_json(indent=1, by_alias=True)

    def save(self, path: str | Path) -> None:
        """Write atomically: a partly written trajectory never replaces a good one."""
        write_atomically(path, self.text())


def is_trajectory_file(path: str | Path) -> bool:
    """Does `path` hold a trajectory (a JSON object naming this schema)? For commands that take a
    task or a trajectory; anything unreadable is not one (the task reader then says why)."""
    try:
        data = json.loads(Path(path).read_bytes())
    except (OSError, ValueError):
        return False
    return isinstance(data, dict) and data.get("schema") == SCHEMA


def load_trajectory(path: str | Path) -> TrajectoryFile:
    """Read a trajectory file (a robot from a robot file is loaded from it: to re-check, to draw)."""
    return load_model(path, TrajectoryFile)
