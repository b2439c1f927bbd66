"""Grasps a person would use, from the ontology: which ones an object allows, in order.

An object kind affords grasps (side, top, handle; `affordsGrasp` on its class), rules may
require some (`requiresGrasp`: a full open cup from the side, a knife by its handle) of those it
affords, and each
grasp says which tool axis lies along the object's axis and where along the object the hand
closes. An arm without a robot hand (a bare UR5 flange) holds objects along its usual axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hriplan import HriplanError
from hriplan.ontology.facts import Facts
from hriplan.robots.bounding import frame_with_z
from hriplan.robots.scene import Box, Cone, Cylinder, Shape, Sphere
from hriplan.robots.spatial import Transform

AXIS_INDEX = {"x": 0, "y": 1, "z": 2}


USUAL = "usual"  # the grasp of an arm without a robot hand: along its usual axis


@dataclass(frozen=True)
class Grasp:
    name: str
    axis: str  # signed tool axis along the held object's z axis
    offset: float = 0.0  # where the hand closes: from the centre along the object's z, per length

    def described(self, obj: str) -> str:
        """How a message says `obj` is held: by its grasp's name, or (an arm without a hand)
        along the tool axis the robot holds objects by."""
        return f"{obj} along the tool's {self.axis}" if self.name == USUAL else f"{obj} by {self.name}"

    def object_in_tool(self, length: float) -> Transform:
        """Pose of the held object in the tool frame: its z along `axis`, the grasp point at the tool."""
        z = np.zeros(3)
        z[AXIS_INDEX[self.axis[1]]] = -1.0 if self.axis[0] == "-" else 1.0
        return Transform(frame_with_z(z), -self.offset * length * z)


def grasp_holding(in_tool: Transform, shape: Shape | None, name: str = "perceived") -> Grasp:
    """The grasp that holds an object at `in_tool` (its pose in the tool frame, as a session's
    held object has it): the signed tool axis nearest the object's axis, and where along it the
    hand closes; an object held at the pose of a grasp gives that grasp's axis and offset."""
    z = in_tool.rotation[:, 2]
    k = int(np.argmax(np.abs(z)))
    axis = f"{'-' if z[k] < 0.0 else '+'}{'xyz'[k]}"
    length = object_length(shape)
    offset = 0.0 if length == 0.0 else float(-(in_tool.translation @ z) / length)
    return Grasp(name, axis, offset)


def object_length(shape: Shape | None) -> float:
    """Length of an object along its z axis (0 without a shape: the grasp point is its centre)."""
    if isinstance(shape, (Cylinder, Cone)):
        return shape.height
    if isinstance(shape, Box):
        return shape.size[2]
    if isinstance(shape, Sphere):
        return 2.0 * shape.radius
    return 0.0


def allowed_grasps(facts: Facts, obj: str, arm_individual: str, usual_axis: str) -> list[Grasp]:
    """The grasps the rules allow for `obj` in an arm, most preferred first."""
    if not facts.get(arm_individual, "hasRobotHand"):
        return [Grasp(USUAL, usual_axis)]
    required, afforded = set(map(str, facts.get(obj, "requiresGrasp"))), set(map(str, facts.get(obj, "affordsGrasp")))
    if not afforded | required:
        return [Grasp(USUAL, usual_axis)]
    names = (
        required & afforded if required and afforded else required or afforded
    )  # rules restrict what the kind affords
    if not names:
        raise HriplanError(
            f"no grasp of {obj} is allowed: the rules require {', '.join(sorted(required))}, "
            f"its kind affords {', '.join(sorted(afforded))}"
        )
    return [
        _grasp(facts, n, arm_individual)
        for n in sorted((str(n) for n in names), key=lambda n: (facts.number(n, "hasPreference"), n))
    ]


def stated_grasp(facts: Facts, obj: str, name: str, arm_individual: str) -> Grasp:
    """The grasp a task says `obj` is held by from the start: any grasp its kind affords. The
    rules' required grasps are about closing a hand on it (a hand closing over a full bowl's rim
    spills it), which happened before the task, so they do not rule a stated grasp out."""
    if not facts.get(arm_individual, "hasRobotHand"):
        raise HriplanError(f"{obj} is held by {name}, but {arm_individual} has no robot hand to hold it by a grasp")
    afforded = sorted(map(str, facts.get(obj, "affordsGrasp")))
    if name not in afforded:
        raise HriplanError(
            f"{obj} is held by {name}, which its kind does not afford; it affords {', '.join(afforded) or 'no grasp'}"
        )
    return _grasp(facts, name, arm_individual)


SIGNED_AXES = ("+x", "-x", "+y", "-y", "+z", "-z")


def _grasp(facts: Facts, name: str, arm_individual: str) -> Grasp:
    """A grasp individual of the ontology in an arm's hand: its axis (written in hriplan's hand
    frame) as the arm's tool axis (the arm's hasHandAxesInTool; the same axis without it) and
    its offset."""
    axis = str(facts.one(name, "hasGraspAxis"))
    if axis not in SIGNED_AXES:
        raise HriplanError(f"grasp {name} has axis {axis!r} in the ontology; use one of {', '.join(SIGNED_AXES)}")
    hand_axes = facts.get(arm_individual, "hasHandAxesInTool")
    if hand_axes:
        axes = str(hand_axes[0]).split()
        if len(axes) != 3 or any(a not in SIGNED_AXES for a in axes) or len({a[1] for a in axes}) != 3:
            raise HriplanError(
                f"arm {arm_individual} has hand axes {str(hand_axes[0])!r} in the ontology; "
                "give three signed tool axes, one per hand axis x, y, z (e.g. '-y +x +z')"
            )
        tool = axes[AXIS_INDEX[axis[1]]]
        axis = tool if axis[0] == "+" else ("-" if tool[0] == "+" else "+") + tool[1]
    return Grasp(name, axis, facts.number(name, "hasGraspOffset"))
