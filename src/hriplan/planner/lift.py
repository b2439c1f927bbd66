"""Lifting a grasped object off what it stands on: the retreat after a pick.

An object standing on a table touches it, so once grasped it cannot leave in a collision-free
motion: every start would be "in collision (cup - table)". As a place ends with the object
released a clearance above its place, a pick ends with the object lifted that far straight up
(the task runner says how far): the tool rises in a straight joint-space line from the grasp to its
IK solution that much higher, nearest the grasp. While lifting, the object is not checked against what it stands on
(`AttachedObject.resting_on`); instead the lift must rise at every dense state (the object can
only move away from its support) and end clear of it. Everything else is checked as in any
motion, and the lift is timed and validated like one (tasks/pipeline.py).
"""

from __future__ import annotations

import numpy as np

from hriplan.planner.validate import densify
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.ik import solve_ik
from hriplan.robots.model import Robot

# A lift may drift sideways this much (m) and must rise by at least this much between dense states.
SIDEWAYS = 0.005
RISE = -1e-6
STEP = 0.01  # rad, as the planner's validation


def supports(checker: CollisionChecker, q: np.ndarray, obj: str) -> list[str]:
    """The obstacles the held object `obj` touches at `q` (what it stands on)."""
    return sorted({c.b if c.a == obj else c.a for c in checker.contacts(q) if obj in (c.a, c.b)})


def lift_path(
    robot: Robot, checker: CollisionChecker, arm: str, q_grasp: np.ndarray, height: float
) -> tuple[np.ndarray | None, str]:
    """The arm's values `height` above the grasp, reached by a straight joint line that rises all
    the way (checked on `checker`, whose scene lets the object touch its supports), or None and why."""
    group = robot.arm_group(arm)
    tool = robot.frame_pose(robot.tool_frame(arm), q_grasp)
    target = tool.copy()
    target[2, 3] += height
    x_grasp = robot.group_values(q_grasp, group)
    ik = solve_ik(robot, arm, target, base_q=q_grasp, reference=x_grasp, is_valid=lambda q: not checker.in_collision(q))
    if not ik.success:
        return None, f"no valid IK solution {height} m above the grasp: {ik.message}"
    x_lift = np.asarray(ik.q, dtype=float)
    heights, drift = [], 0.0
    for x in densify([x_grasp, x_lift], STEP):
        at = robot.frame_pose(robot.tool_frame(arm), robot.configuration(x, group, base=q_grasp))[:3, 3]
        heights.append(at[2])
        drift = max(drift, float(np.linalg.norm(at[:2] - tool[:2, 3])))
    if np.diff(heights).min(initial=0.0) < RISE or drift > SIDEWAYS:
        return None, f"the straight lift does not rise straight up (drifts {drift:.3f} m sideways)"
    return x_lift, ""
