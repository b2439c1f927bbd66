"""A robot with continuous joints, as a new user brings one: example-robot-data's Kinova Jaco (its
joints 1, 4 and 6 turn without end). `hriplan robot init` gives them two turns each and a ready
posture that does not fold the arm into itself; the planned model has the URDF's kinematics
(pinocchio built here from the URDF file itself, the continuous joints as cos/sin); an SRDF state
beyond a revolute joint's range by a whole turn is that turn's placement; a range only narrows;
`robot check` names a posture in self-collision; and a plan turns joint 1 past half a turn."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import example_robot_data
import numpy as np
import pinocchio as pin
import pytest

from hriplan import HriplanError
from hriplan.planner.motion import JointTarget
from hriplan.planner.options import PlanOptions
from hriplan.planner.session import PlanningSession
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.descriptions.registry import load_robot_file, posture
from hriplan.robots.model import load_robot
from hriplan.robots.robot_check import check_report, write_starting_file
from hriplan.robots.scene import Scene
from independent import UrdfMeshes

SHARE = Path(example_robot_data.getModelPath("kinova_description/robots/kinova.urdf")).resolve()
URDF = SHARE / "kinova_description" / "robots" / "kinova.urdf"
SRDF = SHARE / "kinova_description" / "srdf" / "kinova.srdf"
TURNING = ["j2s6s200_joint_1", "j2s6s200_joint_4", "j2s6s200_joint_6"]

pytestmark = pytest.mark.usefixtures("module_robot_registry")


@pytest.fixture(scope="module")
def kinova_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("kinova") / "kinova.yaml"
    write_starting_file(str(URDF), str(SRDF), path)
    return path


@pytest.fixture(scope="module")
def kinova(kinova_file):
    return load_robot(load_robot_file(kinova_file).name)


def test_init_gives_each_continuous_joint_two_turns_and_a_ready_posture_free_of_itself(kinova_file, kinova):
    text = kinova_file.read_text()
    for joint in TURNING:
        assert f"{joint}: {{lower: -6.2832, upper: 6.2832}}" in text
    lower, upper = kinova.limits(kinova.default_group)
    turning = [kinova.joint_names.index(j) for j in TURNING]
    assert np.allclose(lower[turning], -6.2832) and np.allclose(upper[turning], 6.2832)
    checker = CollisionChecker(kinova, Scene())
    assert checker.contacts(kinova.configuration(posture(kinova.name, "ready"))) == []
    # The ends of the ranges nearest zero (what init wrote before) fold the arm into itself.
    nearest_zero = dict(zip(kinova.joint_names, np.clip(0.0, lower, upper)))
    assert checker.contacts(kinova.configuration(nearest_zero)) != []


def test_the_planned_model_has_the_urdf_files_kinematics(kinova):
    """pinocchio from the URDF file itself: the continuous joints take (cos, sin)."""
    model = pin.buildModelFromUrdf(str(URDF))
    data = model.createData()
    tool = kinova.tool_frame("end_effector")
    rng = np.random.default_rng(7)
    lower, upper = kinova.limits(kinova.default_group)
    for _ in range(20):
        x = rng.uniform(lower, upper)
        q = pin.neutral(model)
        for name, value in zip(kinova.joint_names, x):
            joint = model.joints[model.getJointId(name)]
            q[joint.idx_q : joint.idx_q + joint.nq] = [math.cos(value), math.sin(value)] if joint.nq == 2 else [value]
        pin.framesForwardKinematics(model, data, q)
        expected = data.oMf[model.getFrameId(tool)].homogeneous
        assert np.allclose(kinova.frame_pose(tool, x, kinova.default_group), expected, atol=1e-9)


def test_an_srdf_state_beyond_the_range_by_a_whole_turn_is_moved_by_that_turn(kinova):
    state = next(s for s in ET.parse(SRDF).getroot().iter("group_state") if s.get("name") == "arm_up")
    written = {j.get("name"): float(j.get("value")) for j in state.iter("joint")}
    assert written["j2s6s200_joint_3"] < 0.0  # below the URDF's range [0.33, 5.95]
    values = posture(kinova.name, "arm_up")
    assert values["j2s6s200_joint_3"] == pytest.approx(written["j2s6s200_joint_3"] + 2 * math.pi, abs=1e-12)
    assert values["j2s6s200_joint_2"] == pytest.approx(written["j2s6s200_joint_2"], abs=1e-12)  # within: kept


@pytest.mark.parametrize(
    ("limits", "message"),
    [
        ("", "joint 'j2s6s200_joint_1' is continuous; give the range to plan it in"),
        ("j2s6s200_joint_1: {lower: -3.0}", "limits.j2s6s200_joint_1: a continuous joint needs both lower and upper"),
        ("j2s6s200_joint_2: {lower: 0.1, upper: 5.0}", "limits.j2s6s200_joint_2: [0.1, 5.0] is not within the URDF's"),
        ("j2s6s200_joint_2: {lower: 5.0, upper: 1.0}", "lower (5.0) must be below upper (1.0)"),
        ("j2s6s200_joint_2: {upper: 0.5}", "limits.j2s6s200_joint_2: the range [0.820304748437, 0.5] is empty"),
        ("j2s6s200_joint_end_effector: {lower: 0, upper: 1}", "is fixed and has no range to set"),
        ("elbow: {lower: 0, upper: 1}", "limits.elbow: the URDF has no joint 'elbow'"),
    ],
)
def test_a_bad_range_is_one_line(tmp_path, limits, message):
    text = (
        f"name: jaco\nurdf: {URDF}\nsrdf: {SRDF}\n"
        "arms: {arm: {group: end_effector, tool: j2s6s200_end_effector, ik: numeric}}\n"
        f"limits: {{{limits}}}\n"
    )
    if "joint_1:" not in limits:
        text = text.replace("limits: {", "limits: {j2s6s200_joint_1: {lower: -3, upper: 3}, ", 1)
    if not limits:
        text = text.replace("j2s6s200_joint_1: {lower: -3, upper: 3}, ", "")
    (tmp_path / "jaco.yaml").write_text(text)
    with pytest.raises(HriplanError) as error:
        load_robot_file(tmp_path / "jaco.yaml")
    assert message in str(error.value) and "\n" not in str(error.value)


def test_a_narrowed_range_is_planned_in(tmp_path, robot_registry):
    text = (
        f"name: jaco_narrow\nurdf: {URDF}\nsrdf: {SRDF}\n"
        "arms: {arm: {group: end_effector, tool: j2s6s200_end_effector, ik: numeric}}\n"
        "limits: {j2s6s200_joint_1: {lower: -1.0, upper: 2.0}, j2s6s200_joint_4: {lower: -6, upper: 6},"
        " j2s6s200_joint_6: {lower: -6, upper: 6}, j2s6s200_joint_2: {lower: 1.0, upper: 5.0}}\n"
    )
    (tmp_path / "narrow.yaml").write_text(text)
    robot = load_robot(load_robot_file(tmp_path / "narrow.yaml").name)
    lower, upper = robot.limits(robot.default_group)
    assert (lower[0], upper[0], lower[1], upper[1]) == (-1.0, 2.0, 1.0, 5.0)


def test_robot_check_names_a_posture_in_self_collision(tmp_path, kinova_file):
    folded = "\npostures: {folded: {j2s6s200_joint_2: 0.8204, j2s6s200_joint_3: 0.3317, j2s6s200_joint_5: 0.5236}}\n"
    text = kinova_file.read_text().replace("name: kinova", "name: kinova_folded")
    (tmp_path / "folded.yaml").write_text(text.split("postures:")[0] + folded + "limits:" + text.split("limits:")[1])
    lines = check_report(tmp_path / "folded.yaml").splitlines()
    [line] = [line for line in lines if line.startswith("posture ")]
    assert line.startswith("posture folded: in self-collision (j2s6s200_link_")
    assert "posture ready" not in "\n".join(lines)


def test_a_plan_turns_a_continuous_joint_past_half_a_turn(kinova):
    session = PlanningSession(kinova.name)
    start = posture(kinova.name, "ready") | {"j2s6s200_joint_1": -2.5}
    x0 = kinova.group_values(kinova.configuration(start))
    goal = x0.copy()
    goal[kinova.joint_names.index("j2s6s200_joint_1")] = 3.5  # -2.5 to 3.5: through pi, no wrap-around
    result = session.plan(start, JointTarget(values=goal.tolist()), PlanOptions(seed=1))
    assert result.solved, result.message
    positions = np.array([p.positions for p in result.trajectory.points])
    column = result.trajectory.joint_names.index("j2s6s200_joint_1")
    assert positions[0, column] == pytest.approx(-2.5) and positions[-1, column] == pytest.approx(3.5)
    assert np.all(np.abs(np.diff(positions[:, column])) < 0.2)  # continuous: no jump of a turn


def test_init_of_a_bravo_7_guesses_velocities_and_takes_its_arm_off_the_fingers(tmp_path, robot_registry):
    """Reach Robotics' Bravo 7: joints 1, 4 and 6 are continuous with no <limit> at all, and its
    SRDF `arm` group holds the gripper's fingers too (not a serial chain): the arm is the chain
    from the group's first link to the end effector's link, the fingers its gripper. At zero its
    links touch on the URDF meshes (tests/independent.py), so `ready` is its SRDF's state."""
    share = SHARE / "bravo7_description"
    path = tmp_path / "bravo.yaml"
    said = write_starting_file(str(share / "urdf/bravo7_gripper.urdf"), str(share / "srdf/bravo7_gripper.srdf"), path)
    text = path.read_text()
    assert "# The URDF gives joint1, joint4, joint6 no velocity limit: 1.0 rad/s is a guess to check." in text
    for joint in ("joint1", "joint4", "joint6"):
        assert f"{joint}: {{lower: -6.2832, upper: 6.2832, velocity: 1.0}}" in text
    robot = load_robot(load_robot_file(path).name)
    assert robot.joint_names == [f"joint{k}" for k in range(1, 7)]
    assert robot.description.arms["arm"].tool_frame == "link7"
    assert robot.hand_postures  # the fingers are a gripper, not arm joints
    assert len(said.splitlines()) == 1  # nothing in self-collision
    assert posture(robot.name, "ready") == posture(robot.name, "standing")
    meshes = UrdfMeshes(robot)
    meshes.watch(["link1|link5"])
    assert meshes.touching(robot.configuration({j: 0.0 for j in robot.joint_names})) == {"link1|link5"}
    assert meshes.touching(robot.configuration(posture(robot.name, "ready"))) == set()


def test_a_moving_joint_named_like_a_link_is_one_line(tmp_path, robot_registry):
    """so_arm100's URDF names its jaw's joint and a link `gripper`: pinocchio cannot reduce the
    model, and renaming either would rename what the robot file and trajectories say."""
    share = SHARE / "so_arm_description"
    with pytest.raises(HriplanError, match=r"names a moving joint and a link alike \(gripper\)"):
        write_starting_file(str(share / "urdf/so100.urdf"), None, tmp_path / "so.yaml")


def test_a_fixed_joint_named_like_a_link_is_renamed_and_the_robot_loads(tmp_path, robot_registry):
    """Unitree Z1's URDF names a fixed joint and a link `gripperStator` (its SRDF's chain starts
    at a link `base` the URDF does not have, so the user gives the URDF alone). Nothing refers to
    a fixed joint, so hriplan renames it and the robot loads. (init's arm ends at the one jaw's
    link: a single gripper joint at a chain's end looks like an arm joint; the file is a start.)"""
    share = SHARE / "z1_description"
    path = tmp_path / "z1.yaml"
    write_starting_file(str(share / "urdf/z1.urdf"), None, path)
    robot = load_robot(load_robot_file(path).name)
    assert robot.joint_names == [f"joint{k}" for k in range(1, 7)] + ["jointGripper"]
    model = robot.model
    assert model.existFrame("gripperStator", pin.FrameType.BODY)
    assert model.existFrame("gripperStator_joint", pin.FrameType.FIXED_JOINT)
    assert not model.existFrame("gripperStator", pin.FrameType.FIXED_JOINT)
    # The stator stays where the URDF puts it: 0.051 m out along joint6's x (z1.urdf).
    zero = {j: 0.0 for j in robot.joint_names}
    stator, flange = robot.frame_pose("gripperStator", zero), robot.frame_pose("link06", zero)
    expected = np.eye(4)
    expected[0, 3] = 0.051
    np.testing.assert_allclose(np.linalg.inv(flange) @ stator, expected, atol=1e-12)
