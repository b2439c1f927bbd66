"""The preparatory motion of a step: bring the tool where the step's approach constraints hold,
so the approach starts within them.

A constraint whose purpose is the approach must hold during the whole approach: a blade pointing
away from the receiver, an approach from inside the cone at the person's hand. A start outside
it gets an explicit preparatory motion first, under every other constraint of the step (the
people's keep-outs, an upright cup): a tool that starts held another way (scissors upright) is
turned in place; a tool outside the approach cone (a glass just picked off a table, far to the
side of the receiver's line of sight) is brought onto the cone's axis, ENTRY of its height from
the hand, as held. The approach then starts inside. This is the explicit preparatory phase the
seed framework leaves to the user (the handover_scissors example's turn_blades step).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from hriplan.planner.constraints.binding import bind
from hriplan.planner.constraints.evaluator import ConstraintEvaluator
from hriplan.planner.constraints.spec import ConeConstraint, ConstraintSpec, OrientationConstraint, _Volume
from hriplan.planner.motion import ToolTarget
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.model import Robot
from hriplan.robots.spatial import Pose

VIOLATION = 1e-4  # as the planner's validation tolerance
ENTRY = 0.8  # where on its axis a cone is entered, as a fraction of its height from the apex


class Preparation(NamedTuple):
    goal: ToolTarget
    violated: list[str]  # the ids of the constraints the preparatory motion brings the tool within
    what: str  # "turns the held object in place onto sharp_end_away_scissors", for messages


def preparatory_goal(
    robot: Robot, checker: CollisionChecker, constraints: list[tuple[str, ConstraintSpec]], start: dict[str, float]
) -> Preparation | None:
    """The tool goal that brings one arm's tool within every orientation and cone constraint (of
    the (arm, constraint) pairs) the start violates (the first violated one's arm); None when the
    start meets them all."""
    q = robot.configuration(start)
    violated = []
    for arm, spec in constraints:
        if isinstance(spec, (OrientationConstraint, ConeConstraint)) and (not violated or arm == violated[0][0]):
            (bound,) = bind([spec], robot, checker)
            if ConstraintEvaluator(robot, [bound], robot.arm_group(arm), q).margins(q).max() > VIOLATION:
                violated.append((arm, spec, bound))
    if not violated:
        return None
    arm = violated[0][0]
    target, free_axes, what = robot.frame_pose(robot.tool_frame(arm), q), [], []
    for _, spec, bound in violated:
        if isinstance(spec, OrientationConstraint):
            target[:3, :3] = bound.frame.rotation @ spec.target.rotation()
            # free with a cone too (a cone bounds the position only): the target's own turn about
            # a free axis is arbitrary, and may be out of reach or collide
            free_axes = spec.free_axes
            what.append(f"turns the held object onto {spec.id}")
        else:
            target[:3, 3] = bound.frame.act(np.array([0.0, 0.0, ENTRY * spec.height]))
            what.append(f"brings the tool into {spec.id}")
    # A volume the tool must be inside for the step (the shared workspace) but starts outside of
    # is entered on the way, not kept from the start (no path could keep it); the step's own
    # motion then starts inside it, or says that its start is not.
    for other, spec in constraints:
        if (
            other == arm
            and isinstance(spec, _Volume)
            and spec.region == "inside"
            and not isinstance(spec, ConeConstraint)
        ):
            (bound,) = bind([spec], robot, checker)
            if ConstraintEvaluator(robot, [bound], robot.arm_group(arm), q).margins(q).max() > VIOLATION:
                violated.append((arm, spec, bound))
                what.append(f"enters {spec.id}")
    return Preparation(
        ToolTarget(arm=arm, pose=Pose.from_matrix(target), free_axes=free_axes),
        [spec.id for _, spec, _ in violated],
        " and ".join(what),
    )
