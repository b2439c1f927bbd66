"""`hriplan validate` of a bare ROS trajectory_msgs/JointTrajectory (YAML as `ros2 topic echo
--once` prints it, or JSON) in a task step or a planning problem, and of positions and velocities
that must agree (the spline a controller follows between points).

The messages are written here from `hriplan plan`'s trajectories by this file's own code, not
by hriplan's; speeds and limits the refusals name are recomputed here from the URDF's text."""

from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from typer.testing import CliRunner

from hriplan.cli.main import app
from hriplan.planner.trajectory import TrajectoryFile
from hriplan.robots.descriptions.registry import description_of
from independent import constraint_violations

ROOT = Path(__file__).parents[2]
TASK = ROOT / "examples" / "handover_full_can.yaml"
PROBLEM = ROOT / "benchmarks" / "scenarios" / "b_madar_handover.json"


def invoke(*args) -> tuple[int, str, str]:
    result = CliRunner().invoke(app, [str(a) for a in args])
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
    return result.exit_code, result.stdout, result.stderr


def ros2_echo_yaml(trajectory: dict, order: list[int] | None = None, t0: float = 0.0) -> str:
    """The trajectory as `ros2 topic echo /topic --once` prints a JointTrajectory: block style,
    times as sec and nanosec, ending in `---`; its joints in `order` (default: as written)."""
    order = order if order is not None else list(range(len(trajectory["joint_names"])))
    lines = ["header:", "  stamp:", "    sec: 1764754000", "    nanosec: 123", "  frame_id: ''", "joint_names:"]
    lines += [f"- {trajectory['joint_names'][k]}" for k in order]
    lines.append("points:")
    for point in trajectory["points"]:
        nanoseconds = round((point["time_from_start"] + t0) * 1e9)
        lines.append("- positions:")
        lines += [f"  - {point['positions'][k]!r}" for k in order]
        lines.append("  velocities:")
        lines += [f"  - {point['velocities'][k]!r}" for k in order]
        lines += ["  accelerations: []", "  effort: []", "  time_from_start:"]
        lines += [f"    sec: {nanoseconds // 10**9}", f"    nanosec: {nanoseconds % 10**9}"]
    return "\n".join(lines) + "\n---\n"


def as_message(trajectory: dict) -> dict:
    """The same message as JSON data."""
    points = [
        {
            "positions": p["positions"],
            "velocities": p["velocities"],
            "accelerations": p["accelerations"],
            "effort": [],
            "time_from_start": {"sec": int(p["time_from_start"]), "nanosec": round(p["time_from_start"] % 1 * 1e9)},
        }
        for p in trajectory["points"]
    ]
    return {
        "header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": ""},
        "joint_names": trajectory["joint_names"],
        "points": points,
    }


def urdf_speed_limits(robot: str) -> dict[str, float]:
    """Each joint's velocity limit as the URDF's text gives it."""
    root = ET.fromstring(description_of(robot).urdf())
    return {
        j.get("name"): float(j.find("limit").get("velocity")) for j in root.iter("joint") if j.find("limit") is not None
    }


def checks(stdout: str) -> list[str]:
    """What validate found, without its notes (they say how a message was placed)."""
    return [line for line in stdout.splitlines() if not line.startswith("note: ")]


@pytest.fixture(scope="module")
def planned(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("plan")
    code, _, stderr = invoke("plan", TASK, "-o", out / "can.json", "-q")
    assert code == 0, stderr
    return out


def test_a_planned_step_echoed_by_ros2_validates_as_its_own_file(planned, tmp_path):
    data = json.loads((planned / "can.take_can.json").read_text())
    message = tmp_path / "take_can.yaml"
    message.write_text(ros2_echo_yaml(data))
    code, own, _ = invoke("validate", planned / "can.take_can.json", "--task", TASK, "-q")
    assert code == 0
    code, out, stderr = invoke("validate", message, "--task", TASK, "--step", "take_can", "-q")
    assert code == 0, stderr
    assert checks(out) == checks(own)  # the same constraints, margins, states, joints and ISO/TS 15066 speeds
    assert "approach_cone_alice" in out and "speed and separation (ISO/TS 15066" in out
    omitted = [j for j in data["start"] if j not in data["joint_names"]]
    assert omitted and f"note: joints the message omits stay at the start: {', '.join(omitted)}" in out
    assert constraint_violations(TrajectoryFile.model_validate(data)) == []  # the file keeps them, by other code

    # Its joints in another order, as JSON, sent half a second ahead: the same checks.
    reordered = tmp_path / "take_can_reordered.yaml"
    reordered.write_text(ros2_echo_yaml(data, order=[5, 3, 1, 0, 2, 4], t0=0.5))
    code, out, stderr = invoke("validate", reordered, "--task", TASK, "--step", "take_can", "-q")
    assert code == 0 and checks(out) == checks(own), stderr
    assert "note: times are counted from the first point's time_from_start, 0.5 s" in out
    as_json = tmp_path / "take_can.json"
    as_json.write_text(json.dumps(as_message(data)))
    code, out, _ = invoke("validate", as_json, "--task", TASK, "--step", "take_can", "-q")
    assert code == 0 and checks(out) == checks(own)


def test_a_jump_of_5_rad_per_s_between_points_is_refused_with_the_joint_time_and_speed(planned, tmp_path):
    # Before: a point moved 0.05 rad, 10 ms from its neighbours, passed (only the written velocities were checked).
    data = json.loads((planned / "can.take_can.json").read_text())
    k = len(data["points"]) // 2
    data["points"][k]["positions"][0] += 0.05
    before, at = data["points"][k - 1], data["points"][k]
    dt = at["time_from_start"] - before["time_from_start"]
    speed = abs(at["positions"][0] - before["positions"][0]) / dt  # recomputed here
    joint = data["joint_names"][0]
    limit = urdf_speed_limits("madar")[joint]
    assert speed > limit
    for path in (tmp_path / "jump.json", tmp_path / "jump.yaml"):
        path.write_text(json.dumps(data) if path.suffix == ".json" else ros2_echo_yaml(data))
        extra = () if path.suffix == ".json" else ("--step", "take_can")
        code, out, stderr = invoke("validate", path, "--task", TASK, *extra, "-q")
        assert code == 1 and "joints: EXCEEDED" in out
        line = stderr.strip()
        assert "\n" not in line and line.startswith("invalid: beyond a joint's limits: ") and joint in line
        said = re.search(
            r"moves [-+]\d\.\d+ rad in (\d\.\d+) s from t=(\d\.\d+) s: the positions imply (\d+\.\d+) rad/s, "
            r"(\d+\.\d+)x its limit (\d+\.\d+) rad/s",
            line,
        )
        assert said, line
        assert float(said[3]) == pytest.approx(speed, rel=2e-2) and float(said[5]) == pytest.approx(limit, abs=1e-3)
        assert float(said[2]) in (round(before["time_from_start"], 3), round(at["time_from_start"], 3))


def test_velocities_that_disagree_with_the_positions_are_refused(planned, tmp_path):
    # Positions as planned, velocities written three times too large: the controller's spline
    # through both overshoots between points, beyond the joints' speed limits.
    data = json.loads((planned / "can.take_can.json").read_text())
    for point in data["points"]:
        point["velocities"] = [3.0 * v for v in point["velocities"]]
    limits = urdf_speed_limits("madar")
    assert max(abs(v) / limits[j] for p in data["points"] for j, v in zip(data["joint_names"], p["velocities"])) > 1.0
    message = tmp_path / "fast.yaml"
    message.write_text(ros2_echo_yaml(data))
    code, out, stderr = invoke("validate", message, "--task", TASK, "--step", "take_can", "-q")
    assert code == 1 and "joints: EXCEEDED" in out
    assert "the spline through positions and velocities reaches" in stderr


def test_a_motion_into_the_table_in_a_later_step_is_refused(planned, tmp_path):
    # place_can, after take_can moved the right arm: the message gives the right arm, and an
    # extra smooth motion at the end (velocities agreeing) swings the hand down into the table.
    data = json.loads((planned / "can.place_can.json").read_text())
    last, seconds, count = data["points"][-1], 2.0, 40
    for i in range(1, count + 1):
        s = i / count
        positions, velocities = list(last["positions"]), [0.0] * len(last["positions"])
        positions[0] -= 0.6 * (3 * s**2 - 2 * s**3)
        velocities[0] = -0.6 * 6 * s * (1 - s) / seconds
        data["points"].append(
            {
                "time_from_start": last["time_from_start"] + s * seconds,
                "positions": positions,
                "velocities": velocities,
                "accelerations": [0.0] * 6,
            }
        )
    assert any(
        "upright_coke_can" in b for b in constraint_violations(TrajectoryFile.model_validate(data))
    )  # by other code
    message = tmp_path / "into_table.yaml"
    message.write_text(ros2_echo_yaml(data))
    code, out, stderr = invoke("validate", message, "--task", TASK, "--step", "place_can", "-q")
    assert code == 1
    assert re.search(r"upright_coke_can +worst margin \+0\.\d+ VIOLATED", out) and "joints: kept" in out
    assert "- table at dense state" in out
    line = stderr.strip()
    assert "\n" not in line and line.startswith("invalid: constraint upright_coke_can violated; ") and "table" in line


def test_a_solved_problem_echoed_by_ros2_validates_in_its_problem(tmp_path):
    code, _, stderr = invoke("solve", PROBLEM, "--seed", "1", "-o", tmp_path / "solved.json")
    assert code == 0, stderr
    data = json.loads((tmp_path / "solved.json").read_text())
    message = tmp_path / "solved.yaml"
    message.write_text(ros2_echo_yaml(data))
    code, own, _ = invoke("validate", tmp_path / "solved.json")
    code, out, stderr = invoke("validate", message, "--problem", PROBLEM)
    assert code == 0, stderr
    assert checks(out) == checks(own) and "approach_cone" in out


def _message(**changes) -> str:
    data = {
        "joint_names": ["right_shoulder_pan_joint", "right_elbow_joint"],
        "points": [
            {"positions": [1.0, -1.6], "velocities": [0.0, 0.0], "time_from_start": {"sec": 0, "nanosec": 0}},
            {"positions": [1.01, -1.6], "velocities": [0.0, 0.0], "time_from_start": {"sec": 0, "nanosec": 100000000}},
        ],
    }
    for dotted, value in changes.items():
        *parents, last = dotted.split("__")
        node = data
        for key in parents:
            node = node[int(key)] if isinstance(node, list) else node[key]
        if value is None:
            del node[last]
        else:
            node[last] = value
    return json.dumps(data)


BAD = [
    (
        "unknown_joint",
        _message(joint_names=["right_shoulder_pan_joint", "right_knee_joint"]),
        ("--task", TASK, "--step", "take_can"),
        "'right_knee_joint' is not a joint of madar",
    ),
    (
        "short_positions",
        _message(points__1__positions=[1.0]),
        ("--task", TASK, "--step", "take_can"),
        "points.1.positions: 1 values for 2 joint_names",
    ),
    (
        "no_velocities",
        _message(points__0__velocities=[]),
        ("--problem", PROBLEM),
        "points.0.velocities: 0 values for 2 joint_names",
    ),
    (
        "no_time",
        _message(points__1__time_from_start=None),
        ("--problem", PROBLEM),
        "points.1.time_from_start: field required",
    ),
    (
        "times_back",
        _message(points__1__time_from_start={"sec": 0, "nanosec": 0}),
        ("--problem", PROBLEM),
        "does not come after",
    ),
    ("no_setting", _message(), (), "give where it moves"),
    ("no_step", _message(), ("--task", TASK), "--task needs --step"),
    (
        "unknown_step",
        _message(),
        ("--task", TASK, "--step", "fly"),
        "has no step 'fly'; its steps: take_can, place_can",
    ),
    (
        "earlier_step_moved_it",
        _message(joint_names=["left_shoulder_pan_joint", "left_elbow_joint"]),
        ("--task", TASK, "--step", "place_can"),
        "omits right_shoulder_pan_joint, which an earlier step moves",
    ),
]


@pytest.mark.parametrize("name,text,options,says", BAD, ids=[b[0] for b in BAD])
def test_a_bad_message_is_one_line_and_exit_2(tmp_path, name, text, options, says):
    message = tmp_path / "message.json"
    message.write_text(text)
    code, out, stderr = invoke("validate", message, *options, "-q")
    assert code == 2 and out == ""
    assert stderr.count("\n") == 1 and stderr.startswith("error: ") and says.lower() in stderr.lower(), stderr


def test_a_stream_of_several_messages_is_one_line_and_exit_2(planned, tmp_path):
    data = json.loads((planned / "can.take_can.json").read_text())
    stream = tmp_path / "echo.yaml"
    stream.write_text(ros2_echo_yaml(data) * 2)  # ros2 topic echo without --once
    code, _, stderr = invoke("validate", stream, "--task", TASK, "--step", "take_can")
    assert code == 2 and "holds 2 messages (separated by ---); give one (ros2 topic echo --once)" in stderr
    code, _, stderr = invoke("validate", planned / "can.take_can.json", "--step", "take_can")
    assert code == 2 and "is a trajectory file" in stderr and stderr.count("\n") == 1
