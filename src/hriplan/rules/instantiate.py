"""From a required constraint kind and its anchor to the planner's constraint specification.

The reasoned facts say which kind applies about which object or person; the kind's class says
which planner constraint it becomes, its data in the ontology give the parameters, and the
situation gives the geometry: the carried object's axis, the hole's axis, where the person
stands and which way the robot is from them. Joints and tool come from the arm carrying the
object (object kinds) or from every arm the task uses (person kinds).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import pinocchio as pin

from hriplan import HriplanError
from hriplan.ontology.facts import Facts
from hriplan.ontology.situation import Situation, SituationHuman, SituationObject
from hriplan.planner.constraints.spec import (
    BoxConstraint,
    ConeConstraint,
    ConstraintSpec,
    CylinderConstraint,
    FrameRef,
    OrientationConstraint,
    SphereConstraint,
)
from hriplan.robots.human import HELD_OBJECT_OFFSET, HumanSpec, person_frame
from hriplan.robots.spatial import Pose
from hriplan.rules.geometry import angle_between, bearing, box_between, rotation_pose, rotation_with_axis

SIGNED_AXES = ("+x", "-x", "+y", "-y", "+z", "-z")
# A cone reaching back to the tool's start is this much longer than the distance to it.
CONE_START_MARGIN = 0.05
VELOCITY_KIND = "VelocityScalingKind"


@dataclass(frozen=True)
class Arm:
    """An arm as the ontology describes it."""

    name: str
    joints: list[str]
    tool: str
    object_axis: str  # tool-frame axis along a held object's z axis


@dataclass(frozen=True)
class Context:
    situation: Situation
    facts: Facts
    # Each arm as `arm` read it from `facts`: a derivation asks for an arm once per constraint on it.
    _arms: dict[str, Arm] = field(default_factory=dict, compare=False, repr=False)

    @property
    def task(self) -> str:
        return self.situation.task.name

    def param(self, kind: str, prop: str) -> float:
        return self.facts.number(kind, prop)

    def arm(self, individual: str) -> Arm:
        """An arm's name, joints in chain order, tool frame and usual grasp axis, from the ontology."""
        if individual not in self._arms:
            self._arms[individual] = self._read_arm(individual)
        return self._arms[individual]

    def _read_arm(self, individual: str) -> Arm:
        facts = self.facts
        joints = sorted(facts.get(individual, "hasJoint"), key=lambda j: facts.number(str(j), "hasChainIndex"))
        tool_link = str(facts.one(individual, "hasToolLink"))
        axis = str(facts.one(individual, "hasObjectAxisInTool"))
        if axis not in SIGNED_AXES:
            raise HriplanError(
                f"arm {individual} has object axis {axis!r} in the ontology; use one of {', '.join(SIGNED_AXES)}"
            )
        return Arm(
            name=str(facts.one(individual, "hasArmName")),
            joints=[str(facts.one(str(j), "hasUrdfName")) for j in joints],
            tool=str(facts.one(tool_link, "hasUrdfName")),
            object_axis=axis,
        )

    def robot_xy(self) -> tuple[float, float]:
        x, y, _ = self.situation.robot_base.xyz
        return x, y

    def robot_bearing(self, human: SituationHuman) -> float:
        return bearing(human.position, human.yaw, self.robot_xy(), human.name)


Make = Callable[[Context, str, str, Arm, str], ConstraintSpec]


@dataclass(frozen=True)
class Form:
    """How a class of constraint kinds becomes a planner constraint, and what it is about."""

    about: Literal["object", "human"]
    make: Make


def anchored_arms(ctx: Context, form: Form, kind: str, anchor: str) -> list[Arm]:
    """The arms a constraint binds: the one carrying the object, or every arm of the task."""
    if form.about == "object":
        if anchor not in ctx.situation.object_names():
            raise HriplanError(f"constraint kind {kind} applies to a carried object, but {anchor!r} is not an object")
        arms = ctx.facts.get(anchor, "isCarriedBy")
        if not arms:
            raise HriplanError(f"constraint kind {kind} applies to {anchor!r}, but no arm carries it (task.carries)")
    else:
        if anchor not in {h.name for h in ctx.situation.humans}:
            raise HriplanError(f"constraint kind {kind} applies to a person, but {anchor!r} is not one")
        arms = ctx.facts.get(ctx.task, "usesArm")
    return [ctx.arm(str(a)) for a in arms]


def _upright(ctx: Context, kind: str, anchor: str, arm: Arm, cid: str) -> ConstraintSpec:
    return _orientation(ctx, kind, ctx.situation.object(anchor), arm, cid, np.array([0.0, 0.0, 1.0]), FrameRef())


def _alignment(ctx: Context, kind: str, anchor: str, arm: Arm, cid: str) -> ConstraintSpec:
    hole = ctx.situation.object(str(ctx.facts.one(anchor, "goesInto")))
    return _orientation(ctx, kind, ctx.situation.object(anchor), arm, cid, hole.pose.rotation()[:, 2], FrameRef())


def _pointing_away(ctx: Context, kind: str, anchor: str, arm: Arm, cid: str) -> ConstraintSpec:
    human = ctx.situation.human(str(ctx.facts.one(ctx.task, "hasTargetHuman")))
    b = ctx.robot_bearing(human)  # away from the person = towards the robot, in their frame
    away = np.array([math.cos(b), math.sin(b), 0.0])
    return _orientation(ctx, kind, ctx.situation.object(anchor), arm, cid, away, FrameRef(entity=f"{human.name}/base"))


def _pointing_down_away(ctx: Context, kind: str, anchor: str, arm: Arm, cid: str) -> ConstraintSpec:
    """The object's z axis tilted from straight down towards the robot, away from each person it
    comes near (their directions to the robot summed); straight down if those cancel."""
    robot = np.array(ctx.robot_xy())
    away = np.zeros(2)
    for name in ctx.facts.get(anchor, "isNear"):
        towards = robot - np.array(ctx.situation.human(str(name)).position)
        away += towards / max(float(np.linalg.norm(towards)), 1e-9)
    tilt, norm = ctx.param(kind, "hasTilt"), float(np.linalg.norm(away))
    side = np.append(away / norm, 0.0) if norm > 1e-6 else np.zeros(3)
    direction = math.cos(tilt) * np.array([0.0, 0.0, -1.0]) + math.sin(tilt) * side
    return _orientation(ctx, kind, ctx.situation.object(anchor), arm, cid, direction, FrameRef())


def _orientation(
    ctx: Context, kind: str, obj: SituationObject, arm: Arm, cid: str, direction: np.ndarray, frame: FrameRef
) -> OrientationConstraint:
    """The held object's z axis (a signed tool axis) along `direction`, spin about it free."""
    axis = obj.grasp_axis or arm.object_axis
    return OrientationConstraint(
        id=cid,
        joints=arm.joints,
        target_link=arm.tool,
        frame=frame,
        target=rotation_pose(rotation_with_axis(axis, direction)),
        free_axes=[axis[1]],
        tolerance=ctx.param(kind, "hasTolerance"),
        tolerance_gradient=ctx.param(kind, "hasToleranceGradient"),
    )


def _approach_cone(ctx: Context, kind: str, anchor: str, arm: Arm, cid: str) -> ConstraintSpec:
    """A cone opening from the person's hand towards the robot, through the meeting point in
    front of the palm. With the tool's start known the cone is aimed from the meeting point at
    it, as the seed framework aligns its cone with the end effector, and reaches past it (same
    opening angle), so the whole approach lies inside; unless that axis turns further than the
    ontology allows from the line towards the robot (an approach the person would not see)."""
    human = ctx.situation.human(anchor)
    hand = str(ctx.facts.one(str(ctx.facts.one(anchor, "hasActiveHand")), "hasFrameName"))
    b = ctx.robot_bearing(human)
    radius, height = ctx.param(kind, "hasRadius"), ctx.param(kind, "hasHeight")
    # In the hand's frame (oriented like the person, x forward): apex at the palm, axis to the robot.
    apex, axis = np.zeros(3), np.array([math.cos(b), math.sin(b), 0.0])
    start = ctx.situation.tool_poses.get(arm.name)
    if start is not None:
        palm = person_frame(HumanSpec(**human.model_dump(include=set(HumanSpec.model_fields))), hand.split("/", 1)[1])
        meeting = np.array([HELD_OBJECT_OFFSET, 0.0, 0.0])
        towards = palm.rotation.T @ (np.array(start.xyz) - palm.translation) - meeting
        distance = float(np.linalg.norm(towards))
        if distance > 1e-6 and angle_between(towards, axis) <= ctx.param(kind, "hasMaxAxisDeviation"):
            axis = towards / distance
            apex = meeting - axis * HELD_OBJECT_OFFSET  # the meeting point stays as deep in the cone
            stretch = max(1.0, (HELD_OBJECT_OFFSET + distance) * (1.0 + CONE_START_MARGIN) / height)
            radius, height = radius * stretch, height * stretch
    opening = Pose.from_se3(pin.SE3(rotation_with_axis("+z", axis), apex))
    return ConeConstraint(
        id=cid,
        joints=arm.joints,
        target_link=arm.tool,
        frame=FrameRef(entity=hand, offset=opening),
        region="inside",
        radius=radius,
        height=height,
    )


def _workspace_box(ctx: Context, kind: str, anchor: str, arm: Arm, cid: str) -> ConstraintSpec:
    human = ctx.situation.human(anchor)
    pose, size = box_between(
        ctx.robot_xy(),
        human.position,
        ctx.param(kind, "hasRobotMargin"),
        ctx.param(kind, "hasHumanClearance"),
        ctx.param(kind, "hasWidth"),
        ctx.param(kind, "hasBottomHeight"),
        ctx.param(kind, "hasTopHeight"),
        anchor,
    )
    return BoxConstraint(
        id=cid, joints=arm.joints, target_link=arm.tool, frame=FrameRef(offset=pose), region="inside", size=size
    )


def _exclusion_box(ctx: Context, kind: str, anchor: str, arm: Arm, cid: str) -> ConstraintSpec:
    frame = FrameRef(entity=f"{anchor}/torso", offset=Pose(xyz=(0.0, 0.0, ctx.param(kind, "hasVerticalOffset"))))
    size = (ctx.param(kind, "hasDepth"), ctx.param(kind, "hasWidth"), ctx.param(kind, "hasHeight"))
    return BoxConstraint(
        id=cid,
        joints=arm.joints,
        target_link=arm.tool,
        frame=frame,
        region="outside",
        keep_out_all_links=True,
        size=size,
    )


def _keep_out(volume: type[ConstraintSpec], frame: str, arm: Arm, cid: str, **dimensions: float) -> ConstraintSpec:
    """A volume around a person that the tool and every robot link stay outside."""
    return volume(
        id=cid,
        joints=arm.joints,
        target_link=arm.tool,
        frame=FrameRef(entity=frame),
        region="outside",
        keep_out_all_links=True,
        **dimensions,
    )


def _keep_out_cylinder(ctx: Context, kind: str, anchor: str, arm: Arm, cid: str) -> ConstraintSpec:
    radius, height = ctx.param(kind, "hasSeparationDistance"), ctx.param(kind, "hasHeight")
    return _keep_out(CylinderConstraint, f"{anchor}/base", arm, cid, radius=radius, height=height)


def _keep_out_sphere(ctx: Context, kind: str, anchor: str, arm: Arm, cid: str) -> ConstraintSpec:
    return _keep_out(SphereConstraint, f"{anchor}/head", arm, cid, radius=ctx.param(kind, "hasSeparationDistance"))


FORMS: dict[str, Form] = {
    "UprightKind": Form("object", _upright),
    "AlignmentKind": Form("object", _alignment),
    "PointingAwayKind": Form("object", _pointing_away),
    "PointingDownAwayKind": Form("object", _pointing_down_away),
    "ApproachConeKind": Form("human", _approach_cone),
    "WorkspaceBoxKind": Form("human", _workspace_box),
    "ExclusionBoxKind": Form("human", _exclusion_box),
    "KeepOutCylinderKind": Form("human", _keep_out_cylinder),
    "KeepOutSphereKind": Form("human", _keep_out_sphere),
}


def form_of(facts: Facts, kind: str) -> Form | None:
    """The planner form of a kind from its class; None for velocity scaling; error otherwise."""
    if facts.is_a(kind, VELOCITY_KIND):
        return None
    for cls, form in FORMS.items():
        if facts.is_a(kind, cls):
            return form
    raise HriplanError(
        f"constraint kind {kind} has no planner form: make it an individual of one of "
        f"{', '.join([*FORMS, VELOCITY_KIND])}"
    )
