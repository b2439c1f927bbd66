"""The preparatory motion of a step: turn what the hand holds, where it is, so the approach
starts within the step's orientation constraints.

A constraint whose purpose is the approach (a blade pointing away from the receiver) must hold
during the whole approach; a tool that starts held another way (scissors upright) is first
turned in place, under every other constraint of the step (the people's keep-outs), and the
approach then starts inside it. This is the explicit preparatory phase the seed framework
leaves to the user (the handover_scissors example's turn_blades step, done for them).
"""

from __future__ import annotations

import numpy as np

from hriplan.planner.evaluator import ConstraintEvaluator
from hriplan.planner.motion import ToolGoal
from hriplan.planner.resolve import bind
from hriplan.planner.spec import OrientationConstraint
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.model import Robot
from hriplan.robots.spatial import Pose
from hriplan.rules.infer import DerivedConstraint

VIOLATION = 1e-4  # as the planner's validation tolerance


def preparatory_goal(robot: Robot, checker: CollisionChecker, constraints: list[DerivedConstraint],
                     start: dict[str, float]) -> tuple[ToolGoal, DerivedConstraint] | None:  # fmt: skip
    """The tool goal that turns the held object in place onto the first orientation constraint
    the start violates, and that constraint; None when the start meets them all."""
    q = robot.configuration(start)
    for c in constraints:
        if not isinstance(c.spec, OrientationConstraint):
            continue
        (bound,) = bind([c.spec], robot, checker)
        if ConstraintEvaluator(robot, [bound], robot.arm_group(c.arm), q).margins(q).max() <= VIOLATION:
            continue
        tool = robot.frame_pose(robot.tool_frame(c.arm), q)
        target = np.eye(4)
        target[:3, :3] = bound.frame.rotation @ c.spec.target.rotation()
        target[:3, 3] = tool[:3, 3]
        return ToolGoal(arm=c.arm, pose=Pose.from_matrix(target), free_axes=c.spec.free_axes), c
    return None
