"""`hriplan import-kautham --robot ROBOT_FILE`: a Kautham problem planned with a robot given as a
robot file, here the hand-less MADAR of Kautham's madar_dual_arm demo (examples/robots/
madar_bare.yaml). The trajectory is re-checked here: joint limits read from the robot's URDF,
the orientation and box constraints evaluated with pinocchio built from that URDF."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import coal
import example_robot_data
import numpy as np
import pinocchio as pin
import pytest

ROOT = Path(__file__).parents[2]
KAUTHAM = ROOT / "tests" / "data" / "kautham"
PROBLEM = KAUTHAM / "madar_bare_dual_arm.xml"
ROBOT = ROOT / "examples" / "robots" / "madar_bare.yaml"
URDF = ROBOT.with_suffix(".urdf")
WRIST_BY_FOREARM = KAUTHAM / "madar_bare_wrist_by_forearm.xml"
# The folder that holds the example-robot-data package the URDF's meshes are in.
PACKAGES = Path(example_robot_data.getModelPath("ur_description/urdf/ur5_robot.urdf")).resolve().parents[1]


def run(*args):
    return subprocess.run(
        [sys.executable, "-m", "hriplan.cli", "import-kautham", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=600,
    )


def test_a_kautham_problem_plans_with_the_handless_madar_robot_file(tmp_path):
    out = tmp_path / "bare.json"
    done = run(PROBLEM, "--models", KAUTHAM / "models", "--robot", ROBOT, "-o", out, "--plan")
    assert done.returncode == 0, done.stderr
    assert "2 constraints, group all_arms, 2 obstacles" in done.stdout and "madar_bare_dual_arm: solved" in done.stdout
    trajectory = json.loads(out.with_suffix(".trajectory.json").read_text())
    assert trajectory["robot"] == "madar_bare" and trajectory["robot_file"] == str(ROBOT)
    urdf = ET.parse(URDF).getroot()
    limits = {
        j.get("name"): (float(j.find("limit").get("lower")), float(j.find("limit").get("upper")))
        for j in urdf.findall("joint")
        if j.get("type") == "revolute"
    }
    model = pin.buildModelFromUrdf(str(URDF))
    data = model.createData()
    base, flange = model.getFrameId("madar_base_link"), model.getFrameId("right_wrist_3_link")
    target = pin.rpy.rpyToMatrix(math.pi, 0.0, 0.0)  # Kautham's qx = 1: a half turn about x
    box_centre, box_half = np.array([0.25, 0.65, 1.1]), np.array([0.5, 0.4, 0.3]) / 2
    names = trajectory["joint_names"]
    assert len(names) == 12 and len(trajectory["points"]) > 2
    for point in trajectory["points"]:
        values = dict(trajectory["start"]) | dict(zip(names, point["positions"]))
        for joint, value in values.items():
            lower, upper = limits[joint]
            assert lower - 1e-9 <= value <= upper + 1e-9, joint
        q = pin.neutral(model)
        for joint, value in values.items():
            q[model.joints[model.getJointId(joint)].idx_q] = value
        pin.framesForwardKinematics(model, data, q)
        relative = data.oMf[base].rotation.T @ data.oMf[flange].rotation
        angle = np.arccos(np.clip((np.trace(target.T @ relative) - 1.0) / 2.0, -1.0, 1.0))
        assert angle <= 0.1 + 1e-3
        assert np.all(np.abs(data.oMf[flange].translation - box_centre) <= box_half + 1e-3)
    # Both arms move, from the query's start to its goal (within the 6-decimal controls).
    first, last = np.array(trajectory["points"][0]["positions"]), np.array(trajectory["points"][-1]["positions"])
    goal_left_pan = 4 * math.pi * 0.531831 - 2 * math.pi
    assert abs(last[names.index("left_shoulder_pan_joint")] - goal_left_pan) < 1e-4
    assert np.abs(last - first)[names.index("right_shoulder_lift_joint")] > 0.3


def _angle(control: float) -> float:
    """A Kautham control normalised over +-2 pi, as an angle."""
    return -2 * math.pi + 4 * math.pi * control


@pytest.mark.usefixtures("robot_registry")
def test_a_wrist_beside_its_forearm_three_links_apart_plans(tmp_path):
    """Kautham's madar_dual_arm demo stopped at its goal (invalid_goal: left_fore_arm_link -
    left_wrist_3_link): the two links' meshes are 2.4 cm apart there, their fitted capsules
    overlap, and the pair, three links apart, was checked on the capsules. This fixture (hriplan's
    own, in Kautham's format) ends the same way; it plans, and the trajectory is re-checked here:
    the pair's URDF collision meshes, placed by pinocchio from the URDF, never touch."""
    out = tmp_path / "wrist.json"
    done = run(WRIST_BY_FOREARM, "--models", KAUTHAM / "models", "--robot", ROBOT, "-o", out, "--plan")
    assert done.returncode == 0, done.stderr
    assert "madar_bare_wrist_by_forearm: solved" in done.stdout, done.stdout
    trajectory = json.loads(out.with_suffix(".trajectory.json").read_text())
    model = pin.buildModelFromUrdf(str(URDF))
    data = model.createData()
    geoms = pin.buildGeomFromUrdf(model, str(URDF), pin.COLLISION, package_dirs=[str(PACKAGES)])
    shapes = {
        link: [g for g in geoms.geometryObjects if model.frames[g.parentFrame].name == link]
        for link in ("left_fore_arm_link", "left_wrist_3_link")
    }
    assert all(len(s) == 1 for s in shapes.values())
    (fore_arm,), (wrist_3,) = shapes.values()

    def mesh_gap(values: dict[str, float]) -> float:
        q = pin.neutral(model)
        for joint, value in values.items():
            q[model.joints[model.getJointId(joint)].idx_q] = value
        pin.forwardKinematics(model, data, q)
        a, b = (data.oMi[g.parentJoint] * g.placement for g in (fore_arm, wrist_3))
        return coal.distance(
            fore_arm.geometry,
            coal.Transform3s(a.rotation, a.translation),
            wrist_3.geometry,
            coal.Transform3s(b.rotation, b.translation),
            coal.DistanceRequest(),
            coal.DistanceResult(),
        )

    names = trajectory["joint_names"]
    points = [np.array(p["positions"]) for p in trajectory["points"]]
    states = [points[0]]
    for a, b in zip(points, points[1:]):  # between the points too, <= 0.01 rad apart
        steps = max(1, math.ceil(np.abs(b - a).max() / 0.01))
        states += [a + (b - a) * k / steps for k in range(1, steps + 1)]
    gaps = [mesh_gap(dict(trajectory["start"]) | dict(zip(names, q))) for q in states]
    assert min(gaps) > 0.0
    # It ends at the query's goal, the wrist 2.4 cm from the forearm.
    goal = {"left_shoulder_lift_joint": 0.344, "left_elbow_joint": 0.654, "left_wrist_2_joint": 0.377}
    for joint, control in goal.items():
        assert abs(points[-1][names.index(joint)] - _angle(control)) < 1e-4
    assert 0.02 < gaps[-1] < 0.03
    # There the hand-less MADAR's fitted capsules of the pair overlap: on them alone the goal
    # would be in collision.
    from hriplan.robots.descriptions.registry import load_robot_file
    from hriplan.robots.model import load_robot
    from hriplan.robots.robot_geometry import robot_parts

    robot = load_robot(load_robot_file(ROBOT).name)
    assert list(robot.joint_names) == names
    parts = {p.name: p for p in robot_parts(robot)}
    pin.forwardKinematics(robot.model, robot.data, points[-1])
    a, b = (robot.data.oMi[parts[n].joint] * parts[n].placement for n in shapes)
    overlap = coal.distance(
        parts["left_fore_arm_link"].geometry,
        coal.Transform3s(a.rotation, a.translation),
        parts["left_wrist_3_link"].geometry,
        coal.Transform3s(b.rotation, b.translation),
        coal.DistanceRequest(),
        coal.DistanceResult(),
    )
    assert overlap < 0.0


def test_the_shipped_handless_madar_urdf_is_the_built_in_madar_without_hands():
    """Every element of madar_bare.urdf is the built-in madar.urdf's, which has only hands and
    tool frames more (tools/builtin_robot_urdfs.py writes both: tests/robots/test_builtin_robot_files.py)."""
    from hriplan.robots.descriptions.registry import DATA

    shipped = ET.parse(URDF).getroot()
    built = ET.parse(DATA / "madar.urdf").getroot()
    text = lambda el: ET.tostring(el, encoding="unicode").strip()  # noqa: E731
    extra = [el for el in built if text(el) not in {text(e) for e in shipped}]
    assert [text(el) for el in shipped] == [text(el) for el in built if el not in extra]
    assert extra and all("hand" in el.get("name") or "tool" in el.get("name") for el in extra)
    assert not any("hand" in link.get("name") for link in shipped.findall("link"))


def test_a_bad_robot_is_one_line(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: bad\nurdf: nowhere.urdf\narms: {arm: {base: a, tip: b}}\n")
    for robot, message in (
        ("nope", "unknown robot 'nope'"),
        (tmp_path / "missing.yaml", "missing.yaml: no such file"),
        (bad, "missing URDF file"),
    ):
        done = run(PROBLEM, "--robot", robot, "-o", tmp_path / "x.json")
        lines = done.stderr.strip().splitlines()
        assert done.returncode == 2 and "Traceback" not in done.stderr
        assert len(lines) == 1 and lines[0].startswith("error: ") and message in lines[0], done.stderr
