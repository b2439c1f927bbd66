"""A task file and a problem file take a robot file where they take a robot name (relative to
them): the Panda from example-robot-data's URDF and SRDF is planned through the whole pipeline,
and each written trajectory is re-checked by the tests' own geometry and forward kinematics."""

from __future__ import annotations

import csv
import xml.etree.ElementTree as ET
from pathlib import Path

import example_robot_data
import numpy as np
import pinocchio as pin
import pytest
from typer.testing import CliRunner

from hriplan.cli.main import app
from hriplan.planner.trajectory import load_trajectory
from hriplan.robots.descriptions import registry
from independent import constraint_violations, urdf_frame_pose

DATA = Path(__file__).parents[1] / "data" / "robots"
ROBOTS = Path(example_robot_data.getModelPath("panda_description/urdf/panda.urdf")).resolve()
PANDA_URDF = ROBOTS / "panda_description" / "urdf" / "panda.urdf"


pytestmark = pytest.mark.usefixtures("robot_registry")


def forget_robot_files() -> None:
    for name in [n for n, d in registry.DESCRIPTIONS.items() if d.source]:
        del registry.DESCRIPTIONS[name]


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def urdf_limits() -> dict[str, tuple[float, float, float]]:
    root = ET.parse(PANDA_URDF).getroot()
    return {
        el.get("name"): tuple(float(el.find("limit").get(k)) for k in ("lower", "upper", "velocity"))
        for el in root.findall("joint")
        if el.get("type") == "revolute"
    }


def test_a_problem_file_names_a_robot_file_and_reaches_its_tool_pose(tmp_path):
    out = tmp_path / "reach.json"
    result = invoke("solve", DATA / "panda_reach.yaml", "-o", out)
    assert result.exit_code == 0, result.output
    forget_robot_files()
    trajectory = load_trajectory(out)  # brings the Panda back from its robot file
    assert trajectory.robot == "panda" and trajectory.robot_file == str((DATA / "panda.yaml").resolve())
    assert registry.DESCRIPTIONS["panda"].source == trajectory.robot_file
    # The last point's tool pose, by pinocchio on the URDF file itself.
    tool = urdf_frame_pose(PANDA_URDF, trajectory.joint_names, trajectory.points[-1].positions, "panda_hand_tcp")
    assert np.abs(tool.translation - (0.4, 0.3, 0.4)).max() < 1e-4
    assert np.abs(tool.rotation - pin.rpy.rpyToMatrix(3.14159, 0.0, 0.0)).max() < 1e-4
    limits = urdf_limits()
    for point in trajectory.points:
        for name, value in zip(trajectory.joint_names, point.positions):
            assert limits[name][0] - 1e-9 <= value <= limits[name][1] + 1e-9
    assert invoke("validate", out).exit_code == 0


def test_a_task_file_names_a_robot_file_and_its_plan_keeps_the_derived_constraints(tmp_path):
    result = invoke("plan", DATA / "panda_cup.yaml", "-o", tmp_path / "cup.json")
    assert result.exit_code == 0, result.output
    forget_robot_files()
    written = sorted(tmp_path.glob("cup*.json"))
    # Held from the top (as the task states) by the gripper pointing down, the cup is upright from
    # the start: no turn first (the top grasp held it lying down before the gripper's hand axes
    # were read from its URDF). Unstated, the preferred side grasp plans with a turn first.
    assert [p.name for p in written] == ["cup.json"]
    assert load_trajectory(written[0]).grasps == {"cup": "TopGrasp"}
    for path in written:
        trajectory = load_trajectory(path)
        assert trajectory.robot == "panda" and trajectory.hands == {"arm": "closed"}
        assert constraint_violations(trajectory) == []
    last = load_trajectory(tmp_path / "cup.json")
    kinds = sorted(c.spec.type for c in last.constraints)
    assert kinds == ["cylinder", "orientation"]  # the bystander's keep-out, the cup upright
    assert last.points[-1].positions[0] == pytest.approx(0.8, abs=1e-6)


def test_a_task_naming_a_missing_robot_file_is_one_line(tmp_path):
    task = tmp_path / "task.yaml"
    task.write_text((DATA / "panda_cup.yaml").read_text().replace("robot: panda.yaml", "robot: robots/none.yaml"))
    result = invoke("constraints", task)
    assert result.exit_code == 2 and result.stderr.count("\n") == 1
    assert result.stderr.strip() == f"error: {task}: robot: {tmp_path.resolve() / 'robots' / 'none.yaml'}: no such file"


def test_a_task_read_again_elsewhere_loads_its_robot_file():
    # What a service request or a re-read variant does: validate the task's data in a process
    # that never loaded the robot file (before, `unknown robot 'panda'`).
    from hriplan.tasks.load import load_task
    from hriplan.tasks.model import TaskFile

    data = load_task(DATA / "panda_cup.yaml").model_dump(mode="json", by_alias=True)
    assert data["robot"] == "panda" and data["robot_file"] == str((DATA / "panda.yaml").resolve())
    forget_robot_files()
    assert TaskFile.model_validate(data).robot == "panda"
    assert registry.DESCRIPTIONS["panda"].source == data["robot_file"]


def test_a_sweep_of_a_task_on_a_robot_file_plans_in_its_worker_processes(tmp_path):
    # Spawned workers know only the built-in robots: each loads the variant's robot file (before,
    # every row was `error: unknown robot 'panda'`).
    result = invoke(
        "sweep", DATA / "panda_cup.yaml", "-o", tmp_path / "sweep", "--vary", "objects.cup.fill_level=Partial,Empty",
        "--workers", "1", "--format", "csv", "-q",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    with open(tmp_path / "sweep" / "results.csv", newline="") as table:
        rows = list(csv.DictReader(table))
    assert sorted((r["vary.objects.cup.fill_level"], r["step"], r["status"]) for r in rows) == [
        ("Empty", "carry", "solved"),
        ("Partial", "carry", "solved"),
    ]  # (a full cup is held only from the side: across the fingers of the gripper pointing down, it lies on its side)


def test_a_ur10_from_its_urdf_alone_carries_a_container_upright_past_a_supervisor(tmp_path):
    result = invoke("plan", DATA / "ur10_container.yaml", "-o", tmp_path / "carry.json")
    assert result.exit_code == 0, result.output
    forget_robot_files()
    trajectory = load_trajectory(tmp_path / "carry.json")
    assert trajectory.robot == "ur10_carrier" and trajectory.robot_file == str((DATA / "ur10_carrier.yaml").resolve())
    assert sorted((c.spec.type, c.spec.target_link) for c in trajectory.constraints) == [
        ("cylinder", "arm_tool"),  # the supervisor's keep-out, every link
        ("orientation", "arm_tool"),  # the container upright
    ]
    assert constraint_violations(trajectory) == []
    assert trajectory.points[-1].positions[0] == pytest.approx(0.8, abs=1e-6)
