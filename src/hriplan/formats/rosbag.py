"""A task's planned steps as a ROS 2 bag: a `trajectory_msgs/msg/JointTrajectory` topic per
controller and the whole motion as a MoveIt `moveit_msgs/msg/DisplayTrajectory`.

A trajectory file moves one or more arms with the hands fixed at postures. Controllers follow the
robot's description, never its name: each arm's joints go to `/{group}_controller/joint_trajectory`
(MADAR: `/right_arm_controller/...`), each hand's finger joints to `/{arm}_hand_controller/...`,
as the joint values its hand model gives for the step's posture, held from the step's start to its
end (two points). A step sends a message on an arm's topic only if it moves that arm, on a hand's
only if it names the hand's posture. Every message of a step is stamped (header and bag time) with
the step's start: the sum of the durations of the steps before it, the first at 0.

The bag is rosbag2 version 9 in MCAP storage (ROS 2's default storage since Iron): one indexed
file that carries each topic's message definition, so tools without ROS or MoveIt (Foxglove,
rosbags, the mcap CLI) decode it as they find it; written whole or not at all.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys.store import Typestore

from hriplan import HriplanError
from hriplan.files import atomic_directory
from hriplan.formats.ros_messages import typestore
from hriplan.planner.trajectory import TrajectoryFile, load_trajectory
from hriplan.robots.descriptions.description import RobotDescription, hand_model
from hriplan.robots.descriptions.registry import description_of

JOINT_TRAJECTORY = "trajectory_msgs/msg/JointTrajectory"
DISPLAY_TRAJECTORY = "moveit_msgs/msg/DisplayTrajectory"
DISPLAY_TOPIC = "/display_planned_path"  # where MoveIt's RViz plugin listens
# A step starts where the one before it ended, to this much per joint (rad or m).
CONTINUITY = 1e-6
_TOPIC = re.compile(r"(/[A-Za-z][A-Za-z0-9_]*)+")


@dataclass(frozen=True)
class Controller:
    """A joint trajectory controller: an arm's joints or the finger joints of the hand on `arm`."""

    name: str
    topic: str
    arm: str
    joints: tuple[str, ...]
    hand: bool


def controllers(description: RobotDescription, topics: Mapping[str, str] | None = None) -> list[Controller]:
    """The robot's controllers, each on `/{name}/joint_trajectory` unless `topics` names another
    topic for it (controller name -> absolute topic name)."""
    groups = []  # (name, arm, joints, hand)
    for arm_name, arm in description.arms.items():
        groups.append((f"{arm.group}_controller", arm_name, arm.joints, False))
        if arm.hand is not None:
            fingers = finger_values(description, arm_name, hand_model(arm.hand).postures[0])
            groups.append((f"{arm_name}_hand_controller", arm_name, tuple(fingers), True))
    topics = dict(topics or {})
    names = [name for name, *_ in groups]
    if unknown := sorted(set(topics) - set(names)):
        raise HriplanError(f"--topic {unknown[0]}: robot {description.name!r} has controllers {', '.join(names)}")
    for name, topic in topics.items():
        if not _TOPIC.fullmatch(topic):
            raise HriplanError(
                f"--topic {name}={topic}: not an absolute ROS topic name (e.g. /{name}/joint_trajectory)"
            )
    found = [
        Controller(n, topics.get(n, f"/{n}/joint_trajectory"), arm, joints, hand) for n, arm, joints, hand in groups
    ]
    taken = [c.topic for c in found] + [DISPLAY_TOPIC]
    if twice := next((t for t in taken if taken.count(t) > 1), None):
        raise HriplanError(f"--topic: two controllers would share the topic {twice}")
    return found


def load_steps(paths: Sequence[Path]) -> list[TrajectoryFile]:
    """The trajectory files of one robot's steps, each starting where the one before it ended."""
    if not paths:
        raise HriplanError("give at least one trajectory file")
    steps = [load_trajectory(path) for path in paths]
    for path, step in zip(paths[1:], steps[1:]):
        if step.robot != steps[0].robot:
            raise HriplanError(
                f"{path}: robot {step.robot!r}, but {paths[0]} is robot {steps[0].robot!r}: a bag holds one robot's motion"
            )
    state = dict(steps[0].start)
    for k in range(1, len(steps)):
        previous = steps[k - 1]
        state |= dict(zip(previous.joint_names, previous.points[-1].positions))
        for joint, value in steps[k].start.items():
            if joint in state and abs(value - state[joint]) > CONTINUITY:
                raise HriplanError(
                    f"{paths[k]}: starts with {joint} at {value:.6g}, but {paths[k - 1]} ends it at "
                    f"{state[joint]:.6g}: give a task's steps in order"
                )
    return steps


def _nanoseconds(seconds: float) -> int:
    return round(seconds * 1e9)


def _time(store: Typestore, nanoseconds: int, kind: str) -> object:
    sec, nanosec = divmod(nanoseconds, 1_000_000_000)
    return store.types[f"builtin_interfaces/msg/{kind}"](sec=sec, nanosec=nanosec)


def _header(store: Typestore, stamp: int) -> object:
    return store.types["std_msgs/msg/Header"](stamp=_time(store, stamp, "Time"), frame_id="")


def _point(store: Typestore, t: float, positions: Sequence[float], velocities, accelerations) -> object:
    return store.types["trajectory_msgs/msg/JointTrajectoryPoint"](
        positions=np.asarray(positions, dtype=np.float64),
        velocities=np.asarray(velocities, dtype=np.float64),
        accelerations=np.asarray(accelerations, dtype=np.float64),
        effort=np.zeros(0),
        time_from_start=_time(store, _nanoseconds(t), "Duration"),
    )


def _joint_trajectory(store: Typestore, stamp: int, joints: Sequence[str], points: list) -> object:
    return store.types[JOINT_TRAJECTORY](header=_header(store, stamp), joint_names=list(joints), points=points)


def finger_values(description: RobotDescription, arm: str, posture: str) -> dict[str, float]:
    """The finger joints of the hand on `arm` (their names in the robot) at `posture`."""
    description_arm = description.arms[arm]
    hand = hand_model(description_arm.hand)
    return {hand.joint_name(description_arm.prefix, j): v for j, v in hand.joint_values(posture).items()}


def _held(store: Typestore, stamp: int, values: Mapping[str, float], duration: float) -> object:
    """A hand holding its posture through a step: a point at its start and one at its end."""
    zeros = [0.0] * len(values)
    times = [0.0, duration] if duration > 0 else [0.0]
    return _joint_trajectory(
        store, stamp, list(values), [_point(store, t, list(values.values()), zeros, zeros) for t in times]
    )


def step_messages(
    store: Typestore, description: RobotDescription, found: Sequence[Controller], step: TrajectoryFile, stamp: int
) -> list[tuple[Controller, object]]:
    """A step's JointTrajectory per controller it moves (arms) or names a posture for (hands)."""
    arm_joints = {j for c in found if not c.hand for j in c.joints}
    if stray := [j for j in step.joint_names if j not in arm_joints]:
        raise HriplanError(f"step {step.step or '?'}: joint {stray[0]!r} is in no arm of robot {description.name!r}")
    duration = step.points[-1].time_from_start
    messages = []
    for controller in found:
        if controller.hand:
            if controller.arm in step.hands:
                values = finger_values(description, controller.arm, step.hands[controller.arm])
                messages.append((controller, _held(store, stamp, values, duration)))
            continue
        columns = [step.joint_names.index(j) for j in controller.joints if j in step.joint_names]
        if not columns:
            continue
        points = [
            _point(
                store,
                p.time_from_start,
                [p.positions[c] for c in columns],
                [p.velocities[c] for c in columns],
                [p.accelerations[c] for c in columns],
            )
            for p in step.points
        ]
        messages.append((controller, _joint_trajectory(store, stamp, [step.joint_names[c] for c in columns], points)))
    return messages


def display_trajectory(
    store: Typestore, description: RobotDescription, steps: Sequence[TrajectoryFile], stamps: Sequence[int]
) -> object:
    """The motion for MoveIt's RViz display: a RobotTrajectory per step (its planned joints as
    planned, then each named hand's finger joints held at its posture), starting from the first
    step's start (every arm joint it lists, the fingers at its postures)."""
    types = store.types
    trajectories = []
    for step, stamp in zip(steps, stamps):
        fingers: dict[str, float] = {}
        for arm, posture in step.hands.items():
            fingers |= finger_values(description, arm, posture)
        held, zeros = list(fingers.values()), [0.0] * len(fingers)
        points = [
            _point(store, p.time_from_start, p.positions + held, p.velocities + zeros, p.accelerations + zeros)
            for p in step.points
        ]
        trajectories.append(
            types["moveit_msgs/msg/RobotTrajectory"](
                joint_trajectory=_joint_trajectory(store, stamp, step.joint_names + list(fingers), points),
                multi_dof_joint_trajectory=types["trajectory_msgs/msg/MultiDOFJointTrajectory"](
                    header=_header(store, stamp), joint_names=[], points=[]
                ),
            )
        )
    first = steps[0]
    start = dict(first.start) or dict(zip(first.joint_names, first.points[0].positions))
    for arm, posture in first.hands.items():
        start |= finger_values(description, arm, posture)
    joint_state = types["sensor_msgs/msg/JointState"](
        header=_header(store, 0),
        name=list(start),
        position=np.asarray(list(start.values()), dtype=np.float64),
        velocity=np.zeros(0),
        effort=np.zeros(0),
    )
    robot_state = types["moveit_msgs/msg/RobotState"](
        joint_state=joint_state,
        multi_dof_joint_state=types["sensor_msgs/msg/MultiDOFJointState"](
            header=_header(store, 0), joint_names=[], transforms=[], twist=[], wrench=[]
        ),
        attached_collision_objects=[],
        is_diff=False,
    )
    return types[DISPLAY_TRAJECTORY](model_id=description.name, trajectory=trajectories, trajectory_start=robot_state)


def step_stamps(steps: Sequence[TrajectoryFile]) -> list[int]:
    """Each step's start in nanoseconds: the durations of the steps before it added up."""
    stamps, elapsed = [], 0.0
    for step in steps:
        stamps.append(_nanoseconds(elapsed))
        elapsed += step.points[-1].time_from_start
    return stamps


@dataclass(frozen=True)
class Written:
    """What `export_bag` wrote: messages per topic and the motion's length."""

    path: Path
    messages: dict[str, int]
    duration: float


def check_output(path: Path, force: bool) -> None:
    """A bag is a directory: an existing one is replaced only with `force`, and only if it is a
    bag. Not named `.bag`: rosbags' AnyReader takes that for a ROS 1 bag file."""
    if path.suffix == ".bag":
        raise HriplanError(
            f"--output {path}: .bag names a ROS 1 bag file; a ROS 2 bag is a directory, name it without .bag"
        )
    if not path.exists():
        return
    if not force:
        raise HriplanError(f"--output {path}: exists; give --force to replace it")
    if not (path / "metadata.yaml").is_file():
        raise HriplanError(f"--output {path}: not a ROS 2 bag (no metadata.yaml); not replacing it")


def export_bag(
    paths: Sequence[Path], output: Path, force: bool = False, topics: Mapping[str, str] | None = None
) -> Written:
    """Write the steps in `paths` (in order) as a bag at `output` (a directory, as rosbag2 has it)."""
    check_output(output, force)
    steps = load_steps(paths)
    description = description_of(steps[0].robot)
    found = controllers(description, topics)
    store = typestore()
    stamps = step_stamps(steps)
    timeline = [(0, DISPLAY_TOPIC, DISPLAY_TRAJECTORY, display_trajectory(store, description, steps, stamps))]
    for step, stamp in zip(steps, stamps):
        timeline += [
            (stamp, c.topic, JOINT_TRAJECTORY, m) for c, m in step_messages(store, description, found, step, stamp)
        ]
    kinds = {topic: kind for _, topic, kind, _ in timeline}  # the topics that carry a message, in order
    with atomic_directory(output) as where, Writer(where, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connections = {topic: writer.add_connection(topic, kind, typestore=store) for topic, kind in kinds.items()}
        for stamp, topic, kind, message in timeline:
            writer.write(connections[topic], stamp, store.serialize_cdr(message, kind))
    counts = {topic: sum(t == topic for _, t, _, _ in timeline) for topic in kinds}
    return Written(output, counts, sum(s.points[-1].time_from_start for s in steps))
