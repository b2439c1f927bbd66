"""Robot files: robots the code was not written for (example-robot-data's Panda from its URDF and
SRDF, its UR10 from the URDF alone) load, their tool frames agree with pinocchio built here
straight from the URDF, IK solutions reach their targets by that forward kinematics, a Panda
plan keeps its joint limits, and every bad robot file is one line."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import example_robot_data
import numpy as np
import pinocchio as pin
import pytest

from data_robots import data_robot
from hriplan import HriplanError
from hriplan.planner.motion import JointTarget
from hriplan.planner.session import PlanningSession
from hriplan.robots.descriptions.registry import load_robot_file
from hriplan.robots.ik import ik_solutions, solve_ik
from hriplan.robots.model import load_robot
from independent import UrdfFile

DATA = Path(__file__).parents[1] / "data" / "robots"
ROBOTS = Path(example_robot_data.getModelPath("panda_description/urdf/panda.urdf")).resolve()
SHARE = ROBOTS.parent.parent  # the folder that holds example-robot-data/
PANDA_URDF = ROBOTS / "panda_description" / "urdf" / "panda.urdf"
UR10_URDF = ROBOTS / "ur_description" / "urdf" / "ur10_robot.urdf"


pytestmark = pytest.mark.usefixtures("module_robot_registry")


@pytest.fixture(scope="module")
def panda():
    return data_robot("panda")


@pytest.fixture(scope="module")
def ur10():
    return data_robot("ur10")


def random_values(robot, rng, n):
    lower, upper = robot.limits("arm")
    return rng.uniform(lower, upper, (n, len(lower)))


def test_the_panda_is_its_srdf_arm_group_end_effector_and_states(panda):
    assert panda.model.nq == 7 and panda.group_joints("arm") == [f"panda_joint{k}" for k in range(1, 8)]
    assert panda.tool_frame("arm") == "panda_hand_tcp"  # the SRDF end effector's parent link
    assert panda.description.postures["default"]["panda_joint4"] == pytest.approx(-2.35619)
    assert panda.hand_postures == {"arm": "open"}
    assert dict(panda.finger_values) == {"panda_finger_joint1": 0.04, "panda_finger_joint2": 0.04}
    assert "package://" not in panda.urdf
    # Its fingers slide along panda_hand_tcp's y (the URDF's finger joint axis): hriplan's hand
    # frame, in which grasps are written, has its y (a side-grasped cylinder's axis) along the tool's x.
    assert panda.description.arms["arm"].hand_axes == ("-y", "+x", "+z")


@pytest.mark.parametrize("name, urdf, tool", [("panda", PANDA_URDF, "panda_hand_tcp"), ("ur10", UR10_URDF, "tool0")])
def test_tool_frame_equals_forward_kinematics_of_the_urdf(request, name, urdf, tool):
    robot = request.getfixturevalue(name)
    independent = UrdfFile(urdf)
    for values in random_values(robot, np.random.default_rng(0), 30):
        named = dict(zip(robot.group_joints("arm"), values))
        ours = robot.frame_pose(robot.tool_frame("arm"), values, "arm")
        assert np.abs(ours - independent.pose(tool, named)).max() < 1e-9


@pytest.mark.parametrize("name, urdf, kind", [("panda", PANDA_URDF, "numeric"), ("ur10", UR10_URDF, "ur10_analytic")])
def test_ik_solutions_reach_their_targets_by_independent_forward_kinematics(request, name, urdf, kind):
    robot = request.getfixturevalue(name)
    assert robot.description.arms["arm"].ik == kind
    independent = UrdfFile(urdf)
    tool = robot.tool_frame("arm")
    failures = 0
    for values in random_values(robot, np.random.default_rng(1), 100):
        target = independent.pose(tool, dict(zip(robot.group_joints("arm"), values)))
        result = solve_ik(robot, "arm", target)
        if not result.success:
            failures += 1
            continue
        solved = dict(zip(robot.group_joints("arm"), result.q))
        assert np.abs(independent.pose(tool, solved) - target).max() < 1e-5
        for joint, value in solved.items():
            lower, upper, _ = independent.limits[joint]
            assert lower <= value <= upper
    assert failures <= 1


def test_numeric_ik_with_a_free_axis_keeps_only_that_axis_direction(panda):
    independent = UrdfFile(PANDA_URDF)
    values = np.array([0.3, 0.4, -0.2, -1.8, 0.1, 2.0, 0.5])
    target = independent.pose("panda_hand_tcp", dict(zip(panda.group_joints("arm"), values)))
    spun = target @ np.block([[pin.exp3(np.array([0.0, 0.0, 1.3])), np.zeros((3, 1))], [np.zeros((1, 3)), 1.0]])
    result = solve_ik(panda, "arm", spun, free_axes=["z"])
    assert result.success, result.message
    reached = independent.pose("panda_hand_tcp", dict(zip(panda.group_joints("arm"), result.q)))
    assert np.linalg.norm(reached[:3, 3] - target[:3, 3]) < 1e-5
    assert reached[:3, 2] @ target[:3, 2] > math.cos(1e-5)


def test_numeric_ik_is_collision_aware_and_lists_distinct_solutions(panda):
    values = np.array([0.3, 0.4, -0.2, -1.8, 0.1, 2.0, 0.5])
    target = panda.frame_pose("panda_hand_tcp", values, "arm")
    solutions = ik_solutions(panda, "arm", target)
    assert len(solutions) >= 2
    assert all(np.abs(a - b).max() > 1e-3 for k, a in enumerate(solutions) for b in solutions[:k])
    first = solve_ik(panda, "arm", target)
    rejected = solve_ik(panda, "arm", target, is_valid=lambda q: False, why_invalid=lambda q: ["collides: a - b"])
    assert first.success and not rejected.success
    assert rejected.message.startswith("all ") and "collides: a - b" in rejected.message
    # Not the first solution: one far from it, as a collision check might ask for.
    far = solve_ik(panda, "arm", target, is_valid=lambda q: np.abs(q - np.array(first.q)).max() > 0.1)
    assert far.success and np.abs(np.array(far.q) - first.q).max() > 0.1


def test_numeric_ik_out_of_reach_says_so(panda):
    target = np.eye(4)
    target[:3, 3] = (2.0, 0.0, 0.5)
    result = solve_ik(panda, "arm", target)
    assert not result.success and result.message.startswith(
        "no numeric solution: the position is out of reach: 2.007 m from the shoulder of arm 'arm'"
    )


def test_the_ur10_analytic_solver_is_placed_by_measurement(ur10):
    # example-robot-data's UR10 base is turned by pi from the solver's DH base; the arm fits.
    values = np.array([0.4, -1.1, 1.3, -0.8, 1.2, 0.3])
    target = ur10.frame_pose("tool0", values, "arm")
    assert any(np.abs(s - values).max() < 1e-6 for s in ik_solutions(ur10, "arm", target))


def test_an_analytic_kind_that_does_not_fit_is_one_line(tmp_path):
    path = tmp_path / "ur10_as_ur5.yaml"
    path.write_text(
        (DATA / "ur10.yaml").read_text().replace("name: ur10", "name: ur10b").replace("ur10_analytic", "ur5_analytic")
    )
    robot = load_robot(load_robot_file(path).name)
    with pytest.raises(HriplanError, match=r"^the arm arm does not match the ur5_analytic solver .* use another"):
        solve_ik(robot, "arm", robot.frame_pose("tool0", robot.q_neutral))


def test_a_panda_joint_goal_plan_keeps_its_urdf_limits_and_continuity(panda):
    independent = UrdfFile(PANDA_URDF)
    start = panda.description.postures["default"]
    goal = JointTarget(values={"panda_joint1": 1.0, "panda_joint2": 0.2, "panda_joint4": -1.5, "panda_joint6": 2.0})
    session = PlanningSession(str(DATA / "panda.yaml"))  # a session takes the robot file itself
    assert session.robot is panda
    result = session.plan(start, goal, group="arm")
    assert result.solved, result.message
    trajectory = result.trajectory
    assert trajectory.robot == "panda" and trajectory.joint_names == panda.group_joints("arm")
    positions = np.array([p.positions for p in trajectory.points])
    times = np.array([p.time_from_start for p in trajectory.points])
    limits = np.array([independent.limits[j] for j in trajectory.joint_names])
    assert np.all(positions >= limits[:, 0] - 1e-9) and np.all(positions <= limits[:, 1] + 1e-9)
    steps = np.abs(np.diff(positions, axis=0)) / np.diff(times)[:, None]
    assert np.all(steps <= limits[:, 2] * 1.01)  # continuity: no jump faster than the URDF velocity
    assert positions[0] == pytest.approx([start[j] for j in trajectory.joint_names])
    assert positions[-1][[0, 1, 3, 5]] == pytest.approx([1.0, 0.2, -1.5, 2.0], abs=1e-6)


def test_velocity_and_acceleration_overrides_and_the_base_pose(tmp_path):
    path = tmp_path / "panda_fast.yaml"
    text = (DATA / "panda.yaml").read_text().replace("name: panda", "name: panda_b")
    text += "limits: {panda_joint1: {velocity: 1.5, acceleration: 0.5}}\nbase_pose: {xyz: [0.5, 0.0, 0.8]}\n"
    path.write_text(text)
    description = load_robot_file(path)
    robot = load_robot(description.name)
    assert robot.velocity_limit("arm")[0] == 1.5 and description.acceleration_limits == {"panda_joint1": 0.5}
    start = robot.description.postures["default"]
    result = PlanningSession(robot).plan(start, JointTarget(values={"panda_joint1": 1.0}), group="arm")
    assert result.solved, result.message
    first = np.array([p.accelerations[0] for p in result.trajectory.points])
    times = np.array([p.time_from_start for p in result.trajectory.points])
    # Timed by the file's 0.5 rad/s^2 (the planner's default is pi): at least 2 sqrt(1 / 0.5) s.
    assert np.abs(first).max() <= 0.5 * 1.05 and times[-1] >= 2.0 * math.sqrt(2.0) * 0.99
    independent = UrdfFile(PANDA_URDF)
    values = np.array([0.3, 0.4, -0.2, -1.8, 0.1, 2.0, 0.5])
    expected = independent.pose("panda_hand_tcp", dict(zip(robot.group_joints("arm"), values)))
    expected[:3, 3] += (0.5, 0.0, 0.8)
    assert np.abs(robot.frame_pose("panda_hand_tcp", values, "arm") - expected).max() < 1e-9


def test_loading_a_file_again_is_the_same_robot_and_a_taken_name_is_one_line(tmp_path):
    assert load_robot_file(DATA / "panda.yaml") is load_robot_file(DATA / "panda.yaml")
    path = tmp_path / "madar.yaml"
    path.write_text((DATA / "ur10.yaml").read_text().replace("name: ur10", "name: madar"))
    with pytest.raises(HriplanError, match=r"robot name 'madar' is taken \(by a built-in robot\)$"):
        load_robot_file(path)


FORK = DATA / "fork"  # a URDF with two branches from its base, an SRDF with groups on them


@pytest.fixture
def fork(tmp_path):
    shutil.copytree(FORK, tmp_path, dirs_exist_ok=True)
    return tmp_path


@pytest.mark.parametrize(
    "arm, message",
    [
        ("{group: still}", "arms.arm: group 'still' has no joints that move"),
        ("{base: base, tip: nowhere}", "arms.arm: unknown link 'nowhere'"),
        ("{base: c, tip: a}", "arms.arm: link 'c' is not above link 'a'"),
        ("{group: both}", "arms.arm: not a serial chain: joint 'jb' does not follow joint 'ja'"),
        ("{group: a_only}", "arms.arm: no tool frame (the SRDF has no end effector on group 'a_only'); name a link"),
        ("{group: a_only, tool: b}", "arms.arm.tool: link 'b' does not move rigidly with the arm's last joint 'ja'"),
        ("{group: nothing}", "arms.arm.group: the SRDF has no group 'nothing' (groups: both, still, a_only)"),
        ("{group: a_only, base: base}", "arms.arm: give an arm either an SRDF group or base and tip links, not both"),
        ("{base: base}", "arms.arm: give an arm either an SRDF group or both base and tip links"),
        (
            "{group: a_only, tool: c, ik: kdl}",
            "arms.arm.ik: unknown IK kind 'kdl'; choose one of numeric, ur3_analytic",
        ),
        (
            "{group: a_only, tool: c, hand: {gripper: [jb], open: 1, closed: 0}}",
            "arms.arm.hand: finger joint 'jb' (revolute, axis [0.0, 0.0, 1.0] in the tool frame 'c') does not close "
            "along the tool's x or y axis; say which: closes_along: x or y",
        ),
        ("{group: a_only, tool: c, hand: {gripper: [jb], open: 1, closed: 0, closes_along: y}}", None),
    ],
)
def test_every_bad_robot_file_is_one_line(fork, arm, message):
    path = fork / "fork.yaml"
    path.write_text(f"name: fork{abs(hash(arm))}\nurdf: fork.urdf\nsrdf: fork.srdf\narms:\n  arm: {arm}\n")
    if message is None:  # the one good file among them: the other branch is its gripper
        description = load_robot_file(path)
        assert description.arms["arm"].joints == ("ja",) and description.arms["arm"].tool_frame == "c"
        return
    with pytest.raises(HriplanError) as error:
        load_robot_file(path)
    assert str(error.value).startswith(f"{path.resolve()}: ") or str(error.value).startswith(f"{path}: ")
    assert message in str(error.value) and "\n" not in str(error.value)


@pytest.mark.parametrize(
    "change, message",
    [
        (("meshes/d.stl", "meshes/gone.stl"), "missing mesh {tmp}/meshes/gone.stl (from meshes/gone.stl)"),
        (("meshes/d.stl", "package://nopkg/d.stl"), "mesh package://nopkg/d.stl: no package 'nopkg'"),
        (('<link name="c"/>', ""), "URDF joint 'jc' names an unknown link 'c'"),
        # urdfdom refuses these with "not a valid URDF model" alone (and pinocchio with a traceback)
        (('<link name="c"/>', '<link name="c"/><link name="c"/>'), "the URDF names two links 'c'"),
    ],
)
def test_a_bad_urdf_is_one_line(fork, change, message):
    (fork / "fork.urdf").write_text((FORK / "fork.urdf").read_text().replace(*change))
    path = fork / "fork.yaml"
    path.write_text("name: fork\nurdf: fork.urdf\narms:\n  arm: {base: base, tip: c}\n")
    with pytest.raises(HriplanError) as error:
        load_robot_file(path)
    assert message.format(tmp=fork.resolve()) in str(error.value) and "\n" not in str(error.value)


def test_an_offset_tool_frame_takes_a_joint_name_the_urdf_does_not_use(fork):
    """The offset tool frame `ARM_tool` hangs on a fixed joint hriplan names: `ARM_tool_joint`,
    unless the URDF has one (TIAGo's `arm_tool_joint`), when two joints of one name made
    pinocchio refuse the URDF with a traceback."""
    urdf = (FORK / "fork.urdf").read_text()
    (fork / "fork.urdf").write_text(urdf.replace('name="jc"', 'name="arm_tool_joint"'))
    path = fork / "fork.yaml"
    path.write_text(
        "name: fork_offset\nurdf: fork.urdf\narms:\n  arm: {base: base, tip: c, tool_offset: {xyz: [0, 0, 0.1]}}\n"
    )
    robot = load_robot(load_robot_file(path).name)
    assert robot.model.existFrame("arm_tool")
    tool, tip = (robot.model.frames[robot.model.getFrameId(f)] for f in ("arm_tool", "c"))
    assert np.allclose((tip.placement.inverse() * tool.placement).translation, (0.0, 0.0, 0.1))
    assert "arm_tool_joint1" in robot.description.urdf()


def test_a_package_folder_named_in_the_file_resolves_meshes(tmp_path):
    (tmp_path / "pkg" / "meshes").mkdir(parents=True)
    (tmp_path / "pkg" / "meshes" / "d.stl").write_text("solid d\nendsolid d\n")
    (tmp_path / "fork.urdf").write_text(
        (FORK / "fork.urdf").read_text().replace("meshes/d.stl", "package://mine/meshes/d.stl")
    )
    path = tmp_path / "fork.yaml"
    path.write_text("name: forkpkg\nurdf: fork.urdf\npackages: {mine: pkg}\narms:\n  arm: {base: base, tip: c}\n")
    urdf = load_robot_file(path).urdf()
    assert f'filename="{(tmp_path / "pkg" / "meshes" / "d.stl").resolve()}"' in urdf


def test_a_robot_file_robot_is_an_ontology_individual_with_its_stopping_data(panda):
    from hriplan.ontology.robot_individuals import robot_turtle

    turtle = robot_turtle()
    assert "hp:panda hp:hasReactionTime 0.1 ; hp:hasStoppingTime 0.2 ; hp:hasPositionUncertainty 0.02" in turtle
    assert (
        "hp:panda_arm a owl:NamedIndividual , hp:Arm" in turtle
        and "hp:panda_arm_hand a owl:NamedIndividual" not in turtle
    )
    assert "hp:panda_hand a owl:NamedIndividual , hp:RobotHand" in turtle  # the gripper
    for k in range(1, 8):
        assert (
            f'hp:panda_panda_joint{k} a owl:NamedIndividual , hp:Joint ; hp:hasUrdfName "panda_joint{k}" ; hp:hasChainIndex {k} .'
            in turtle
        )
