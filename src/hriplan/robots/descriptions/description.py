"""What the planner knows of a robot beyond its kinematics, as MoveIt keeps it in the SRDF: a
`RobotDescription` (its URDF, arms with their tool frames, groups, hands and IK solvers, the base
link, postures), read from a robot file (robots/robot_file.py); and the kinds of robot hand and
of IK solver a robot file may name."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from hriplan import HriplanError
from hriplan.robots.descriptions.allegro import HAND_POSTURES, hand_joint_name, posture_values
from hriplan.robots.srdf import Srdf

# The arms ur_analytic_ik solves (the UR7e and UR12e are the UR5e and UR10e renamed); an arm's IK
# kind is `{model}_analytic` or `numeric` (robots/ik.py).
UR_MODELS = (
    "ur3",
    "ur3e",
    "ur5",
    "ur5e",
    "ur7e",
    "ur8long",
    "ur10",
    "ur10e",
    "ur12e",
    "ur15",
    "ur16e",
    "ur18",
    "ur20",
    "ur30",
)
NUMERIC_IK = "numeric"
IK_KINDS = (NUMERIC_IK, *(f"{model}_analytic" for model in UR_MODELS))


@dataclass(frozen=True)
class HandModel:
    """A kind of robot hand: its finger postures and, per posture, the finger joint values."""

    label: str  # its name in words ("Allegro")
    postures: tuple[str, ...]  # the first is the one a hand has when a task names none
    released: str  # the posture it opens to when it lets an object go
    joint_values: Callable[[str], dict[str, float]]  # posture -> value per the hand URDF's own joint name
    joint_name: Callable[[str, str], str]  # (arm prefix, hand joint) -> the joint's name in the robot


# The hand models by the name a robot file gives (`hand: allegro`); a robot file's parallel
# gripper adds its own.
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
    # ROS-Industrial's `base` and `tool0` per arm, Kautham's names (same frame, checked by forward
    # kinematics in tests/formats/test_kautham.py). Every loaded robot has a frame per alias
    # (robots/model.py), so constraints, IK and tools take them.
    link_aliases: dict[str, str] = field(default_factory=dict)
    # Where the robot stands in the world, (xyz, rpy) (a task's base pose moves it further).
    base_pose: tuple[tuple[float, float, float], tuple[float, float, float]] = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    # rad/s^2 per joint where the description knows it (the planning options' limit otherwise).
    acceleration_limits: dict[str, float] = field(default_factory=dict)
    source: str = ""  # the robot file it was loaded from ("" for a built-in robot: robots/data/)
    # What the robot's SRDF says (None without one); its disabled pairs are only reported
    # (`hriplan robot check`) against the sampled allowed-collision matrix (acm.py), which decides.
    srdf: Srdf | None = None
    # Link pairs the robot file says never to check for self-collision (acm.py: reason "user").
    allowed_collisions: tuple[tuple[str, str], ...] = ()
    # ISO/TS 15066 stopping data (ontology property -> value, e.g. hasReactionTime -> 0.1 s),
    # stated about the robot's individual in the ontology (ontology/robot_individuals.py).
    stopping: dict[str, float] = field(default_factory=dict)

    @property
    def hands(self) -> list[str]:
        """The arms with a robot hand (their postures are chosen per task)."""
        return [arm for arm, description in self.arms.items() if description.hand is not None]
