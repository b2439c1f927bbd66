"""ROS `trajectory_msgs/JointTrajectory` messages: hriplan's trajectories written as one (the
service's `?ros=true`), and a bare one read as `ros2 topic echo /topic --once` prints it (YAML in
block style, ending in `---`) or the same as JSON, placed in a task step or a planning problem
(`MotionSetting`) so that `hriplan validate` checks it as it checks its own trajectories.

The message may name the joints of one arm only, in any order: the motion is the smallest joint
group holding them, and every joint it omits stays where the setting starts it. Positions and
velocities are required at every point (the controller interpolates a spline through both:
planner/spline.py); accelerations and effort may be empty, and effort is not checked.
"""

from __future__ import annotations

import re
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from hriplan import HriplanError
from hriplan.files import Finite, parse_data, read_text, validation_message
from hriplan.planner.replay import MotionSetting
from hriplan.planner.trajectory import ResolvedConstraint, TrajectoryFile, TrajectoryPoint
from hriplan.robots.model import load_robot
from hriplan.robots.scene import Scene

MESSAGE_FIELDS = ("header", "joint_names", "points")
# A separator or end line of a YAML stream: ros2 topic echo ends every message with `---`.
_DOCUMENT_END = re.compile(r"^(?:---|\.\.\.)[ \t]*$", re.MULTILINE)
START_TOLERANCE = 1e-3  # rad: a first point farther than this from the setting's start is said


class RosTime(BaseModel):
    """builtin_interfaces/Time or Duration: whole seconds and nanoseconds."""

    model_config = ConfigDict(extra="forbid")

    sec: int
    nanosec: int = Field(0, ge=0, lt=1_000_000_000)

    @property
    def seconds(self) -> float:
        return self.sec + self.nanosec * 1e-9

    @classmethod
    def of(cls, seconds: float) -> RosTime:
        """Seconds as whole seconds + nanoseconds, rounded to the nearest nanosecond."""
        sec, nanosec = divmod(round(seconds * 1e9), 1_000_000_000)
        return cls(sec=sec, nanosec=nanosec)


class RosHeader(BaseModel):
    model_config = ConfigDict(extra="forbid")

    stamp: RosTime = Field(default_factory=lambda: RosTime(sec=0))
    frame_id: str = ""


class RosTrajectoryPoint(BaseModel):
    model_config = ConfigDict(extra="forbid")

    positions: list[Finite]
    velocities: list[Finite] = Field(default_factory=list)
    accelerations: list[Finite] = Field(default_factory=list)
    effort: list[Finite] = Field(default_factory=list)
    time_from_start: RosTime


class JointTrajectoryMessage(BaseModel):
    """trajectory_msgs/JointTrajectory: one position and one velocity per named joint at every
    point (accelerations and effort: one per joint or none), times strictly increasing."""

    model_config = ConfigDict(extra="forbid")

    header: RosHeader = Field(default_factory=RosHeader)
    joint_names: list[str] = Field(min_length=1)
    points: list[RosTrajectoryPoint] = Field(min_length=1)

    @model_validator(mode="after")
    def _one_value_per_joint(self) -> JointTrajectoryMessage:
        n = len(self.joint_names)
        twice = next((j for k, j in enumerate(self.joint_names) if j in self.joint_names[:k]), None)
        if twice is not None:
            raise ValueError(f"joint_names: {twice!r} is named twice")
        for k, p in enumerate(self.points):
            for field in ("positions", "velocities", "accelerations", "effort"):
                count = len(getattr(p, field))
                if count != n and (count or field in ("positions", "velocities")):
                    needs = (
                        "one value per joint" if field in ("positions", "velocities") else "one value per joint or none"
                    )
                    raise ValueError(f"points.{k}.{field}: {count} values for {n} joint_names ({needs})")
            if k and p.time_from_start.seconds <= self.points[k - 1].time_from_start.seconds:
                raise ValueError(
                    f"points.{k}.time_from_start: {p.time_from_start.seconds:g} s does not come after "
                    f"{self.points[k - 1].time_from_start.seconds:g} s (times must increase)"
                )
        if self.points[0].time_from_start.seconds < 0.0:
            raise ValueError(f"points.0.time_from_start: {self.points[0].time_from_start.seconds:g} s is negative")
        return self


def joint_trajectory_message(trajectory: TrajectoryFile) -> JointTrajectoryMessage:
    """The planned group's joints and timed points; the header is left empty (stamp 0: start on
    receipt) and so is effort (hriplan plans kinematics only)."""
    points = [
        RosTrajectoryPoint(
            positions=p.positions,
            velocities=p.velocities,
            accelerations=p.accelerations,
            time_from_start=RosTime.of(p.time_from_start),
        )
        for p in trajectory.points
    ]
    return JointTrajectoryMessage(joint_names=trajectory.joint_names, points=points)


class PlacedTrajectory(BaseModel):
    """A message placed in a setting: the parts a re-check needs (`replay.Motion`), with the
    message's points in the order of its joint group, and what the placing had to assume."""

    robot: str
    hands: dict[str, str]
    joint_names: list[str]
    start: dict[str, float]
    scene: Scene
    points: list[TrajectoryPoint]
    constraints: list[ResolvedConstraint]
    notes: list[str] = Field(default_factory=list)


def _message_data(path: Path, only: bool = True) -> object:
    """The message a file holds, as data (a YAML stream's empty documents left out): the only
    one (else one line), or with `only` False the first."""
    syntax = "json" if path.suffix == ".json" else "yaml"
    text = read_text(path, "JointTrajectory message")
    documents = [text] if syntax == "json" else [d for d in _DOCUMENT_END.split(text) if d.strip()]
    if not documents:
        raise HriplanError(f"{path}: the file is empty")
    if len(documents) > 1 and only:
        raise HriplanError(
            f"{path}: holds {len(documents)} messages (separated by ---); give one (ros2 topic echo --once)"
        )
    try:
        return parse_data(documents[0], syntax)
    except HriplanError as exc:
        raise HriplanError(f"{path}: {exc}") from None


def is_joint_trajectory_message(path: str | Path) -> bool:
    """Does `path` look like a ROS JointTrajectory (a mapping with one of its fields and no hriplan
    `schema`)? Anything unreadable is not one (the trajectory reader then says why)."""
    try:
        data = _message_data(Path(path), only=False)
    except HriplanError:
        return False
    return isinstance(data, dict) and "schema" not in data and any(f in data for f in MESSAGE_FIELDS)


def load_joint_trajectory(path: str | Path) -> JointTrajectoryMessage:
    """Read a JointTrajectory message (YAML as ros2 topic echo prints it, or JSON); one line per problem."""
    path = Path(path)
    data = _message_data(path)
    if not isinstance(data, dict):
        raise HriplanError(f"{path}: expected a JointTrajectory message (a mapping), got {type(data).__name__}")
    try:
        return JointTrajectoryMessage.model_validate(data)
    except ValidationError as exc:
        raise HriplanError(f"{path}: {validation_message(exc)}") from None


def place(message: JointTrajectoryMessage, setting: MotionSetting) -> PlacedTrajectory:
    """The message as a motion of the setting's robot: its joints' smallest group, in the group's
    order, joints it omits held at the setting's start; times counted from its first point."""
    robot = load_robot(setting.robot, setting.hands or None)
    names = message.joint_names
    unknown = next((j for j in names if j not in robot.joint_names), None)
    if unknown is not None:
        raise HriplanError(
            f"joint_names: {unknown!r} is not a joint of {robot.name}; its joints: {', '.join(robot.joint_names)}"
        )
    group = min(
        (g for g in robot.groups if set(names) <= set(robot.group_joints(g))), key=lambda g: len(robot.groups[g])
    )
    omitted = [j for j in robot.joint_names if j not in names]
    not_known = [j for j in omitted if j in setting.unknown_start]
    if not_known:
        raise HriplanError(
            f"joint_names: the message omits {not_known[0]}, which an earlier step moves (validate plans nothing to "
            f"find where it leaves it): give every joint of that arm"
        )
    column = {j: k for k, j in enumerate(names)}
    joints = robot.group_joints(group)
    t0 = message.points[0].time_from_start.seconds
    points = [
        TrajectoryPoint(
            time_from_start=p.time_from_start.seconds - t0,
            positions=[p.positions[column[j]] if j in column else setting.start[j] for j in joints],
            velocities=[p.velocities[column[j]] if j in column else 0.0 for j in joints],
            accelerations=[p.accelerations[column[j]] if j in column else 0.0 for j in joints]
            if p.accelerations
            else [],
        )
        for p in message.points
    ]
    first = dict(zip(names, message.points[0].positions))
    notes = [f"joints the message omits stay at the start: {', '.join(omitted)}"] if omitted else []
    away = {j: v - setting.start[j] for j, v in first.items() if j not in setting.unknown_start}
    far = max(away, key=lambda j: abs(away[j]), default=None)
    if far is not None and abs(away[far]) > START_TOLERANCE:
        notes.append(f"the message starts {away[far]:+.4f} rad from the start at {far}: checked from its first point")
    if t0 > 0.0:
        notes.append(f"times are counted from the first point's time_from_start, {t0:g} s")
    return PlacedTrajectory(
        robot=robot.name,
        hands=setting.hands,
        joint_names=joints,
        start=setting.start | first,
        scene=setting.scene,
        points=points,
        constraints=setting.constraints,
        notes=notes,
    )
