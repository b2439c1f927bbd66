"""The preparatory goal of a start outside both an approach cone and an upright constraint with a
free axis (TALOS's handover from a ready posture turned 0.3 rad at the wrist): the cone fixes the
position, the upright the free axis's direction, and the turn about that axis stays free. Fixed
to the constraint's own turn (arbitrary: for TALOS, the gripper pointing back at its chest) the
goal had no IK solution although the point was within reach."""

import numpy as np
import pinocchio as pin

from hriplan.planner.constraints.spec import ConeConstraint, FrameRef, OrientationConstraint
from hriplan.planner.prepare import preparatory_goal
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.ik import solve_ik
from hriplan.robots.model import load_robot
from hriplan.robots.scene import Scene
from hriplan.robots.spatial import Pose


def test_a_cone_keeps_the_free_axis_of_the_orientation_turned_onto():
    robot = load_robot("ur5")
    arm = next(iter(robot.arms))
    group, tool = robot.arm_group(arm), robot.tool_frame(arm)
    joints = robot.group_joints(group)
    values = np.array([0.3, -1.2, 1.4, -1.8, -1.5, 0.4])
    start = dict(zip(joints, values.tolist()))
    here = robot.frame_pose(tool, values, group)
    tilted = pin.exp3(np.array([0.3, 0.0, 0.0])) @ here[:3, :3]  # the tool's x 0.3 rad off where it is
    upright = OrientationConstraint(
        id="upright", joints=joints, target_link=tool, target=Pose.from_matrix(_rotation(tilted)), free_axes=["x"]
    )
    apex = here[:3, 3] + np.array([0.1, 0.0, -0.1])  # a cone opening up beside the tool: it is outside
    cone = ConeConstraint(
        id="cone", joints=joints, target_link=tool, radius=0.05, height=0.2, frame=FrameRef(offset=Pose(xyz=apex))
    )
    prepared = preparatory_goal(robot, CollisionChecker(robot, Scene()), [(arm, upright), (arm, cone)], start)
    assert prepared is not None and prepared.violated == ["upright", "cone"]
    assert prepared.goal.free_axes == ["x"]  # was [] whenever a cone was violated too
    goal = prepared.goal.pose.matrix()
    assert np.allclose(goal[:3, 3], apex + [0.0, 0.0, 0.8 * 0.2]) and np.allclose(goal[:3, 0], tilted[:, 0])
    result = solve_ik(robot, arm, goal, free_axes=prepared.goal.free_axes, reference=values)
    assert result.success and result.orientation_error < 1e-6


def _rotation(rotation: np.ndarray) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, :3] = rotation
    return pose
