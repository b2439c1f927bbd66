"""Reading a ROS JointTrajectory message and placing it on a robot (formats/ros_trajectory.py)."""

import numpy as np
import pytest

from hriplan import HriplanError
from hriplan.formats.ros_trajectory import is_joint_trajectory_message, load_joint_trajectory, place
from hriplan.planner.replay import MotionSetting, PlannedWorld
from hriplan.robots.model import load_robot
from hriplan.robots.scene import Scene

# What `ros2 topic echo /arm_controller/joint_trajectory --once` prints (two joints of the right arm).
ECHOED = """header:
  stamp:
    sec: 1764754000
    nanosec: 250000000
  frame_id: base_link
joint_names:
- right_elbow_joint
- right_shoulder_pan_joint
points:
- positions:
  - -1.5
  - 1.0
  velocities:
  - 0.0
  - 0.0
  accelerations: []
  effort: []
  time_from_start:
    sec: 1
    nanosec: 0
- positions:
  - -1.4
  - 1.2
  velocities:
  - 0.0
  - 0.0
  accelerations: []
  effort: []
  time_from_start:
    sec: 2
    nanosec: 500000000
---
"""


@pytest.fixture(scope="module")
def setting() -> MotionSetting:
    robot = load_robot("madar")
    start = {j: 0.1 * k - 0.5 for k, j in enumerate(robot.joint_names)}  # a distinct value per joint
    return MotionSetting(robot="madar", hands={}, start=start, scene=Scene(), constraints=[], policy=None)


def test_the_echoed_message_is_read_with_its_times(tmp_path):
    path = tmp_path / "echo.yaml"
    path.write_text(ECHOED)
    assert is_joint_trajectory_message(path)
    message = load_joint_trajectory(path)
    assert message.header.frame_id == "base_link" and message.header.stamp.seconds == pytest.approx(1764754000.25)
    assert [p.time_from_start.seconds for p in message.points] == [1.0, 2.5]


def test_placed_on_its_arm_the_omitted_joints_stay_at_the_start(tmp_path, setting):
    path = tmp_path / "echo.yaml"
    path.write_text(ECHOED)
    placed = place(load_joint_trajectory(path), setting)
    arm = [j for j in setting.start if j.startswith("right_")]  # the right arm's group, in its order
    assert placed.joint_names == arm
    expected = {j: setting.start[j] for j in arm} | {"right_elbow_joint": -1.4, "right_shoulder_pan_joint": 1.2}
    assert placed.points[-1].positions == [expected[j] for j in arm]
    assert [p.time_from_start for p in placed.points] == [0.0, 1.5]  # counted from the first point
    assert placed.start == setting.start | {"right_elbow_joint": -1.5, "right_shoulder_pan_joint": 1.0}
    omitted = [j for j in setting.start if j not in ("right_elbow_joint", "right_shoulder_pan_joint")]
    assert placed.notes[0] == f"joints the message omits stay at the start: {', '.join(omitted)}"
    away = -1.5 - setting.start["right_elbow_joint"]  # farther than the shoulder's 1.0 - its start
    assert f"starts {away:+.4f} rad from the start at right_elbow_joint" in placed.notes[1]
    assert "counted from the first point's time_from_start, 1 s" in placed.notes[2]
    world = PlannedWorld.load(placed)  # every joint of the robot where the setting and the message put it
    row = world.joint_values(world.positions[-1])
    assert row == pytest.approx(setting.start | {"right_elbow_joint": -1.4, "right_shoulder_pan_joint": 1.2})
    # 0.2 rad in 1.5 s of the shoulder, at rest at both ends: the spline peaks at 1.5 x the mean
    assert world.spline.peak_speeds().max() == pytest.approx(1.5 * 0.2 / 1.5)
    assert np.isclose(world.spline.mean_speeds().max(), 0.2 / 1.5)


def test_a_joint_whose_start_is_unknown_must_be_given(tmp_path, setting):
    path = tmp_path / "echo.yaml"
    path.write_text(ECHOED)
    unknown = MotionSetting(**{**setting.__dict__, "unknown_start": frozenset({"right_wrist_1_joint"})})
    with pytest.raises(HriplanError, match="omits right_wrist_1_joint, which an earlier step moves"):
        place(load_joint_trajectory(path), unknown)


def test_a_hriplan_trajectory_or_a_task_is_not_a_message(tmp_path):
    (tmp_path / "t.json").write_text('{"schema": "hriplan.trajectory", "joint_names": [], "points": []}')
    (tmp_path / "task.yaml").write_text("name: x\nsteps: []\n")
    assert not is_joint_trajectory_message(tmp_path / "t.json")
    assert not is_joint_trajectory_message(tmp_path / "task.yaml")
    assert not is_joint_trajectory_message(tmp_path / "missing.yaml")
