"""Kautham problem import: constraints, frames, the rpy convention, the query, clear errors.

The files in tests/data/kautham are hriplan's own, written in the format of Kautham's
demos/OMPL_constr_demos: a controls file, a problem file and obstacle URDFs in a models folder.
"""

import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from hriplan import HriplanError
from hriplan.formats.kautham import import_kautham
from hriplan.planner.constraints.spec import BoxConstraint, ConeConstraint, OrientationConstraint
from independent import constraint_violations

FIXTURE = Path(__file__).parents[1] / "data" / "kautham_madar_handover.xml"


@pytest.fixture(scope="module")
def problem():
    return import_kautham(FIXTURE, warn=lambda message: None)


def test_orientation_with_dynamic_tolerance(problem):
    upright = problem.constraints.constraints[0]
    assert isinstance(upright, OrientationConstraint)
    assert upright.joints[0] == "right_shoulder_pan_joint" and upright.joints[-1] == "right_wrist_3_joint"
    assert upright.target_link == "right_wrist_3_link" and upright.frame.entity == "robot_base"
    assert upright.target.quat_xyzw == (1.0, 0.0, 0.0, 0.0) and upright.free_axes == []
    assert (upright.tolerance, upright.tolerance_gradient) == (0.1, 0.2)


def test_cone_refers_to_the_obstacle_with_kautham_rpy(problem):
    cone = problem.constraints.constraints[1]
    assert isinstance(cone, ConeConstraint) and (cone.radius, cone.height, cone.region) == (0.3, 0.6, "inside")
    # The can (tests/data/obstacles/coke_can.urdf, found next to the problem) is a cylinder whose
    # centre is 6 cm above the can's frame; the cone still hangs from the can's frame.
    can = next(o for o in problem.scene.obstacles if o.name == "Coke can")
    assert can.shape.type == "cylinder" and can.pose.xyz == pytest.approx((0.1, 0.9, 1.06))
    assert cone.frame.entity == "Coke can"
    world = can.pose.se3() * cone.frame.offset.se3()
    assert np.allclose(world.translation, (0.1, 0.8, 1.0))
    assert np.allclose(world.rotation, pin.rpy.rpyToMatrix(1.5708, 0, 0))


def test_box_disabled_and_query_mapped_by_name(problem):
    box = problem.constraints.constraints[2]
    assert isinstance(box, BoxConstraint) and not box.enabled and box.size == (1.0, 1.0, 1.0)
    # c = 0.629 -> 4 pi c - 2 pi; the fore arm link is the elbow joint's child
    assert problem.start["right_shoulder_pan_joint"] == pytest.approx(4 * math.pi * 0.629 - 2 * math.pi)
    assert problem.start["right_elbow_joint"] == pytest.approx(4 * math.pi * 0.581 - 2 * math.pi)
    assert problem.goal.values["right_wrist_3_joint"] == pytest.approx(4 * math.pi * 0.552 - 2 * math.pi)
    assert problem.group == "right_arm" and problem.options.time_limit == 10.0 and problem.options.planner == "CBiRRT"


def test_rpy_conventions_differ_for_combined_angles(tmp_path):
    text = FIXTURE.read_text().replace('rpy="1.5708 0 0"', 'rpy="0.3 0.4 0.5"')
    path = tmp_path / "p.xml"
    path.write_text(text)
    kautham = import_kautham(path, warn=lambda m: None).constraints.constraints[1].frame.offset.rotation()
    urdf = import_kautham(path, rpy="urdf", warn=lambda m: None).constraints.constraints[1].frame.offset.rotation()
    rx, ry, rz = (pin.rpy.rpyToMatrix(0.3, 0, 0), pin.rpy.rpyToMatrix(0, 0.4, 0), pin.rpy.rpyToMatrix(0, 0, 0.5))
    assert np.allclose(kautham, rx @ ry @ rz) and np.allclose(urdf, rz @ ry @ rx)
    assert not np.allclose(kautham, urdf)


@pytest.mark.parametrize(
    "old, new, message",
    [
        ('type="cone"', 'type="torus"', "unknown type 'torus'"),
        (
            '<GeometricParams radius="0.3" height="0.6"/>',
            '<GeometricParams radius="0.3"/>',
            "has no attribute 'height'",
        ),
        (
            '<TargetLink name="right_wrist_3_link"/>\n        <Joint name="right_shoulder_link"/>\n        <Joint name="right_upper_arm_link"/>\n        <Joint name="right_fore_arm_link"/>\n        <Joint name="right_wrist_1_link"/>\n        <Joint name="right_wrist_2_link"/>\n        <Joint name="right_wrist_3_link"/>\n        <GeometricParams radius',
            '<TargetLink name="right_nose_link"/>\n        <GeometricParams radius',
            "has no link 'right_nose_link'",
        ),
        (
            '<Joint name="right_wrist_1_link"/>',
            '<Joint name="right_wrist_9_link"/>',
            "no link or joint 'right_wrist_9_link'",
        ),
        ('entity="Coke can"', 'entity="Pepsi can"', "'Pepsi can' is not an obstacle"),
        ('qx="1"', 'qx="2"', "not a unit quaternion"),
        ('init="0.629"', 'init="1.629"', "not a normalised value"),
        ("</Problem>", "", "not valid XML"),
    ],
)
def test_bad_files_give_one_line_errors(tmp_path, old, new, message):
    text = FIXTURE.read_text()
    assert old in text
    path = tmp_path / "bad.xml"
    path.write_text(text.replace(old, new, 1))
    with pytest.raises(HriplanError, match=message) as info:
        import_kautham(path, warn=lambda message: None)
    assert str(info.value).startswith(str(path)) and "\n" not in str(info.value)


def test_an_imported_problem_plans():
    from hriplan.planner.session import PlanningSession

    problem = import_kautham(FIXTURE.with_name("kautham_ur5_upright.xml"), warn=lambda message: None)
    assert problem.robot == "ur5" and problem.group == "arm" and problem.constraints.constraints[0].free_axes == ["z"]
    session = PlanningSession(problem.robot, problem.scene)
    session.set_constraints(problem.constraints)
    result = session.plan(problem.start, problem.goal, problem.options.model_copy(update={"seed": 1}), problem.group)
    assert result.solved, result.message
    assert (
        result.trajectory.report.max_violation["upright"] <= 1e-4
        and result.trajectory.report.max_violation["workspace"] <= 1e-4
    )
    assert constraint_violations(result.trajectory) == []


# -- Kautham's own format: controls files, models folder, Home, link aliases ------------------
KAUTHAM = Path(__file__).parents[1] / "data" / "kautham"
MODELS = KAUTHAM / "models"
UR5_CELL = KAUTHAM / "ur5_cell.xml"
MADAR_RIGHT = KAUTHAM / "madar_right_arm.xml"
TWO_PI = 2 * math.pi


def _import(path, **kwargs):
    warnings = []
    return import_kautham(path, models=[MODELS], warn=warnings.append, **kwargs), warnings


def test_controls_file_gives_every_joint_its_angle():
    problem, warnings = _import(UR5_CELL)
    assert warnings == []
    start, goal = problem.start, problem.goal.values
    # ur5/pan moves the shoulder one to one over +-2 pi: q = -2 pi + 4 pi c.
    assert start["shoulder_pan_joint"] == pytest.approx(-TWO_PI + 2 * TWO_PI * 0.687037)
    assert goal["shoulder_pan_joint"] == pytest.approx(-TWO_PI + 2 * TWO_PI * 0.780620)
    # ur5/twist has eigValue 0.5: p = 0.5 + 0.5 (c - 0.5).
    assert start["wrist_3_joint"] == pytest.approx(-TWO_PI + 2 * TWO_PI * (0.5 + 0.5 * (0.124074 - 0.5)))
    # No control moves these: their offsets, the elbow over the robot file's range of +-pi.
    assert start["elbow_joint"] == pytest.approx(-math.pi + 2 * math.pi * 0.815) == goal["elbow_joint"]
    assert start["shoulder_lift_joint"] == pytest.approx(-TWO_PI + 2 * TWO_PI * 0.405852)
    assert start["wrist_2_joint"] == pytest.approx(-math.pi / 2) and start["wrist_1_joint"] != 0.0
    assert problem.group == "arm" and set(start) == set(goal)


def test_query_as_init_and_goal_lists_in_control_order(tmp_path):
    _copy_fixture(tmp_path)
    text = UR5_CELL.read_text()
    query = text[text.index("<RobotControl") : text.index("</Query>")]
    path = tmp_path / "lists.xml"
    path.write_text(text.replace(query, "<Init>0.687037 0.124074</Init><Goal>0.780620 0.311240</Goal>\n"))
    listed = import_kautham(path, models=[MODELS], warn=lambda message: None)
    named, _ = _import(UR5_CELL)
    assert listed.start == named.start and listed.goal == named.goal


def test_home_moves_the_world_into_the_robot_frame():
    problem, _ = _import(UR5_CELL)
    (crate,) = problem.scene.obstacles
    # Robot Home X=0.1; crate Home (0.55, -0.6, 0); its box centre 0.1 above the crate's frame.
    assert crate.shape.size == (0.3, 0.2, 0.2) and crate.pose.xyz == pytest.approx((0.45, -0.6, 0.1))
    box = problem.constraints.constraints[1]
    assert box.frame.entity == "crate"
    world = crate.pose.se3() * box.frame.offset.se3()
    assert np.allclose(world.translation, (0.45, 0.0, 0.3)) and np.allclose(world.rotation, np.eye(3))


def test_obstacle_scale_and_a_skipped_obstacle(tmp_path):
    _copy_fixture(
        tmp_path,
        problem_edit=('obstacle="obstacles/crate.urdf" scale="1.0"', 'obstacle="obstacles/crate.urdf" scale="2.0"'),
    )
    (crate,) = import_kautham(tmp_path / "ur5_cell.xml", models=[MODELS], warn=lambda message: None).scene.obstacles
    assert crate.shape.size == (0.6, 0.4, 0.4) and crate.pose.xyz == pytest.approx((0.45, -0.6, 0.2))
    # Without the models folder: no crate, and the robot file (the elbow's range) is missing too.
    _copy_fixture(tmp_path, problem_edit=('robot="robots/ur5_cell.urdf"', 'robot="robots/ur5_elsewhere.urdf"'))
    (tmp_path / "controls" / "ur5_cell.cntr").write_text(
        (tmp_path / "controls" / "ur5_cell.cntr").read_text().replace('"0.815"', '"0.6575"')
    )
    warnings = []
    skipped = import_kautham(tmp_path / "ur5_cell.xml", warn=warnings.append)
    assert skipped.scene.obstacles == [] and skipped.start["elbow_joint"] == pytest.approx(
        -TWO_PI + 2 * TWO_PI * 0.6575
    )
    assert any("skipped obstacle 'crate'" in w and "--models" in w for w in warnings)
    assert any("robot file 'robots/ur5_elsewhere.urdf'" in w for w in warnings)
    box = skipped.constraints.constraints[1]
    assert box.frame.entity == "world" and np.allclose(box.frame.offset.xyz, (0.45, 0.0, 0.3))


def test_madar_aliases_offsets_enabled_and_a_two_piece_obstacle():
    problem, warnings = _import(MADAR_RIGHT)
    assert len(warnings) == 1 and "madar_dual_manipulator.urdf" in warnings[0]  # the robot file is Kautham's
    upright, box, sphere = problem.constraints.constraints
    assert upright.target_link == box.target_link == "right_hand_palm_link"
    assert upright.enabled and box.enabled and not sphere.enabled
    # The left arm, which no control moves, is folded by its offsets (not at zero).
    assert problem.start["left_shoulder_lift_joint"] == pytest.approx(-2.2, abs=1e-4)
    assert problem.start["left_elbow_joint"] == pytest.approx(1.2, abs=1e-4)
    assert problem.start["left_wrist_3_joint"] == 0.0 and problem.group == "right_arm"
    top, leg = problem.scene.obstacles
    assert (top.name, leg.name) == ("side_table", "side_table_part2")
    assert top.pose.xyz == pytest.approx((0.45, 0.85, 0.7)) and leg.pose.xyz == pytest.approx((0.45, 0.85, 0.35))
    assert leg.shape.type == "cylinder" and leg.shape.height == pytest.approx(0.64)


def test_kautham_hand_base_link_is_the_palm(madar, rng):
    """Kautham's MADAR: wrist_3 -> adapter (0 0 0.0225) -> hand base (0 0.01 0.1175, yaw pi/2)."""
    adapter = pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.0225]))
    support = pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, 1.570796326589793), np.array([0.0, 0.01, 0.1175]))
    for _ in range(5):
        q = rng.uniform(madar.model.lowerPositionLimit, madar.model.upperPositionLimit)
        wrist = pin.SE3(madar.frame_pose("right_wrist_3_link", q))
        kautham = (wrist * adapter * support).homogeneous
        assert np.allclose(madar.frame_pose(madar.link_name("right_hand_base_link"), q), kautham, atol=1e-9)
        assert np.allclose(
            madar.frame_pose(madar.link_name("right_hand_adapter_link"), q), (wrist * adapter).homogeneous
        )


def _orientation_error(robot, q, constraint) -> float:
    """Rotation-vector error of the target link against the target, relative to the robot base
    (masked free axes): written out here rather than taken from the planner."""
    base = robot.frame_pose("madar_base_link" if robot.name == "madar" else "base_link", q)[:3, :3]
    link = robot.frame_pose(constraint.target_link, q)[:3, :3]
    error = pin.log3(constraint.target.rotation().T @ base.T @ link)
    for axis in constraint.free_axes:
        error["xyz".index(axis)] = 0.0
    return float(np.linalg.norm(error))


@pytest.mark.parametrize("path", [UR5_CELL, MADAR_RIGHT], ids=["ur5_cell", "madar_right_arm"])
def test_own_fixtures_plan_and_every_point_keeps_the_constraints(path):
    from hriplan.planner.session import PlanningSession

    problem, _ = _import(path)
    session = PlanningSession(problem.robot, problem.scene)
    session.set_constraints(problem.constraints)
    result = session.plan(problem.start, problem.goal, problem.options.model_copy(update={"seed": 1}), problem.group)
    assert result.solved, result.message
    trajectory, robot = result.trajectory, session.robot
    upright, box = problem.constraints.constraints[:2]
    obstacles = {o.name: o for o in problem.scene.obstacles}
    frame = obstacles[box.frame.entity].pose.se3() * box.frame.offset.se3()
    for point in trajectory.points:
        # The problem's start for joints outside the group (trajectory.start holds them once I2 is merged).
        q = robot.configuration({**problem.start, **dict(zip(trajectory.joint_names, point.positions))})
        assert _orientation_error(robot, q, upright) <= upright.tolerance + 1e-6
        local = frame.actInv(robot.frame_pose(box.target_link, q)[:3, 3])
        assert np.all(np.abs(local) <= np.array(box.size) / 2 + 1e-6)
        assert not session.checker.in_collision(q)


@pytest.mark.parametrize(
    "edit, message",
    [
        (
            ('robot="controls/ur5_cell.cntr"', 'robot="controls/ur5_missing.cntr"'),
            "controls file 'controls/ur5_missing.cntr' not found",
        ),
        (('name="ur5/twist" init', 'name="ur5/spin" init'), "control 'ur5/spin' is not in"),
        (
            ('<RobotControl name="ur5/twist" init="0.124074" goal="0.311240"/>', ""),
            "query sets 1 of 2 controls; missing: ur5/twist",
        ),
        (
            (
                '<RobotControl name="ur5/pan"',
                '<RobotControl name="ur5/pan" init="0.5" goal="0.5"/><RobotControl name="ur5/pan"',
            ),
            "control 'ur5/pan' is set twice",
        ),
        (
            (
                '<TargetLink name="wrist_3_link"/>\n\t\t\t<GeometricParams',
                '<TargetLink name="wrist_3_link"/>\n\t\t\t<Enabled status="maybe"/>\n\t\t\t<GeometricParams',
            ),
            "<Enabled status> must be true or false",
        ),
    ],
)
def test_bad_problem_pieces_give_one_line_errors(tmp_path, edit, message):
    _copy_fixture(tmp_path, problem_edit=edit)
    _expect(tmp_path / "ur5_cell.xml", message)


@pytest.mark.parametrize(
    "edit, message",
    [
        (('eigValue="0.5"', 'eigValue="half"'), "control 'ur5/twist': eigValue: 'half' is not 1 numbers"),
        (
            ('"ur5/wrist_2_link"', '"ur5/wrist_7_link"'),
            "DOF 'ur5/wrist_7_link': the robot has no joint moving link 'wrist_7_link'",
        ),
        (('"ur5/wrist_2_link"', '"ur10/wrist_2_link"'), "names robot 'ur10', not"),
        (('"ur5/wrist_2_link"', '"wrist_2_link"'), "DOF 'wrist_2_link' is not ROBOT/LINK"),
        (('<DOF name="ur5/shoulder_link" value="1.0"/>', '<DOF name="ur5/X" value="1.0"/>'), "moves the mobile base"),
        (("</ControlSet>", ""), "not valid XML"),
    ],
)
def test_bad_controls_files_give_one_line_errors(tmp_path, edit, message):
    _copy_fixture(tmp_path, controls_edit=edit)
    _expect(tmp_path / "ur5_cell.xml", message, tmp_path / "controls" / "ur5_cell.cntr")


def test_bad_obstacle_urdf_and_overlapping_constraints(tmp_path):
    _copy_fixture(tmp_path)
    crate = tmp_path / "models" / "obstacles" / "crate.urdf"
    crate.write_text(crate.read_text().replace('<box size="0.3 0.2 0.2" />', '<box size="0.3 0.2" />'))
    _expect(tmp_path / "ur5_cell.xml", "link 'base', collision 1: '0.3 0.2' is not 3 finite numbers", crate)
    _copy_fixture(
        tmp_path,
        problem_edit=(
            '<Joint name="shoulder_link" />\n\t\t\t<Joint name="upper_arm_link" />\n\t\t\t<Joint name="fore_arm_link" />\n\t\t\t<Joint name="wrist_1_link" />\n\t\t\t<Joint name="wrist_2_link" />\n\t\t\t<Joint name="wrist_3_link" />\n\t\t</Constraint>\n\t</Robot>',
            '<Joint name="upper_arm_link" />\n\t\t\t<Joint name="fore_arm_link" />\n\t\t\t<Joint name="wrist_1_link" />\n\t\t\t<Joint name="wrist_2_link" />\n\t\t\t<Joint name="wrist_3_link" />\n\t\t</Constraint>\n\t</Robot>',
        ),
    )
    _expect(tmp_path / "ur5_cell.xml", "constraints 'upright' and 'workspace' share joints .* but not all of them")


def _copy_fixture(tmp_path, problem_edit=None, controls_edit=None):
    import shutil

    shutil.copytree(KAUTHAM, tmp_path, dirs_exist_ok=True)
    for name, edit in (("ur5_cell.xml", problem_edit), ("controls/ur5_cell.cntr", controls_edit)):
        if edit:
            text = (KAUTHAM / name).read_text()
            assert edit[0] in text, edit[0]
            (tmp_path / name).write_text(text.replace(edit[0], edit[1], 1))


def _expect(path, message, named=None):
    with pytest.raises(HriplanError, match=message) as info:
        import_kautham(path, models=[path.parent / "models"], warn=lambda m: None)
    assert str(info.value).startswith(str(named or path)) and "\n" not in str(info.value)


def test_cli_imports_with_models_and_plans(tmp_path):
    from test_kautham_robot_file import run  # `hriplan import-kautham` in its own process

    done = run(UR5_CELL, "--models", MODELS, "-o", tmp_path / "cell.json", "--plan")
    assert done.returncode == 0, done.stderr
    assert (
        "2 constraints, group arm, 1 obstacles" in done.stdout
        and "ur5_cell: solved" in done.stdout
        and done.stderr == ""
    )
    # Without its models the robot file is missing: over +-2 pi the elbow's offset is out of range.
    bare = run(UR5_CELL, "-o", tmp_path / "bare.json")
    lines = bare.stderr.strip().splitlines()
    assert bare.returncode == 2 and "Traceback" not in bare.stderr and len(lines) == 3
    assert "skipped obstacle 'crate'" in lines[0] and "robot file" in lines[1]
    assert lines[2].startswith("error: ") and "elbow_joint = 3.958 rad is outside hriplan's limits" in lines[2]
    broken = run(KAUTHAM / "nope.xml")
    assert broken.returncode == 2 and broken.stderr.strip() == f"error: {KAUTHAM / 'nope.xml'}: no such file"
