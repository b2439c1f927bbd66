"""ROS-Industrial frame names: a constraint on `tool0` (`right_tool0` on MADAR) binds to the
flange's pose, by pinocchio built here from the robot's URDF and by UR's own forward kinematics
(the controller's base-to-tool0 transform); a robot file names them per arm or explicitly, and a
bad alias is one line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import ur_analytic_ik
import yaml
from typer.testing import CliRunner

from hriplan.cli.main import app
from hriplan.planner.constraints.binding import bind
from hriplan.planner.constraints.spec import OrientationConstraint
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.descriptions.registry import description_of, load_robot_file
from hriplan.robots.model import load_robot

DATA = Path(__file__).parents[1] / "data" / "robots"

pytestmark = pytest.mark.usefixtures("robot_registry")


def _urdf_fk(urdf: str, values: dict[str, float]) -> tuple[pin.Model, pin.Data]:
    model = pin.buildModelFromXML(urdf)
    data = model.createData()
    q = pin.neutral(model)
    for joint, value in values.items():
        q[model.joints[model.getJointId(joint)].idx_q] = value
    pin.framesForwardKinematics(model, data, q)
    return model, data


@pytest.mark.parametrize(
    "name, arm, tool0, base, flange",
    [
        ("ur5", "arm", "tool0", "base", "wrist_3_link"),
        ("madar", "right", "right_tool0", "right_base", "right_wrist_3_link"),
        ("madar", "left", "left_tool0", "left_base", "left_wrist_3_link"),
    ],
)
def test_a_constraint_on_tool0_binds_to_the_flange(name, arm, tool0, base, flange, rng):
    robot = load_robot(name)
    joints = list(description_of(name).arms[arm].joints)
    spec = OrientationConstraint(id="c", joints=joints, target_link=tool0)
    [bound] = bind([spec], robot, CollisionChecker(robot))
    data = robot.model.createData()
    for _ in range(5):
        values = dict(zip(joints, rng.uniform(-3.0, 3.0, len(joints))))
        q = robot.configuration(values)
        pin.framesForwardKinematics(robot.model, data, q)
        model, independent = _urdf_fk(description_of(name).urdf(), values)
        flange_pose = independent.oMf[model.getFrameId(flange)]
        arm_base = independent.oMf[model.getFrameId(description_of(name).arms[arm].base_link)]
        # hriplan stands the robot at its base pose; the URDF's root is at the origin.
        world = (
            pin.SE3(robot.frame_pose(description_of(name).base_link, q))
            * pin.SE3(independent.oMf[model.getFrameId(description_of(name).base_link)]).inverse()
        )
        assert np.allclose(data.oMf[bound.link].homogeneous, (world * flange_pose).homogeneous, atol=1e-9)
        # UR's tool0 in its base frame is the controller's (ur_analytic_ik's) forward kinematics.
        relative = np.linalg.inv(robot.frame_pose(base, q)) @ robot.frame_pose(tool0, q)
        assert np.allclose(relative, ur_analytic_ik.ur5.forward_kinematics(*values.values()), atol=1e-6)
        assert np.allclose(robot.frame_pose(base, q), (world * arm_base).homogeneous, atol=1e-9)


def _robot_file(tmp_path: Path, **changes) -> Path:
    data = yaml.safe_load((DATA / "ur10.yaml").read_text())
    data.update(changes)
    path = tmp_path / "robot.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_robot_file_aliases_per_arm_and_explicit(tmp_path, rng):
    path = _robot_file(
        tmp_path,
        name="ur10_aliased",
        arms={"arm": {"base": "base_link", "tip": "wrist_3_link", "ik": "numeric", "ros_industrial": True}},
        frame_aliases={"flange": "wrist_3_link", "mount": "shoulder_link"},
    )
    description = load_robot_file(path)
    # ur_description's URDF has its own base and tool0 links: they are kept, not aliased.
    assert description.link_aliases == {"flange": "wrist_3_link", "mount": "shoulder_link"}
    robot = load_robot(description.name)
    q = robot.configuration(rng.uniform(-2.0, 2.0, 6))
    assert np.allclose(robot.frame_pose("flange", q), robot.frame_pose("wrist_3_link", q))
    assert robot.frame_pose("tool0", q) is not None  # the URDF's own tool0 link


def test_ros_industrial_names_the_base_and_flange_where_the_urdf_does_not(tmp_path):
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(description_of("ur5").urdf())
    path = tmp_path / "robot.yaml"
    path.write_text(
        yaml.safe_dump(
            {
                "name": "two_names",
                "urdf": "arm.urdf",
                "arms": {"arm": {"base": "base_link", "tip": "tool", "ros_industrial": True}},
            }
        )
    )
    description = load_robot_file(path)
    assert description.link_aliases == {"base": "base_link", "tool0": "wrist_3_link"}


@pytest.mark.parametrize(
    "changes, message",
    [
        ({"frame_aliases": {"flange": "no_such_link"}}, "frame_aliases.flange: unknown link 'no_such_link'"),
        ({"frame_aliases": {"wrist_3_link": "base_link"}}, "frame_aliases.wrist_3_link: the URDF already has a link"),
    ],
)
def test_a_bad_alias_is_one_line(tmp_path, changes, message):
    path = _robot_file(tmp_path, **changes)
    result = CliRunner().invoke(app, ["robot", "check", str(path)])
    assert result.exit_code == 2
    assert message in result.stderr and len(result.stderr.strip().splitlines()) == 1
    assert "Traceback" not in result.stderr
