"""The plug-in API: a tool goal's arm is the group, what an integrator needs is exported, and
run_task says what it does to the session it is given."""

import numpy as np

from hriplan import api
from hriplan.api import (
    BoxConstraint,
    HumanSpec,
    PlanningSession,
    PlanOptions,
    Pose,
    Scene,
    TaskFile,
    ToolTarget,
    posture,
    run_task,
)


def test_a_tool_goal_without_group_moves_its_arm_only():
    session = PlanningSession("madar", hands={"right": "power"})
    start = posture("madar", "ready")
    tool = session.robot.frame_pose("right_tool", start)
    goal = ToolTarget(arm="right", pose=Pose(xyz=tuple(tool[:3, 3] + (0.0, 0.05, 0.0)), quat_xyzw=_quat(tool[:3, :3])))
    result = session.plan(start, goal, PlanOptions(seed=1, time_limit=20))
    assert result.solved, result.message
    trajectory = result.trajectory
    assert trajectory.joint_names == session.robot.group_joints("right_arm")
    end = session.robot.configuration(
        trajectory.start | dict(zip(trajectory.joint_names, trajectory.points[-1].positions))
    )
    assert np.allclose(session.robot.frame_pose("right_tool", end)[:3, 3], goal.pose.xyz, atol=2e-3)


def _quat(rotation: np.ndarray) -> tuple[float, float, float, float]:
    import pinocchio as pin

    q = pin.Quaternion(rotation)
    return (q.x, q.y, q.z, q.w)


TASK = {
    "name": "api",
    "robot": "ur5",
    "humans": [{"name": "bob", "role": "Bystander", "position": [1.5, 0.0], "yaw": 3.14}],
    "steps": [{"name": "move", "goal": {"joints": {"elbow_joint": 1.0}}}],
    "planning": {"time_limit": 5, "seed": 1},
}


def test_run_task_puts_the_sessions_scene_and_constraints_back_unless_asked():
    zoe = HumanSpec(name="zoe", position=(0.0, -1.5), yaw=1.57)
    session = PlanningSession("ur5", Scene(humans=[zoe]))
    joints = session.robot.group_joints("arm")
    mine = BoxConstraint(id="mine", joints=joints, target_link="tool", size=(2.0, 2.0, 2.0))
    session.set_constraints([mine])
    outcome = run_task(TaskFile.model_validate(TASK), session)
    assert outcome.solved, [(s.name, s.message) for s in outcome.steps]
    assert outcome.steps[0].trajectory.scene.humans[0].name == "bob"  # planned in the task's world
    assert [h.name for h in session.checker.scene.humans] == ["zoe"] and list(session.constraints) == ["mine"]
    run_task(TaskFile.model_validate(TASK), session, keep_task_world=True)
    assert [h.name for h in session.checker.scene.humans] == ["bob"] and "mine" not in session.constraints


def test_api_exports_postures_and_person_frames():
    assert "ready" in api.POSTURES["madar"] and api.posture("ur5", "home")
    assert {"right_hand", "torso", "head"} <= set(api.PERSON_FRAMES)
    assert all(hasattr(api, name) for name in api.__all__)
