"""Robot descriptions: MADAR and a single UR5, each its URDF and what an SRDF adds to it.

The URDF is the single source of truth for kinematics and display; `hriplan robot urdf NAME`
prints it. Numbers are from the Kautham project's MADAR description. What the planner knows of
a robot beyond its kinematics (arms, their tool frames and groups, hands, the base link) is a
`RobotDescription`, as MoveIt keeps it in the SRDF: no code asks for a robot by name.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass, field

from hriplan import HriplanError
from hriplan.robots import urdf_xml as X
from hriplan.robots.descriptions.allegro import HAND_POSTURES, add_allegro, hand_joint_name, posture_values
from hriplan.robots.descriptions.postures import MADAR_POSTURES, UR5_POSTURES
from hriplan.robots.descriptions.ur5_arm import add_ur5, joint_names
from hriplan.robots.srdf import Srdf

MADAR_BASE = "madar_base_link"
# Arm base mounts on the MADAR base (URDF rpy), as published for the real robot.
ARM_MOUNTS = {
    "right": ((0.256, 0.0, 1.389), (3.142, -0.7874, 0.0)),
    "left": ((-0.256, 0.0, 1.389), (-3.142, 0.7874, 0.0)),
}
# wrist_3 -> adapter -> Allegro palm, and the adapter's collision cylinder.
ADAPTER_OFFSET = (0.0, 0.0, 0.0225)
ADAPTER_TO_PALM = ((0.0, 0.01, 0.1175), (0.0, 0.0, math.pi / 2))
ADAPTER_CYLINDER = (0.035, 0.045)
# Tool (TCP) frame in the palm frame: the centre of a power grasp, z = approach direction
# (out of the palm), x = along the fingers, y = z x x (the axis of a grasped cylinder).
TOOL_IN_PALM = ((0.045, 0.0, 0.035), (math.pi, -math.pi / 2, 0.0))
# Torso / structure primitives: (name, geometry, xyz).
TORSO = (
    ("madar_base_cylinder", X.cylinder(0.4, 0.75), (0.0, 0.0, 0.375)),
    ("madar_crossbar", X.box((0.5, 0.08, 0.05)), (0.0, 0.0, 1.395)),
    ("madar_column", X.box((0.08, 0.08, 0.63)), (0.0, 0.0, 1.056)),
    ("madar_electronics_box", X.box((0.43, 0.2, 0.33)), (0.0, -0.14, 0.916)),
)
WHEEL_RADIUS = 0.10
WHEEL_CIRCLE = 0.29


def _add_structure(robot: ET.Element) -> None:
    base = X.link(robot, MADAR_BASE)
    for name, geometry, xyz in TORSO:
        for role in ("visual", "collision"):
            X.shape(base, role, geometry, xyz, name=name)
    for i in range(3):
        angle = 2.0 * math.pi * i / 3.0
        wheel = f"madar_wheel_{i + 1}"
        el = X.link(robot, wheel)
        for role in ("visual", "collision"):
            X.shape(el, role, X.sphere(WHEEL_RADIUS), name=wheel)
        X.joint(
            robot,
            f"motor_{i + 1}",
            "continuous",
            MADAR_BASE,
            wheel,
            xyz=(WHEEL_CIRCLE * math.cos(angle), WHEEL_CIRCLE * math.sin(angle), WHEEL_RADIUS),
            rpy=(0.0, 0.0, angle),
            axis=(1.0, 0.0, 0.0),
            limit={"effort": 50.0, "velocity": 10.0},
        )


def _add_hand(robot: ET.Element, prefix: str, side: str) -> None:
    adapter = f"{prefix}hand_adapter"
    el = X.link(robot, adapter)
    radius, length = ADAPTER_CYLINDER
    for role in ("visual", "collision"):
        X.shape(el, role, X.cylinder(radius, length), name=adapter)
    X.joint(robot, f"{prefix}hand_adapter_joint", "fixed", f"{prefix}wrist_3_link", adapter, ADAPTER_OFFSET)
    palm = add_allegro(robot, prefix, side)
    X.joint(robot, f"{prefix}hand_mount_joint", "fixed", adapter, palm, *ADAPTER_TO_PALM)
    X.link(robot, f"{prefix}tool")
    X.joint(robot, f"{prefix}tool_joint", "fixed", palm, f"{prefix}tool", *TOOL_IN_PALM)


def madar_urdf(hands: bool = True) -> str:
    """MADAR: torso primitives, three omni wheels, two UR5 arms, an Allegro hand on each wrist
    (`hands=False`: bare flanges, as Kautham's madar_dual_arm; examples/robots/madar_bare.urdf)."""
    robot = ET.Element("robot", name="madar")
    _add_structure(robot)
    for side, (xyz, rpy) in ARM_MOUNTS.items():
        prefix = f"{side}_"
        add_ur5(robot, prefix)
        X.joint(robot, f"{prefix}arm_mount_joint", "fixed", MADAR_BASE, f"{prefix}base_link", xyz, rpy)
        if hands:
            _add_hand(robot, prefix, side)
    return X.to_string(robot)


def ur5_urdf() -> str:
    """A single UR5 with a TCP frame `tool` on the flange (z out of the flange)."""
    robot = ET.Element("robot", name="ur5")
    add_ur5(robot, "")
    X.link(robot, "tool")
    X.joint(robot, "tool_joint", "fixed", "wrist_3_link", "tool")
    return X.to_string(robot)


@dataclass(frozen=True)
class HandModel:
    """A kind of robot hand: its finger postures and, per posture, the finger joint values."""

    label: str  # its name in words ("Allegro")
    postures: tuple[str, ...]  # the first is the one a hand has when a task names none
    released: str  # the posture it opens to when it lets an object go
    joint_values: Callable[[str], dict[str, float]]  # posture -> value per the hand URDF's own joint name
    joint_name: Callable[[str, str], str]  # (arm prefix, hand joint) -> the joint's name in the robot


HAND_MODELS = {"allegro": HandModel("Allegro", HAND_POSTURES, "release", posture_values, hand_joint_name)}


def hand_model(kind: str) -> HandModel:
    if kind not in HAND_MODELS:
        raise HriplanError(f"hand model {kind!r} is not supported; supported: {', '.join(HAND_MODELS)}")
    return HAND_MODELS[kind]


@dataclass(frozen=True)
class ArmDescription:
    """One arm: the prefix of its hand's joints and individuals, its tool frame, its planning
    group, its joints (a serial chain, root first) and the link they are mounted on, the kind of
    IK solver that solves it (robots/ik.py), the model of the robot hand on it (None: a bare
    flange), the arm's model, the tool axis along a held object's axis and where hriplan's hand
    frame lies in the tool frame."""

    prefix: str
    tool_frame: str
    group: str
    joints: tuple[str, ...]
    base_link: str
    hand: str | None = None
    ik: str = "ur5_analytic"
    model: str = "UR5"
    object_axis: str = "-z"  # a bare flange holds an object out of it; a hand's tool frame says (+y)
    # The signed tool axes along hriplan's hand frame x (along the fingers), y (across them: a
    # cylinder's axis in a side grasp) and z (out of the palm), the frame the ontology's grasps
    # are written in: the Allegro's tool frame is that frame; a parallel gripper closing along
    # its tool y holds a cylinder along its tool x.
    hand_axes: tuple[str, str, str] = ("+x", "+y", "+z")


@dataclass(frozen=True)
class RobotDescription:
    name: str
    label: str  # its name in words ("MADAR"), for the ontology
    summary: str  # what kind of robot it is ("Dual-arm mobile robot"), for the ontology
    urdf: Callable[[], str]
    base_link: str
    arms: dict[str, ArmDescription]  # the first is the arm a step moves when nothing says which
    whole_group: str  # every arm joint, in the model's order
    postures: dict[str, dict[str, float]]  # named start configurations (joints not listed are 0)
    # Other names of links (alias -> link), as other descriptions of the same robot spell them:
    # ROS-Industrial's `base` and `tool0` per arm (`ros_industrial_aliases`), Kautham's names
    # (same frame, checked by forward kinematics in tests/formats/test_kautham.py). Every loaded
    # robot has a frame per alias (robots/model.py), so constraints, IK and tools take them.
    link_aliases: dict[str, str] = field(default_factory=dict)
    # Where the robot stands in the world, (xyz, rpy) (a task's base pose moves it further).
    base_pose: tuple[tuple[float, float, float], tuple[float, float, float]] = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    # rad/s^2 per joint where the description knows it (the planning options' limit otherwise).
    acceleration_limits: dict[str, float] = field(default_factory=dict)
    source: str = ""  # the robot file it was loaded from ("" for a built-in robot)
    # What the robot's SRDF says (None without one); its disabled pairs are only reported
    # (`hriplan robot check`) against the sampled allowed-collision matrix (acm.py), which decides.
    srdf: Srdf | None = None
    # ISO/TS 15066 stopping data of a robot from a file (ontology property -> value, e.g.
    # hasReactionTime -> 0.1 s); a built-in robot's are in hriplan.ttl, with their sources.
    stopping: dict[str, float] = field(default_factory=dict)

    @property
    def hands(self) -> list[str]:
        """The arms with a robot hand (their postures are chosen per task)."""
        return [arm for arm, description in self.arms.items() if description.hand is not None]


def ros_industrial_aliases(arms: dict[str, ArmDescription], flange: str) -> dict[str, str]:
    """ROS-Industrial's frame names per arm (REP-199): `{prefix}base`, the arm's base link, and
    `{prefix}tool0`, its flange link `{prefix}{flange}` (no tool mounted)."""
    aliases = {}
    for arm in arms.values():
        aliases[f"{arm.prefix}base"] = arm.base_link
        aliases[f"{arm.prefix}tool0"] = f"{arm.prefix}{flange}"
    return aliases


_MADAR_ARMS = {
    side: ArmDescription(
        f"{side}_",
        f"{side}_tool",
        f"{side}_arm",
        tuple(joint_names(f"{side}_")),
        f"{side}_base_link",
        hand="allegro",
        object_axis="+y",
    )
    for side in ("right", "left")
}
_UR5_ARMS = {"arm": ArmDescription("", "tool", "arm", tuple(joint_names()), "base_link")}
# The UR5's DH-style base_link and wrist_3_link are the frames its controller and its analytic
# IK call base and flange (measured: ur5_analytic fits them with identity offsets), so they are
# ROS-Industrial's `base` and `tool0`.
DESCRIPTIONS = {
    "madar": RobotDescription(
        name="madar",
        label="MADAR",
        summary="Dual-arm mobile robot",
        urdf=madar_urdf,
        base_link=MADAR_BASE,
        whole_group="both_arms",
        postures=MADAR_POSTURES,
        arms=_MADAR_ARMS,
        # Kautham's MADAR names the adapter and the hand's base (the Allegro palm) differently.
        link_aliases={
            "right_hand_adapter_link": "right_hand_adapter",
            "right_hand_base_link": "right_hand_palm_link",
            **ros_industrial_aliases(_MADAR_ARMS, "wrist_3_link"),
        },
    ),
    "ur5": RobotDescription(
        name="ur5",
        label="UR5",
        summary="A single arm",
        urdf=ur5_urdf,
        base_link="base_link",
        whole_group="arm",
        postures=UR5_POSTURES,
        arms=_UR5_ARMS,
        link_aliases=ros_industrial_aliases(_UR5_ARMS, "wrist_3_link"),
    ),
}
# The robot a task, a problem, a situation or a session has when it names none.
DEFAULT_ROBOT = "madar"
# Every robot's named postures (the API's view of the descriptions).
POSTURES = {name: description.postures for name, description in DESCRIPTIONS.items()}


def description_of(name: str) -> RobotDescription:
    if name not in DESCRIPTIONS:
        raise HriplanError(f"unknown robot {name!r}; known robots: {', '.join(DESCRIPTIONS)}")
    return DESCRIPTIONS[name]


def posture(robot: str, name: str) -> dict[str, float]:
    """Joint values of one of a robot's named postures (joints not listed are 0)."""
    postures = description_of(robot).postures
    if name not in postures:
        raise HriplanError(f"robot {robot!r} has no posture {name!r}; postures: {', '.join(postures)}")
    return dict(postures[name])
