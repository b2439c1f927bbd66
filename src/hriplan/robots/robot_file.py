"""A robot file: any robot from its URDF (and SRDF), as a `RobotDescription` the rest of hriplan
asks for by the file's robot name.

```yaml
name: panda
urdf: package://example-robot-data/robots/panda_description/urdf/panda.urdf  # or relative to this file
srdf: package://example-robot-data/robots/panda_description/srdf/panda.srdf  # optional
packages: {my_meshes: ../meshes}             # package://NAME/ -> a folder (also searched: ROS_PACKAGE_PATH,
                                             # AMENT_PREFIX_PATH, example-robot-data)
arms:
  arm:
    group: arm                               # an SRDF group, or base: LINK and tip: LINK
    tool: panda_hand_tcp                     # default: the SRDF end effector's parent link, or the tip
    tool_offset: {xyz: [0, 0, 0.05]}         # optional: a frame ARM_tool at this offset
    hand: {gripper: [panda_finger_joint1, panda_finger_joint2], open: 0.04, closed: 0.0}  # or none, allegro
                                             # (a gripper's closes_along: x or y, default from its URDF)
    ik: numeric                              # or an analytic UR kind (ur10_analytic, ...)
    object_axis: -z                          # the tool axis along a held object's z (default)
    ros_industrial: true                     # frames `base` (the arm's base link) and `tool0` (the
                                             # last joint's link, its flange) too; ARM_base, ARM_tool0
                                             # with several arms; a link the URDF names so is kept
frame_aliases: {flange: panda_link8}         # other names of links (constraints, tool: take them)
postures: {ready: {panda_joint4: -2.0}}      # with the SRDF's group states
                                             # (the SRDF group of exactly the arms' joints, if any, is
                                             # the whole-robot group: MADAR's both_arms; else all_arms)
limits: {panda_joint1: {velocity: 1.0, acceleration: 3.75}, panda_joint7: {lower: -1.5, upper: 1.5}}
                                             # (lower/upper narrow a range, or give a continuous joint one)
base_pose: {xyz: [0, 0, 0.8]}
allowed_collisions: [[panda_link5, panda_link7]]  # link pairs never checked (the user's word, as MoveIt's "User")
stopping: {reaction_time: 0.1, stopping_time: 0.2, position_uncertainty: 0.02, moving_mass: 6.0}  # ISO/TS 15066
```
Every problem (a group with no joints, an unknown link, a missing mesh, a non-serial arm, no tool
frame) is one line naming the file and what is wrong. The built-in robots are robot files too
(robots/data/madar.yaml, ur5.yaml), read by this module as any other (descriptions/registry.py).
"""

from __future__ import annotations

import functools
import math
import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Collection
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
import pinocchio as pin
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    FiniteFloat,
    NonNegativeFloat,
    PositiveFloat,
    StringConstraints,
    field_validator,
    model_validator,
)

from hriplan import HriplanError
from hriplan.files import read_text
from hriplan.robots import urdf_xml as X
from hriplan.robots.assets import robots_dir
from hriplan.robots.descriptions.allegro import hand_joint_name
from hriplan.robots.descriptions.description import (
    HAND_MODELS,
    IK_KINDS,
    ArmDescription,
    HandModel,
    RobotDescription,
)
from hriplan.robots.spatial import Pose
from hriplan.robots.srdf import Srdf, read_srdf
from hriplan.robots.urdf_tree import MOVABLE, UrdfTree

Identifier = Annotated[str, StringConstraints(pattern=r"^[A-Za-z][A-Za-z0-9_]*$")]
PACKAGE_URI = re.compile(r"^package://([^/]+)/(.*)$")
GRIPPER_POSTURES = ("open", "closed", "release")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class Gripper(_Strict):
    """A parallel gripper: its finger joints (a mimic joint listed too) and their open and closed values."""

    gripper: list[str] = Field(min_length=1)
    open: float
    closed: float
    closes_along: Literal["x", "y"] | None = Field(
        None,
        description="The tool axis the fingers close along (default: read from the first finger joint's axis in the URDF).",
    )


class ArmSpec(_Strict):
    group: str | None = Field(None, description="The SRDF group of the arm's joints.")
    base: str | None = Field(None, description="Without an SRDF group: the link the arm is mounted on.")
    tip: str | None = Field(None, description="... and the link at its end.")
    tool: str | None = Field(None, description="The tool frame's link (default: SRDF end effector, or the tip).")
    tool_offset: Pose | None = None
    hand: Literal["none", "allegro"] | Gripper = "none"
    ik: str = "numeric"
    object_axis: Literal["+x", "-x", "+y", "-y", "+z", "-z"] = Field(
        "-z",
        description="The tool axis along a held object's z axis (-z: held out of the tool, upright when it points down).",
    )
    model: str | None = Field(None, description="The arm's model in words (default: the robot's label).")
    ros_industrial: bool = Field(
        False, description="Also name the arm's base link `base` and its flange (the last joint's link) `tool0`."
    )

    @field_validator("ik")
    @classmethod
    def _known_kind(cls, kind: str) -> str:
        if kind not in IK_KINDS:
            raise ValueError(f"unknown IK kind {kind!r}; choose one of {', '.join(IK_KINDS)}")
        return kind

    @model_validator(mode="after")
    def _group_or_chain(self) -> ArmSpec:
        if (self.group is None) == (self.base is None or self.tip is None):
            raise ValueError("give an arm either an SRDF group or both base and tip links")
        if self.group is not None and (self.base or self.tip):
            raise ValueError("give an arm either an SRDF group or base and tip links, not both")
        return self


class JointLimits(_Strict):
    """Overrides of a joint's URDF limits. `lower`/`upper` (rad or m) narrow a revolute or
    prismatic joint's range, or give a continuous joint the range it is planned in (it is then
    planned as a revolute joint: a Kinova's or a PR2's wrist)."""

    lower: FiniteFloat | None = None
    upper: FiniteFloat | None = None
    velocity: PositiveFloat | None = None
    acceleration: PositiveFloat | None = None

    @model_validator(mode="after")
    def _ordered(self) -> JointLimits:
        if self.lower is not None and self.upper is not None and not self.lower < self.upper:
            raise ValueError(f"lower ({self.lower}) must be below upper ({self.upper})")
        return self


class Stopping(_Strict):
    """ISO/TS 15066 5.5.4 data a deployment measures: T_r, T_s (s), Z_r (m), and m_R (kg, Annex A.3.2)."""

    reaction_time: PositiveFloat
    stopping_time: PositiveFloat
    position_uncertainty: NonNegativeFloat
    moving_mass: PositiveFloat


ONTOLOGY_STOPPING = {
    "reaction_time": "hasReactionTime",
    "stopping_time": "hasStoppingTime",
    "position_uncertainty": "hasPositionUncertainty",
    "moving_mass": "hasMovingMass",
}


class RobotFile(_Strict):
    name: Identifier
    label: str | None = None
    summary: str = "A robot"
    urdf: str
    srdf: str | None = None
    packages: dict[str, str] = Field(default_factory=dict)
    arms: dict[Identifier, ArmSpec] = Field(min_length=1)
    frame_aliases: dict[Identifier, str] = Field(default_factory=dict, description="Other names of links.")
    postures: dict[str, dict[str, float]] = Field(default_factory=dict)
    limits: dict[str, JointLimits] = Field(default_factory=dict)
    base_pose: Pose = Field(default_factory=Pose)
    allowed_collisions: list[tuple[str, str]] = Field(
        default_factory=list,
        description="Link pairs never checked for self-collision, as the user says (MoveIt's 'User' reason).",
    )
    stopping: Stopping | None = Field(None, description="Needed to plan: speed and separation use it.")


def package_search_path() -> list[Path]:
    """Folders that hold ROS packages: ROS_PACKAGE_PATH (a package's own folder counts as its
    parent's, as pinocchio reads it), AMENT_PREFIX_PATH's share/, and example-robot-data's."""
    folders = []
    for entry in filter(None, os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep)):
        path = Path(entry)
        folders.append(path.parent if (path / "package.xml").exists() else path)
    for entry in filter(None, os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep)):
        folders.append(Path(entry) / "share")
    return [*folders, robots_dir().parent.parent]


def resolve_file(uri: str, packages: dict[str, Path], folder: Path, what: str) -> Path:
    """A file name as an absolute path: package://NAME/ through `packages` then the search path,
    file:// and relative names from `folder`; a file that is not there is an error."""
    match = PACKAGE_URI.match(uri)
    if match:
        name, rest = match.groups()
        roots = (
            [packages[name]] if name in packages else [d / name for d in package_search_path() if (d / name).is_dir()]
        )
        if not roots:
            raise HriplanError(f"{what} {uri}: no package {name!r} (name its folder under packages:)")
        path = roots[0] / rest
    else:
        path = folder / uri.removeprefix("file://")
    if not path.is_file():
        raise HriplanError(f"missing {what} {path}" + (f" (from {uri})" if str(path) != uri else ""))
    return path.resolve()


def _resolve_meshes(root: ET.Element, packages: dict[str, Path], folder: Path) -> None:
    """Every <mesh filename> of a URDF as an absolute path (`resolve_file`), each distinct name
    resolved once: MADAR's 70 meshes are 27 files, and resolving a path (a stat of each of its
    folders) took 11 of the 30 ms that reading the built-in robots took at every start."""
    resolved: dict[str, str] = {}
    for el in root.iter("mesh"):
        name = el.get("filename", "")
        if name not in resolved:
            resolved[name] = str(resolve_file(name, packages, folder, "mesh"))
        el.set("filename", resolved[name])


def _urdf_root(path: Path) -> ET.Element:
    try:
        root = ET.fromstring(read_text(path, "URDF file"))
    except ET.ParseError as exc:
        raise HriplanError(f"{path}: not valid URDF XML ({exc})") from None
    if root.tag != "robot":
        raise HriplanError(f"{path}: not a URDF (its top element is <{root.tag}>, not <robot>)")
    return root


def _unused(name: str, taken: Collection[str]) -> str:
    """`name`, else `name1`, `name2`, ...: the first that `taken` does not hold."""
    return next(f"{name}{k or ''}" for k in range(len(taken) + 1) if f"{name}{k or ''}" not in taken)


def _rename_fixed_joints_named_as_links(root: ET.Element) -> None:
    """Give a fixed joint named like a link (Unitree Z1's `gripperStator`) a name of its own,
    `NAME_joint`: pinocchio cannot reduce a model whose frames share a name, and nothing refers
    to a fixed joint (not postures, trajectories or the SRDF's states), so the rename is unseen."""
    links = {el.get("name") for el in root.findall("link")}
    joints = root.findall("joint")
    names = {el.get("name") for el in joints}
    for el in joints:
        if el.get("type") == "fixed" and el.get("name") in links:
            new = _unused(f"{el.get('name')}_joint", names | links)
            names.add(new)
            el.set("name", new)


class _Builder:
    """Turns a validated robot file into a description (every check in one place)."""

    def __init__(self, spec: RobotFile, folder: Path) -> None:
        self.spec = spec
        packages = {name: (folder / path).resolve() for name, path in spec.packages.items()}
        urdf = resolve_file(spec.urdf, packages, folder, "URDF file")
        self.root = _urdf_root(urdf)
        _rename_fixed_joints_named_as_links(self.root)
        _resolve_meshes(self.root, packages, urdf.parent)
        self._set_ranges()
        self.tree = UrdfTree(self.root)
        self.frame_aliases = {}
        for alias, link in spec.frame_aliases.items():
            if alias in self.tree.links:
                raise HriplanError(f"frame_aliases.{alias}: the URDF already has a link {alias!r}")
            self.frame_aliases[alias] = self.tree.link(link, f"frame_aliases.{alias}")
        if spec.srdf is None:
            self.srdf = Srdf()
        else:
            self.srdf = read_srdf(
                read_text(resolve_file(spec.srdf, packages, folder, "SRDF file"), "SRDF file"), self.tree
            )

    def _set_ranges(self) -> None:
        """Write the file's joint ranges (`limits.J.lower/upper`) into the URDF: within the URDF's
        own range for a revolute or prismatic joint (a range only narrows), both ends for a
        continuous joint, which becomes revolute."""
        joints = {el.get("name"): el for el in self.root.findall("joint")}
        for name, limits in self.spec.limits.items():
            if limits.lower is None and limits.upper is None:
                continue
            what = f"limits.{name}"
            if name not in joints:
                raise HriplanError(f"{what}: the URDF has no joint {name!r}")
            element, kind = joints[name], joints[name].get("type")
            limit = element.find("limit")
            if kind == "continuous":
                if limits.lower is None or limits.upper is None:
                    raise HriplanError(f"{what}: a continuous joint needs both lower and upper")
                element.set("type", "revolute")
                if limit is None:
                    if limits.velocity is None:
                        raise HriplanError(f"{what}: the URDF gives joint {name!r} no <limit>: give its velocity too")
                    limit = ET.SubElement(element, "limit", effort="0", velocity=repr(limits.velocity))
            elif kind in ("revolute", "prismatic") and limit is not None:
                own = float(limit.get("lower", "0")), float(limit.get("upper", "0"))
                lower, upper = limits.lower, limits.upper
                if (lower is not None and lower < own[0]) or (upper is not None and upper > own[1]):
                    raise HriplanError(
                        f"{what}: [{lower}, {upper}] is not within the URDF's range [{own[0]:.6g}, {own[1]:.6g}]"
                        " (a range only narrows)"
                    )
            else:
                raise HriplanError(f"{what}: joint {name!r} is {kind} and has no range to set")
            for end, value in (("lower", limits.lower), ("upper", limits.upper)):
                if value is not None:
                    limit.set(end, repr(value))
            if not float(limit.get("lower", "0")) < float(limit.get("upper", "0")):
                raise HriplanError(f"{what}: the range [{limit.get('lower')}, {limit.get('upper')}] is empty")

    def arm_joints(self, arm: str, a: ArmSpec) -> list[str]:
        what = f"arms.{arm}"
        if a.group is not None:
            if a.group not in self.srdf.groups:
                known = ", ".join(self.srdf.groups) or "none"
                raise HriplanError(f"{what}.group: the SRDF has no group {a.group!r} (groups: {known})")
            joints = self.srdf.groups[a.group]
        else:
            joints = self.tree.chain(a.base, a.tip, what)
        movable = [j for j in self.tree.movable(joints) if self.tree.joints[j].mimic is None]
        if not movable:
            raise HriplanError(f"{what}: group {a.group or arm!r} has no joints that move")
        for j in movable:
            if self.tree.joints[j].type == "continuous":
                raise HriplanError(
                    f"{what}: joint {j!r} is continuous; give the range to plan it in, e.g. "
                    f"limits: {{{j}: {{lower: -6.2832, upper: 6.2832}}}}"
                )
        for before, after in zip(movable, movable[1:]):
            if self.tree.moving_between(before, self.tree.joints[after].parent) != []:
                raise HriplanError(f"{what}: not a serial chain: joint {after!r} does not follow joint {before!r}")
        return movable

    def aliases(self, arm: str, a: ArmSpec, prefix: str, joints: list[str]) -> None:
        """Add the arm's ROS-Industrial names (`base`, `tool0`) to `self.frame_aliases`, except
        where the URDF has a link of that name already (ur_description's own base and tool0)."""
        if not a.ros_industrial:
            return
        names = {
            f"{prefix}base": self.tree.joints[joints[0]].parent,
            f"{prefix}tool0": self.tree.joints[joints[-1]].child,
        }
        for alias, link in names.items():
            if alias in self.frame_aliases:
                raise HriplanError(f"arms.{arm}.ros_industrial: {alias!r} is also in frame_aliases")
            if alias not in self.tree.links:
                self.frame_aliases[alias] = link

    def tool(self, arm: str, a: ArmSpec, joints: list[str]) -> str:
        what = f"arms.{arm}.tool"
        if a.tool is not None:
            link = self.tree.link(self.frame_aliases.get(a.tool, a.tool), what)
        elif a.group is not None:
            ends = [e for e in self.srdf.end_effectors if a.group in (e.parent_group, e.group)]
            if not ends:
                raise HriplanError(
                    f"arms.{arm}: no tool frame (the SRDF has no end effector on group {a.group!r}); name a link as tool:"
                )
            link = ends[0].parent_link
        else:
            link = a.tip
        last = joints[-1]
        if self.tree.moving_between(last, link) != []:
            raise HriplanError(f"{what}: link {link!r} does not move rigidly with the arm's last joint {last!r}")
        if a.tool_offset is None:
            return link
        name = f"{arm}_tool"
        if name in self.tree.links:
            raise HriplanError(f"{what}: the URDF already has a link {name!r} for the offset tool frame")
        xyz, rpy = _xyz_rpy(a.tool_offset)
        X.link(self.root, name)
        # Its joint's name is ours to choose: one the URDF does not use (TIAGo has an arm_tool_joint).
        X.joint(self.root, _unused(f"{name}_joint", self.tree.joints), "fixed", link, name, xyz, rpy)
        return name

    def hand(self, arm: str, a: ArmSpec, prefix: str, joints: list[str]) -> str | None:
        if a.hand == "none":
            return None
        if a.hand == "allegro":
            self.tree.joint(hand_joint_name(prefix, "joint_0.0"), f"arms.{arm}.hand")
            return "allegro"
        for j in a.hand.gripper:
            if self.tree.joint(j, f"arms.{arm}.hand").type not in MOVABLE or j in joints:
                raise HriplanError(f"arms.{arm}.hand: {j!r} is not a finger joint (fixed, or an arm joint)")
        kind = f"{self.spec.name}_{arm}_gripper"
        values = {"open": a.hand.open, "release": a.hand.open, "closed": a.hand.closed}
        # A listed finger that mimics another takes the URDF's multiplier and offset of its value
        # (Baxter's right finger mirrors its left, multiplier -1); the others take the value.
        follows = {}
        for el in self.root.findall("joint"):
            mimic = el.find("mimic")
            if el.get("name") in a.hand.gripper and mimic is not None and mimic.get("joint") in a.hand.gripper:
                follows[el.get("name")] = (float(mimic.get("multiplier", 1.0)), float(mimic.get("offset", 0.0)))
        fingers = {j: follows.get(j, (1.0, 0.0)) for j in a.hand.gripper}
        HAND_MODELS[kind] = HandModel(
            "parallel gripper",
            GRIPPER_POSTURES,
            "release",
            lambda posture: {j: m * values[posture] + o for j, (m, o) in fingers.items()},
            lambda _prefix, joint: joint,
        )
        return kind

    def hand_axes(self, arm: str, a: ArmSpec, tool: str) -> tuple[str, str, str]:
        """Where hriplan's hand frame (grasps are written in it: z out of the palm, y across the
        fingers, x = y x z) lies in the tool frame: for a parallel gripper, z is the tool's z
        (the approach) and y the tool axis across both the approach and the direction its first
        finger joint moves in, read from the URDF (a gripper closing along its tool y holds a
        side-grasped cylinder along its tool x)."""
        if not isinstance(a.hand, Gripper):
            return ("+x", "+y", "+z")
        if a.hand.closes_along is not None:
            return ("+x", "+y", "+z") if a.hand.closes_along == "x" else ("-y", "+x", "+z")
        model = pin.buildModelFromXML(ET.tostring(self.root, encoding="unicode"))
        data = model.createData()
        pin.framesForwardKinematics(model, data, pin.neutral(model))
        finger = a.hand.gripper[0]
        element = next(el for el in self.root.findall("joint") if el.get("name") == finger)
        axis = element.find("axis")
        local = np.array([float(v) for v in (axis.get("xyz", "1 0 0") if axis is not None else "1 0 0").split()])
        world = data.oMi[model.getJointId(finger)].rotation @ local
        in_tool = data.oMf[model.getFrameId(tool)].rotation.T @ world
        # A sliding finger closes along its axis; a hinged one swings across its axis and the approach.
        moves = in_tool if element.get("type") == "prismatic" else np.cross(in_tool, [0.0, 0.0, 1.0])
        k = int(np.argmax(np.abs(moves)))
        if k == 2 or abs(moves[k]) < 0.99 * max(float(np.linalg.norm(moves)), 1e-9):
            raise HriplanError(
                f"arms.{arm}.hand: finger joint {finger!r} ({element.get('type')}, axis {np.round(in_tool, 3).tolist()} "
                f"in the tool frame {tool!r}) does not close along the tool's x or y axis; say which: closes_along: x or y"
            )
        return ("+x", "+y", "+z") if k == 0 else ("-y", "+x", "+z")

    def postures(self, planning: list[str]) -> dict[str, dict[str, float]]:
        limits = {
            el.get("name"): (float(el.find("limit").get("lower", "-inf")), float(el.find("limit").get("upper", "inf")))
            for el in self.root.findall("joint")
            if el.find("limit") is not None
        }
        postures: dict[str, dict[str, float]] = {}
        for name, _group, values in self.srdf.states:
            postures.setdefault(name, {}).update({j: v for j, v in values.items() if j in planning})
        for name, values in self.spec.postures.items():
            postures[name] = postures.get(name, {}) | values
        for name, values in postures.items():
            for j, v in values.items():
                if j not in planning:
                    raise HriplanError(f"postures.{name}: {j!r} is not an arm joint; arm joints: {', '.join(planning)}")
                lower, upper = limits.get(j, (-float("inf"), float("inf")))
                if lower <= v <= upper:
                    continue
                turned = _by_whole_turns(v, lower, upper) if self.tree.joints[j].type == "revolute" else None
                if turned is None:
                    raise HriplanError(
                        f"postures.{name}: {j} = {v:.4g} is beyond its limits [{lower:.4g}, {upper:.4g}]"
                        " (a robot file's postures override its SRDF's)"
                    )
                values[j] = turned  # the same placement of the joint's link (Kinova's SRDF: -pi/2 for 3 pi/2)
        return postures

    def limits(self) -> dict[str, float]:
        """Velocity overrides written into the URDF; the acceleration limits (rad/s^2) per joint."""
        elements = {el.get("name"): el for el in self.root.findall("joint")}
        acceleration = {}
        for j, limits in self.spec.limits.items():
            self.tree.joint(j, "limits")
            if limits.velocity is not None:
                element = elements[j].find("limit")
                if element is None:
                    raise HriplanError(f"limits.{j}: the URDF joint has no <limit> to override")
                element.set("velocity", repr(limits.velocity))
            if limits.acceleration is not None:
                acceleration[j] = limits.acceleration
        return acceleration

    def shared_names(self) -> None:
        """pinocchio cannot reduce a model in which a moving joint has the name of a link (its
        frames are ambiguous: so_arm100's `gripper`), and renaming either would change names the
        robot file and the trajectories use: say so in one line, not with its traceback."""
        shared = sorted(set(self.tree.joints) & set(self.tree.links))
        if shared:
            raise HriplanError(
                f"the URDF names a moving joint and a link alike ({', '.join(shared)}), which pinocchio"
                " cannot reduce to the arms: rename one of each pair in a copy of the URDF"
            )

    def whole_group(self, arms: dict[str, ArmDescription], planning: list[str]) -> str:
        """The group of every arm joint: a one-armed robot's arm group, else the SRDF group of
        exactly the arms' joints (MADAR's both_arms), else `all_arms`."""
        if len(arms) == 1:
            return next(iter(arms.values())).group
        for name, joints in self.srdf.groups.items():
            movable = [j for j in self.tree.movable(joints) if self.tree.joints[j].mimic is None]
            if sorted(movable) == sorted(planning):
                return name
        return "all_arms"

    def description(self, source: str) -> RobotDescription:
        spec = self.spec
        label = spec.label or spec.name
        arms = {}
        for arm, a in spec.arms.items():
            prefix = "" if len(spec.arms) == 1 else f"{arm}_"
            joints = self.arm_joints(arm, a)
            self.aliases(arm, a, prefix, joints)
            tool = self.tool(arm, a, joints)
            hand_axes = self.hand_axes(arm, a, tool)
            arms[arm] = ArmDescription(
                prefix,
                tool,
                a.group or arm,
                tuple(joints),
                self.tree.joints[joints[0]].parent,
                hand=self.hand(arm, a, prefix, joints),
                ik=a.ik,
                model=a.model or label,
                object_axis=a.object_axis,
                hand_axes=hand_axes,
            )
        planning = [j for a in arms.values() for j in a.joints]
        if len(set(planning)) != len(planning):
            raise HriplanError("arms: two arms share a joint")
        self.shared_names()
        whole = self.whole_group(arms, planning)
        acceleration = self.limits()
        text = ET.tostring(self.root, encoding="unicode")
        return RobotDescription(
            name=spec.name,
            label=label,
            summary=spec.summary,
            urdf=functools.partial(str, text),
            base_link=self.tree.root,
            arms=arms,
            whole_group=whole,
            postures=self.postures(planning),
            base_pose=_xyz_rpy(spec.base_pose),
            acceleration_limits=acceleration,
            source=source,
            srdf=self.srdf if spec.srdf else None,
            link_aliases=self.frame_aliases,
            allowed_collisions=tuple(
                (self.tree.link(a, "allowed_collisions"), self.tree.link(b, "allowed_collisions"))
                for a, b in spec.allowed_collisions
            ),
            stopping={} if spec.stopping is None else {ONTOLOGY_STOPPING[k]: v for k, v in spec.stopping},
        )


def _by_whole_turns(value: float, lower: float, upper: float) -> float | None:
    """`value` moved by the fewest whole turns into [lower, upper], or None if no turn fits."""
    turns = [k for k in range(-3, 4) if lower <= value + 2 * math.pi * k <= upper]
    return value + 2 * math.pi * min(turns, key=abs) if turns else None


def _xyz_rpy(pose: Pose) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    rpy = pin.rpy.matrixToRpy(pose.se3().rotation)
    return tuple(pose.xyz), (float(rpy[0]) + 0.0, float(rpy[1]) + 0.0, float(rpy[2]) + 0.0)  # no -0.0


def robot_description(spec: RobotFile, path: Path, source: str) -> RobotDescription:
    """The robot of the robot file `spec` read from `path`; `source` is what the description
    names as its file ("" for a built-in robot: a trajectory of it names the robot only)."""
    try:
        return _Builder(spec, path.parent).description(source)
    except HriplanError as exc:
        raise HriplanError(f"{path}: {exc}") from None
