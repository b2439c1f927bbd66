"""MADAR and UR5 kinematics against an independent computation from the reference numbers."""

from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest

from hriplan import HriplanError
from hriplan.robots.descriptions.registry import description_of
from hriplan.robots.model import load_robot
from hriplan.robots.spatial import Pose

# Reference (the Kautham project's MADAR description), written out here on purpose.
MOUNTS = {"right": ((0.256, 0, 1.389), (3.142, -0.7874, 0)), "left": ((-0.256, 0, 1.389), (-3.142, 0.7874, 0))}
ORIGINS = [
    ((0, 0, 0.089159), (0, 0, 0)),
    ((0, 0, 0), (np.pi / 2, 0, 0)),
    ((-0.425, 0, 0), (0, 0, 0)),
    ((-0.39225, 0, 0.10915), (0, 0, 0)),
    ((0, -0.09465, 0), (np.pi / 2, 0, 0)),
    ((0, 0.0823, 0), (np.pi / 2, np.pi, np.pi)),
]
LINKS = [f"{n}_link" for n in ("base", "shoulder", "upper_arm", "fore_arm", "wrist_1", "wrist_2", "wrist_3")]


def rot(axis, a):
    c, s = np.cos(a), np.sin(a)
    return {
        "x": np.array([[1, 0, 0], [0, c, -s], [0, s, c]]),
        "y": np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
        "z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]),
    }[axis]


def transform(xyz, rpy, joint=0.0):
    t = np.eye(4)
    t[:3, :3] = rot("z", rpy[2]) @ rot("y", rpy[1]) @ rot("x", rpy[0]) @ rot("z", joint)
    t[:3, 3] = xyz
    return t


def reference_links(side, q):
    pose = transform(*MOUNTS[side])
    poses = {f"{side}_base_link": pose}
    for i, (xyz, rpy) in enumerate(ORIGINS):
        pose = pose @ transform(xyz, rpy, q[i])
        poses[f"{side}_{LINKS[i + 1]}"] = pose
    return poses


@pytest.mark.parametrize("side", ["right", "left"])
def test_link_frames_match_the_reference_parameterisation(madar, rng, side):
    lower, upper = madar.limits(f"{side}_arm")
    for _ in range(50):
        q = rng.uniform(lower, upper)
        for link, expected in reference_links(side, q).items():
            got = madar.frame_pose(link, q, f"{side}_arm")
            assert np.abs(got - expected).max() < 1e-6, link


def test_zero_configuration_wrist_positions_from_the_reference(madar):
    assert np.allclose(madar.frame_pose("right_wrist_3_link", {})[:3, 3], (-0.3247, 0.1914, 0.8139), atol=1e-4)
    assert np.allclose(madar.frame_pose("left_wrist_3_link", {})[:3, 3], (-0.8289, 0.1915, 1.9719), atol=1e-4)


def test_groups_limits_and_names(madar):
    assert len(madar.group_joints("right_arm")) == 6 and len(madar.group_joints("both_arms")) == 12
    assert madar.group_joints("right_arm")[0] == "right_shoulder_pan_joint"
    lower, upper = madar.limits("right_arm")
    assert np.allclose(upper, [2 * np.pi, 2 * np.pi, np.pi, 2 * np.pi, 2 * np.pi, 2 * np.pi])
    assert np.allclose(madar.velocity_limit("left_arm"), [3.15, 3.15, 3.15, 3.2, 3.2, 3.2])


def test_frame_jacobian_matches_finite_differences(madar, rng):
    q = rng.uniform(-2, 2, 6)
    jac = madar.frame_jacobian("right_tool", q, "right_arm")
    eps = 1e-7
    for k in range(6):
        dq = np.zeros(6)
        dq[k] = eps
        plus, minus = (
            madar.frame_pose("right_tool", q + dq, "right_arm"),
            madar.frame_pose("right_tool", q - dq, "right_arm"),
        )
        assert np.allclose((plus[:3, 3] - minus[:3, 3]) / (2 * eps), jac[:3, k], atol=1e-6)
        omega = pin.log3(plus[:3, :3] @ minus[:3, :3].T) / (2 * eps)
        assert np.allclose(omega, jac[3:, k], atol=1e-6)


def test_base_pose_moves_every_frame(rng):
    moved = load_robot("madar", base_pose=Pose(xyz=(1.0, 2.0, 0.0), rpy=(0, 0, np.pi / 2)))
    home = load_robot("madar")
    q = rng.uniform(-1, 1, 12)
    expected = Pose(xyz=(1.0, 2.0, 0.0), rpy=(0, 0, np.pi / 2)).matrix() @ home.frame_pose("left_tool", q)
    assert np.allclose(moved.frame_pose("left_tool", q), expected)


def test_urdf_loads_back_with_the_same_kinematics(madar, rng):
    model = pin.buildModelFromXML(description_of("madar").urdf())
    data = model.createData()
    q_arm = rng.uniform(-1, 1, 12)
    values = dict(zip(madar.group_joints(), q_arm))
    q_full = madar.full_configuration(values)
    pin.framesForwardKinematics(model, data, q_full)
    for frame in ("right_tool", "left_hand_palm_link", "right_hand_link_15.0_tip"):
        expected = madar.frame_pose(frame, madar.configuration(values))
        assert np.allclose(data.oMf[model.getFrameId(frame)].homogeneous, expected, atol=1e-9), frame


def test_tool_frame_sits_between_palm_and_fingertips(madar):
    q = np.zeros(12)
    palm = madar.frame_pose("right_hand_palm_link", q)
    tool = madar.frame_pose("right_tool", q)
    in_palm = np.linalg.inv(palm) @ tool
    assert np.allclose(in_palm[:3, 3], (0.045, 0.0, 0.035))
    assert np.allclose(in_palm[:3, 2], (1, 0, 0), atol=1e-9)  # approach = palm normal


def test_ur5_single_arm():
    ur5 = load_robot("ur5")
    assert ur5.group_joints() == [
        f"{j}_joint" for j in ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3")
    ]
    assert np.allclose(ur5.frame_pose("tool", np.zeros(6)), ur5.frame_pose("wrist_3_link", np.zeros(6)))


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda r: load_robot("pr2"), "unknown robot 'pr2'"),
        (lambda r: load_robot("madar", {"right": "fist"}), "unknown hand posture 'fist'"),
        (lambda r: r.frame_pose("nose", np.zeros(12)), "has no frame 'nose'"),
        (lambda r: r.frame_pose("right_tool", [0.0] * 5, "right_arm"), "has 6 joints, got a vector of 5"),
        (lambda r: r.frame_pose("right_tool", {"right_knee": 1.0}), "no arm joint 'right_knee'"),
        (lambda r: r.configuration({"universe": 1.0}), "no arm joint 'universe'"),  # a model joint, not an arm's
        (lambda r: r.frame_pose("right_tool", [np.nan] * 6, "right_arm"), "must be finite"),
        (lambda r: r.group_joints("torso"), "no joint group 'torso'"),
    ],
)
def test_bad_input_is_a_clear_error(madar, call, message):
    with pytest.raises(HriplanError, match=message):
        call(madar)


def test_joint_values_by_name_go_where_pinocchio_puts_each_joint(madar):
    """Named values land on their joints' entries; the joints not named keep `base`'s."""
    values = {name: 0.1 * (k + 1) for k, name in enumerate(reversed(madar.joint_names[:7]))}
    base = madar.q_neutral + 0.5
    expected = base.copy()
    for name, value in values.items():
        expected[madar.model.joints[madar.model.getJointId(name)].idx_q] = value
    np.testing.assert_array_equal(madar.configuration(values, base=base), expected)


def test_frame_ids_are_each_robots_own_and_the_same_when_asked_again(madar):
    """`frame_id` keeps the ids it looked up, per robot: pinocchio's id on that robot's model."""
    ur5 = load_robot("ur5")
    for robot in (madar, ur5, madar, ur5):
        for frame in robot.model.frames:
            assert robot.frame_id(frame.name) == robot.model.getFrameId(frame.name)
    for robot, other in ((madar, ur5), (ur5, madar)):
        name = other.tool_frame(next(iter(other.arms)))
        assert not robot.model.existFrame(name)
        with pytest.raises(HriplanError, match=f"has no frame {name!r}"):  # the other robot's, asked of it
            robot.frame_id(name)


def test_non_unit_quaternion_is_rejected():
    with pytest.raises(ValueError, match="not a unit quaternion"):
        Pose(quat_xyzw=(0, 0, 0, 2))
    assert np.allclose(Pose(quat_xyzw=(0, 0, 0, 1.0005)).rotation(), np.eye(3))


def test_meshes_sit_where_example_robot_data_puts_them(rng):
    """Our DH-style frames and mesh origins place every UR5 mesh where example-robot-data's own
    UR5 does at the same joint values (its base frame is ours turned by pi about z), to within
    the 0.5 mm by which the DH and URDF link lengths differ."""
    import coal
    import example_robot_data

    ours = load_robot("ur5")
    ref = example_robot_data.load("ur5")
    ref_data = ref.model.createData()
    turn = pin.rpy.rpyToMatrix(0, 0, np.pi)

    def world(model, data, geometry, q, name):
        pin.forwardKinematics(model, data, q)
        geom = next(
            g for g in geometry.geometryObjects if g.name.startswith(name) and isinstance(g.geometry, coal.BVHModelBase)
        )
        vertices = np.asarray(coal.MeshLoader().load(geom.meshPath, geom.meshScale).vertices())
        placement = data.oMi[geom.parentJoint] * geom.placement
        return vertices @ placement.rotation.T + placement.translation

    for q in rng.uniform(-3, 3, (5, 6)):
        for ours_name, ref_name in [
            ("shoulder", "shoulder"),
            ("upper_arm", "upper_arm"),
            ("fore_arm", "forearm"),
            ("wrist_1", "wrist_1"),
            ("wrist_2", "wrist_2"),
            ("wrist_3", "wrist_3"),
        ]:
            a = world(ours.model, ours.data, ours.collision_meshes, q, ours_name)
            b = world(ref.model, ref_data, ref.collision_model, q, ref_name)
            assert np.abs(a @ turn.T - b).max() < 1e-3, ours_name


def test_a_robot_is_its_description_not_its_name(monkeypatch):
    # A robot added as data only (a UR5 whose arm is called "main"): groups, tool frame, hands and
    # the base link come from its description; before, code branched on the names madar and ur5.
    from hriplan.planner.motion import JointTarget
    from hriplan.planner.session import PlanningSession
    from hriplan.robots.descriptions import registry as descriptions
    from hriplan.robots.descriptions.description import ArmDescription, RobotDescription

    main = RobotDescription(
        name="cell_ur5",
        label="UR5 cell",
        summary="A single arm",
        urdf=descriptions.DESCRIPTIONS["ur5"].urdf,
        base_link="base_link",
        whole_group="all",
        postures={"ready": {}},
        arms={
            "main": ArmDescription(
                "", "tool", "main_arm", descriptions.DESCRIPTIONS["ur5"].arms["arm"].joints, "base_link"
            )
        },
    )
    monkeypatch.setitem(descriptions.DESCRIPTIONS, "cell_ur5", main)
    robot = load_robot("cell_ur5")
    assert robot.groups.keys() == {"main_arm", "all"} and robot.default_group == "all"
    assert robot.arm_group("main") == "main_arm" and robot.tool_frame("main") == "tool" and robot.hand_postures == {}
    with pytest.raises(HriplanError, match="has no hand 'right'"):
        load_robot("cell_ur5", {"right": "power"})
    session = PlanningSession(robot)
    goal = JointTarget(values={"shoulder_lift_joint": -1.2, "elbow_joint": 1.0})
    result = session.plan(dict(zip(robot.joint_names, [0.0, -1.57, 1.57, 0.0, 0.0, 0.0])), goal, group="main_arm")
    assert result.solved, result.message
    assert result.trajectory.points[-1].positions[1] == pytest.approx(-1.2, abs=1e-6)


def test_an_arm_names_its_ik_solver_and_its_hand_model(monkeypatch):
    # The solver and the hand are picked by the description's data; an unknown kind is one line.
    from hriplan.robots.descriptions import registry as descriptions
    from hriplan.robots.ik import solve_ik

    madar = descriptions.DESCRIPTIONS["madar"]
    right = madar.arms["right"]
    kdl = replace(madar, arms={**madar.arms, "right": replace(right, ik="kdl")})
    monkeypatch.setitem(descriptions.DESCRIPTIONS, "madar_kdl", kdl)
    robot = load_robot("madar_kdl")
    with pytest.raises(
        HriplanError,
        match="the right arm's IK solver 'kdl' is not supported; supported: numeric, ur3_analytic, ur3e_analytic",
    ):
        solve_ik(robot, "right", robot.frame_pose("right_tool", robot.q_neutral))
    assert solve_ik(robot, "left", robot.frame_pose("left_tool", robot.q_neutral)).success
    shadow = replace(madar, arms={**madar.arms, "right": replace(right, hand="shadow")})
    monkeypatch.setitem(descriptions.DESCRIPTIONS, "madar_shadow", shadow)
    with pytest.raises(HriplanError, match="hand model 'shadow' is not supported; supported: allegro"):
        load_robot("madar_shadow")


def test_robots_with_other_hand_postures_share_the_meshes_not_the_fingers(rng):
    """A task loads the robot with a hand closed, then opened to release: the full model and its
    collision meshes are loaded once (about 50 ms), and each robot's planning model still has the
    fingers at its own posture (checked against pinocchio on the URDF text, fingers set here)."""
    from hriplan.robots.descriptions.description import hand_model

    closed, opened = load_robot("madar", {"right": "power"}), load_robot("madar", {"right": "open"})
    assert closed is not opened
    assert closed.full_model is opened.full_model and closed.full_collision is opened.full_collision
    assert load_robot("madar", base_pose=Pose(xyz=(1.0, 0, 0))).full_model is not closed.full_model
    model = pin.buildModelFromXML(description_of("madar").urdf())
    data = model.createData()
    arm = description_of("madar").arms["right"]
    hand = hand_model(arm.hand)
    q_arm = rng.uniform(-1, 1, 12)
    tip = "right_hand_link_3.0_tip"
    poses = {}
    for posture, robot in (("power", closed), ("open", opened)):
        q = pin.neutral(model)
        for joint, value in hand.joint_values(posture).items():
            q[model.joints[model.getJointId(hand.joint_name(arm.prefix, joint))].idx_q] = value
        for name, value in zip(robot.group_joints(), q_arm):
            q[model.joints[model.getJointId(name)].idx_q] = value
        pin.framesForwardKinematics(model, data, q)
        poses[posture] = robot.frame_pose(tip, q_arm)
        assert np.allclose(data.oMf[model.getFrameId(tip)].homogeneous, poses[posture], atol=1e-9), posture
    assert np.linalg.norm(poses["power"][:3, 3] - poses["open"][:3, 3]) > 0.01  # the postures differ
