"""The shipped examples on robots other than MADAR (examples/panda_handover_full_cup.yaml,
examples/ur10_carry_upright_supervisor.yaml, their robot files in examples/robots/) plan end to
end, and every written trajectory is checked again by code that is not hriplan's: the derived
constraints and the ISO/TS 15066 speeds by tests/independent.py, the tool's last pose by
pinocchio loading the URDF here, placed where the robot file stands the robot."""

from __future__ import annotations

import functools
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
import pytest
import yaml
from typer.testing import CliRunner

from hriplan.cli.main import app
from hriplan.planner.trajectory import load_trajectory
from hriplan.robots.robot_file import resolve_file
from hriplan.safety.policy import default_policy
from independent import clearance, constraint_violations, trajectory_speed_margins, urdf_frame_pose

EXAMPLES = Path(__file__).parents[2] / "examples"

pytestmark = pytest.mark.usefixtures("module_robot_registry")


@functools.cache
def planned(task: str, out: Path) -> dict[str, object]:
    """`hriplan plan` on a shipped example (once per process): step -> trajectory."""
    result = CliRunner().invoke(app, ["plan", str(EXAMPLES / task), "-o", str(out / "plan.json"), "-q"])
    assert result.exit_code == 0, result.output
    return {t.step: t for t in map(load_trajectory, sorted(out.glob("plan*.json")))}


@pytest.fixture(scope="module")
def out(tmp_path_factory):
    return tmp_path_factory.mktemp("shipped")


def urdf_tool_pose(robot_file: Path, trajectory, tool: str, offset: np.ndarray | None = None) -> pin.SE3:
    """The tool frame at the trajectory's last point: pinocchio on the URDF the robot file names,
    placed at the file's base pose (its own reading of the YAML)."""
    spec = yaml.safe_load(robot_file.read_text())
    urdf = resolve_file(spec["urdf"], {}, robot_file.parent, "URDF file")
    base = pin.SE3(np.eye(3), np.array(spec.get("base_pose", {}).get("xyz", [0.0, 0.0, 0.0]), dtype=float))
    at = base * urdf_frame_pose(urdf, trajectory.joint_names, trajectory.points[-1].positions, tool)
    return at if offset is None else at * pin.SE3(np.eye(3), offset)


def checked_independently(trajectory, task_file: Path) -> None:
    assert constraint_violations(trajectory) == []
    roles = {h["name"]: h["role"] for h in yaml.safe_load(task_file.read_text())["humans"]}
    policy = default_policy(trajectory.robot, trajectory.scene.humans, roles)
    speed, _gap = trajectory_speed_margins(trajectory, policy, padding=0.05, factor=0.95)
    assert speed >= -1e-3  # never faster towards a person than ISO/TS 15066 allows them


def test_the_panda_hands_a_full_cup_upright_to_the_receiver(out):
    trajectories = planned("panda_handover_full_cup.yaml", out / "panda")
    assert sorted(trajectories) == ["hand_over", "hand_over_release"]
    hand_over, release = trajectories["hand_over"], trajectories["hand_over_release"]
    assert (
        hand_over.robot == "franka_panda"
        and hand_over.hands == {"arm": "closed"}
        and release.hands == {"arm": "release"}
    )
    assert sorted(c.spec.id for c in hand_over.constraints) == [
        "approach_cone_rita",
        "exclusion_box_rita",
        "shared_workspace_rita",
        "upright_cup",
    ]
    for trajectory in trajectories.values():
        checked_independently(trajectory, EXAMPLES / "panda_handover_full_cup.yaml")
    # Where the goal says: the cup upright, 19 cm in front of rita's palm, its axis across the
    # direction the fingers close (the finger joint's axis, read from the URDF here).
    tool = urdf_tool_pose(EXAMPLES / "robots" / "panda.yaml", hand_over, "panda_hand_tcp")
    cup = tool * pin.SE3(hand_over.scene.attached[0].grasp.matrix())
    assert cup.rotation[:, 2] @ (0.0, 0.0, 1.0) > np.cos(0.05)
    assert abs(tool.rotation[:, 1] @ cup.rotation[:, 2]) < 1e-6  # panda_finger_joint1 slides along the tcp's y
    palm = np.array([0.65, 0.05, 1.05])
    assert 0.15 < np.linalg.norm(cup.translation - palm) < 0.25
    # The gripper opens and backs away, clear of the cup it left in rita's hand.
    last = urdf_tool_pose(EXAMPLES / "robots" / "panda.yaml", release, "panda_hand_tcp")
    backed = tool.rotation.T @ (last.translation - tool.translation)
    assert backed[2] < -0.05 and np.linalg.norm(backed[:2]) < 1e-3
    cup_solid = coal.Cylinder(0.035, 0.09)
    assert clearance(release.model_copy(update={"points": release.points[-1:]}), cup_solid, cup)[0] > 0.0


def test_the_ur10_carries_the_container_upright_past_the_supervisor(out):
    trajectories = planned("ur10_carry_upright_supervisor.yaml", out / "ur10")
    assert sorted(trajectories) == ["carry", "carry_release"]
    carry = trajectories["carry"]
    assert carry.robot == "ur10_on_stand" and carry.robot_file == str((EXAMPLES / "robots" / "ur10.yaml").resolve())
    assert sorted((c.spec.type, c.spec.id) for c in carry.constraints) == [
        ("cylinder", "keep_out_sam"),
        ("orientation", "upright_tray"),
    ]
    for trajectory in trajectories.values():
        checked_independently(trajectory, EXAMPLES / "ur10_carry_upright_supervisor.yaml")
    # The tool (12 cm out of tool0) ends pointing down with the tray standing at the goal
    # (released 4 cm above where it will stand).
    tool = urdf_tool_pose(EXAMPLES / "robots" / "ur10.yaml", carry, "tool0", np.array([0.0, 0.0, 0.12]))
    assert tool.rotation[:, 2] @ (0.0, 0.0, -1.0) > np.cos(0.05)
    assert np.abs(tool.translation - (0.0, 0.9, 0.77 + 0.04)).max() < 1e-3
    # No link comes within the supervisor's keep-out cylinder (radius 0.5 m), by coal on meshes.
    sam = pin.SE3(np.eye(3), np.array([1.3, 1.1, 1.0]))
    for trajectory in trajectories.values():
        assert clearance(trajectory, coal.Cylinder(0.5, 2.0), sam)[0] > 0.0
