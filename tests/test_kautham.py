"""Kautham problem import: constraints, frames, the rpy convention, the query, clear errors."""

import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from hriplan import HriplanError
from hriplan.planner.spec import BoxConstraint, ConeConstraint, OrientationConstraint
from hriplan.tasks.kautham import import_kautham

FIXTURE = Path(__file__).parent / "data" / "kautham_madar_handover.xml"


@pytest.fixture(scope="module")
def problem():
    return import_kautham(FIXTURE)


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
    assert cone.frame.entity == "Coke can" and cone.frame.offset.xyz == (0.0, -0.1, 0.0)
    assert np.allclose(cone.frame.offset.rotation(), pin.rpy.rpyToMatrix(1.5708, 0, 0))
    can = next(o for o in problem.scene.obstacles if o.name == "Coke can")
    assert can.pose.xyz == (0.1, 0.9, 1.0)


def test_box_disabled_and_query_mapped_by_name(problem):
    box = problem.constraints.constraints[2]
    assert isinstance(box, BoxConstraint) and not box.enabled and box.size == (1.0, 1.0, 1.0)
    # c = 0.629 -> 4 pi c - 2 pi; the fore arm link is the elbow joint's child
    assert problem.start["right_shoulder_pan_joint"] == pytest.approx(4 * math.pi * 0.629 - 2 * math.pi)
    assert problem.start["right_elbow_joint"] == pytest.approx(4 * math.pi * 0.581 - 2 * math.pi)
    assert problem.goal.values["right_wrist_3_joint"] == pytest.approx(4 * math.pi * 0.552 - 2 * math.pi)
    assert problem.group == "right_arm" and problem.options.time_limit == 10.0 and problem.options.range == 0.1


def test_rpy_conventions_differ_for_combined_angles(tmp_path):
    text = FIXTURE.read_text().replace('rpy="1.5708 0 0"', 'rpy="0.3 0.4 0.5"')
    path = tmp_path / "p.xml"
    path.write_text(text)
    kautham = import_kautham(path).constraints.constraints[1].frame.offset.rotation()
    urdf = import_kautham(path, rpy="urdf").constraints.constraints[1].frame.offset.rotation()
    rx, ry, rz = (pin.rpy.rpyToMatrix(0.3, 0, 0), pin.rpy.rpyToMatrix(0, 0.4, 0), pin.rpy.rpyToMatrix(0, 0, 0.5))
    assert np.allclose(kautham, rx @ ry @ rz) and np.allclose(urdf, rz @ ry @ rx)
    assert not np.allclose(kautham, urdf)


@pytest.mark.parametrize(
    "old, new, message",
    [
        ('type="cone"', 'type="torus"', "unknown type 'torus'"),
        ('<GeometricParams radius="0.3" height="0.6"/>', '<GeometricParams radius="0.3"/>', "has no attribute 'height'"),
        ('<TargetLink name="right_wrist_3_link"/>\n        <Joint name="right_shoulder_link"/>\n        <Joint name="right_upper_arm_link"/>\n        <Joint name="right_fore_arm_link"/>\n        <Joint name="right_wrist_1_link"/>\n        <Joint name="right_wrist_2_link"/>\n        <Joint name="right_wrist_3_link"/>\n        <GeometricParams radius',
         '<TargetLink name="right_nose_link"/>\n        <GeometricParams radius', "has no link 'right_nose_link'"),
        ('<Joint name="right_wrist_1_link"/>', '<Joint name="right_wrist_9_link"/>', "no link or joint 'right_wrist_9_link'"),
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
        import_kautham(path)
    assert str(info.value).startswith(str(path)) and "\n" not in str(info.value)


def test_an_imported_problem_plans():
    from hriplan.planner.session import PlanningSession

    problem = import_kautham(FIXTURE.with_name("kautham_ur5_upright.xml"))
    assert problem.robot == "ur5" and problem.group == "arm" and problem.constraints.constraints[0].free_axes == ["z"]
    session = PlanningSession(problem.robot, problem.scene)
    session.set_constraints(problem.constraints)
    result = session.plan(problem.start, problem.goal, problem.options.model_copy(update={"seed": 1}), problem.group)
    assert result.solved, result.message
    assert result.trajectory.report.max_violation["upright"] <= 1e-4 and result.trajectory.report.max_violation["workspace"] <= 1e-4
