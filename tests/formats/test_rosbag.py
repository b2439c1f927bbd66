"""`hriplan export`: planned steps as a ROS 2 bag, read back by rosbags' own reader.

The bag is read with `AnyReader`, which builds its message types from the definitions the bag
carries (not from hriplan's), and compared with the trajectory files as plain JSON: every joint
name and value, times to 1e-9 s, a topic per controller, the fingers at the posture the robot's
description gives, MoveIt's DisplayTrajectory. Bad input is one line and exit 2, nothing written.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from rosbags.highlevel import AnyReader
from typer.testing import CliRunner

from hriplan.cli.main import app
from hriplan.robots.descriptions.description import hand_model
from hriplan.robots.descriptions.registry import description_of

EXAMPLES = Path(__file__).parents[2] / "examples"
CAN_STEPS = ("take_can", "place_can", "place_can_release")
ARM = "/right_arm_controller/joint_trajectory"
RIGHT_HAND = "/right_hand_controller/joint_trajectory"
LEFT_HAND = "/left_hand_controller/joint_trajectory"
DISPLAY = "/display_planned_path"


def cli(*args: object):
    result = CliRunner().invoke(app, [str(a) for a in args])
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
    return result


@pytest.fixture(scope="module")
def planned(tmp_path_factory) -> Path:
    """The demo's three steps (right arm) and the peg-in-hole's one step (both arms)."""
    where = tmp_path_factory.mktemp("planned")
    for task, stem in (("handover_full_can.yaml", "can"), ("peg_in_hole_supervised.yaml", "peg")):
        result = cli("plan", EXAMPLES / task, "-o", where / f"{stem}.json")
        assert result.exit_code == 0, result.stderr
    return where


def can_files(planned: Path) -> list[Path]:
    return [planned / f"can.{step}.json" for step in CAN_STEPS]


def read_bag(path: Path) -> tuple[dict[str, str], dict[str, list[tuple[int, object]]]]:
    """Topic -> message type, and topic -> (log time ns, message) in the bag's order."""
    with AnyReader([path]) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        messages: dict[str, list[tuple[int, object]]] = {topic: [] for topic in types}
        for connection, stamp, raw in reader.messages():
            messages[connection.topic].append((stamp, reader.deserialize(raw, connection.msgtype)))
    return types, messages


def seconds(time: object) -> float:
    return time.sec + time.nanosec * 1e-9


def fields(message: object) -> list[str]:
    return [name for name in message.__dataclass_fields__ if not name.startswith("__")]


def fingers(arm: str, posture: str) -> dict[str, float]:
    """The finger joints of MADAR's hand on `arm` at `posture`, as its description gives them."""
    description = description_of("madar").arms[arm]
    hand = hand_model(description.hand)
    return {hand.joint_name(description.prefix, j): v for j, v in hand.joint_values(posture).items()}


@pytest.fixture(scope="module")
def can_bag(planned: Path, tmp_path_factory):
    out = tmp_path_factory.mktemp("bag") / "can_bag"
    result = cli("export", *can_files(planned), "-o", out)
    assert result.exit_code == 0, result.stderr
    assert f"wrote {out} (rosbag2, MCAP storage): 3 step(s)" in result.stdout
    steps = [json.loads(p.read_text()) for p in can_files(planned)]
    return out, steps, *read_bag(out)


def test_one_topic_per_controller_and_the_display(can_bag):
    out, _, types, messages = can_bag
    jt = "trajectory_msgs/msg/JointTrajectory"
    # the left arm never moves in the demo: no topic; both hands have a posture in every step
    assert types == {ARM: jt, RIGHT_HAND: jt, LEFT_HAND: jt, DISPLAY: "moveit_msgs/msg/DisplayTrajectory"}
    assert {t: len(m) for t, m in messages.items()} == {ARM: 3, RIGHT_HAND: 3, LEFT_HAND: 3, DISPLAY: 1}
    assert sorted(p.name for p in out.iterdir()) == ["can_bag.mcap", "metadata.yaml"]
    assert not list(out.parent.glob(".*.tmp"))


def test_arm_messages_are_the_files_stamped_at_each_steps_start(can_bag):
    _, steps, _, messages = can_bag
    start = 0.0
    for step, (log_time, message) in zip(steps, messages[ARM]):
        assert abs(seconds(message.header.stamp) - start) < 1e-9
        assert log_time == message.header.stamp.sec * 10**9 + message.header.stamp.nanosec
        assert message.joint_names == step["joint_names"] == [f"right_{j}" for j in UR5_JOINTS]
        assert len(message.points) == len(step["points"])
        for got, want in zip(message.points, step["points"]):
            assert got.positions.tolist() == want["positions"]
            assert got.velocities.tolist() == want["velocities"]
            assert got.accelerations.tolist() == want["accelerations"]
            assert abs(seconds(got.time_from_start) - want["time_from_start"]) <= 1e-9
            assert 0 <= got.time_from_start.nanosec < 10**9
        start += step["points"][-1]["time_from_start"]


UR5_JOINTS = (
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
)


def test_hand_topics_hold_the_fingers_of_each_steps_posture(can_bag):
    _, steps, _, messages = can_bag
    assert [s["hands"] for s in steps] == [{"left": "open", "right": "power"}] * 2 + [
        {"left": "open", "right": "release"}
    ]
    for topic, arm in ((RIGHT_HAND, "right"), (LEFT_HAND, "left")):
        for step, (_, message) in zip(steps, messages[topic]):
            want = fingers(arm, step["hands"][arm])
            assert message.joint_names == list(want) and len(want) == 16
            duration = step["points"][-1]["time_from_start"]
            assert [seconds(p.time_from_start) for p in message.points] == pytest.approx([0.0, duration], abs=1e-9)
            for point in message.points:
                assert point.positions.tolist() == list(want.values())
                assert not point.velocities.any() and not point.accelerations.any()
    # the Allegro's power grasp bends the index's second joint 1.1 rad; release straightens the
    # fingers and keeps the thumb opposed (1.3 rad)
    power = dict(zip(messages[RIGHT_HAND][0][1].joint_names, messages[RIGHT_HAND][0][1].points[0].positions))
    release = dict(zip(messages[RIGHT_HAND][2][1].joint_names, messages[RIGHT_HAND][2][1].points[0].positions))
    assert power["right_hand_joint_1.0"] == 1.1 and release["right_hand_joint_1.0"] == 0.0
    assert release["right_hand_joint_12.0"] == 1.3


def test_display_trajectory_is_the_whole_motion_for_moveit(can_bag):
    _, steps, _, messages = can_bag
    [(log_time, display)] = messages[DISPLAY]
    assert log_time == 0 and display.model_id == "madar"
    # moveit_msgs' fields (moveit_msgs/msg/*.msg), as the bag's own definitions have them
    assert fields(display) == ["model_id", "trajectory", "trajectory_start"]
    assert fields(display.trajectory_start) == [
        "joint_state",
        "multi_dof_joint_state",
        "attached_collision_objects",
        "is_diff",
    ]
    assert len(display.trajectory) == 3
    start = 0.0
    for step, robot_trajectory in zip(steps, display.trajectory):
        trajectory = robot_trajectory.joint_trajectory
        hands = {}
        for arm, posture in step["hands"].items():
            hands |= fingers(arm, posture)
        assert trajectory.joint_names == step["joint_names"] + list(hands)
        assert abs(seconds(trajectory.header.stamp) - start) < 1e-9
        n = len(step["joint_names"])
        for got, want in zip(trajectory.points, step["points"], strict=True):
            assert got.positions[:n].tolist() == want["positions"]
            assert got.positions[n:].tolist() == list(hands.values())
            assert got.velocities[:n].tolist() == want["velocities"] and not got.velocities[n:].any()
            assert abs(seconds(got.time_from_start) - want["time_from_start"]) <= 1e-9
        assert robot_trajectory.multi_dof_joint_trajectory.joint_names == []
        start += step["points"][-1]["time_from_start"]
    state = display.trajectory_start
    first = dict(steps[0]["start"])
    for arm, posture in steps[0]["hands"].items():
        first |= fingers(arm, posture)
    assert state.joint_state.name == list(first) and len(first) == 12 + 32
    assert state.joint_state.position.tolist() == list(first.values())
    assert state.is_diff is False and state.attached_collision_objects == []


def test_a_two_arm_step_goes_to_each_arms_controller(planned, tmp_path):
    step = json.loads((planned / "peg.json").read_text())
    assert len(step["joint_names"]) == 12
    result = cli("export", planned / "peg.json", "-o", tmp_path / "peg_bag")
    assert result.exit_code == 0, result.stderr
    types, messages = read_bag(tmp_path / "peg_bag")
    for arm in ("left", "right"):
        [(_, message)] = messages[f"/{arm}_arm_controller/joint_trajectory"]
        assert message.joint_names == [f"{arm}_{j}" for j in UR5_JOINTS]
        columns = [step["joint_names"].index(j) for j in message.joint_names]
        for got, want in zip(message.points, step["points"], strict=True):
            assert got.positions.tolist() == [want["positions"][c] for c in columns]
            assert got.velocities.tolist() == [want["velocities"][c] for c in columns]
            assert got.accelerations.tolist() == [want["accelerations"][c] for c in columns]
        [(_, hand)] = messages[f"/{arm}_hand_controller/joint_trajectory"]
        assert hand.points[0].positions.tolist() == list(fingers(arm, "power").values())
    assert len(types) == 5


def test_a_controller_on_another_topic(planned, tmp_path):
    result = cli(
        "export", planned / "peg.json", "-o", tmp_path / "b", "--topic", "right_arm_controller=/madar/right/follow"
    )
    assert result.exit_code == 0, result.stderr
    types, _ = read_bag(tmp_path / "b")
    assert "/madar/right/follow" in types and "/right_arm_controller/joint_trajectory" not in types
    assert "/left_arm_controller/joint_trajectory" in types


def _ur5_step(planned: Path, where: Path) -> Path:
    """The demo's first step relabelled as the UR5's (same joint count): another robot's file."""
    data = json.loads((planned / "can.take_can.json").read_text())
    data |= {"robot": "ur5", "joint_names": list(UR5_JOINTS), "hands": {}, "start": {}}
    path = where / "ur5.json"
    path.write_text(json.dumps(data))
    return path


BAD = {
    "missing": (lambda p, d: [d / "nope.json"], "nope.json: no such file"),
    "not_a_trajectory": (lambda p, d: [EXAMPLES / "handover_full_can.yaml"], "handover_full_can.yaml"),
    "mixed_robots": (lambda p, d: [p / "can.take_can.json", _ur5_step(p, d)], "a bag holds one robot's motion"),
    "out_of_order": (lambda p, d: [p / "can.place_can.json", p / "can.take_can.json"], "give a task's steps in order"),
}


@pytest.mark.parametrize("case", BAD, ids=list(BAD))
def test_bad_trajectories_are_one_line(case, planned, tmp_path):
    files, says = BAD[case]
    result = cli("export", *files(planned, tmp_path), "-o", tmp_path / "out_bag")
    lines = result.stderr.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1 and says in lines[0], result.stderr
    assert lines[0].startswith("error: ") and "Traceback" not in result.stderr
    assert not (tmp_path / "out_bag").exists() and not list(tmp_path.glob(".*.tmp"))


def test_an_existing_bag_is_replaced_only_with_force(planned, tmp_path):
    out = tmp_path / "out_bag"
    assert cli("export", planned / "peg.json", "-o", out).exit_code == 0
    again = cli("export", *can_files(planned), "-o", out)
    assert again.exit_code == 2 and again.stderr.strip() == f"error: --output {out}: exists; give --force to replace it"
    assert "/left_arm_controller/joint_trajectory" in read_bag(out)[0]  # still the peg's bag
    forced = cli("export", *can_files(planned), "-o", out, "--force")
    assert forced.exit_code == 0, forced.stderr
    types, messages = read_bag(out)
    assert "/left_arm_controller/joint_trajectory" not in types and len(messages[ARM]) == 3
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out_bag"]
    # --force replaces a bag, never another directory
    (tmp_path / "notes").mkdir()
    (tmp_path / "notes" / "keep.txt").write_text("mine")
    refused = cli("export", planned / "peg.json", "-o", tmp_path / "notes", "--force")
    assert refused.exit_code == 2 and "not a ROS 2 bag (no metadata.yaml); not replacing it" in refused.stderr
    assert [p.name for p in (tmp_path / "notes").iterdir()] == ["keep.txt"]


def test_a_bag_is_not_named_like_a_ros1_bag_file(planned, tmp_path):
    result = cli("export", planned / "peg.json", "-o", tmp_path / "peg.bag")
    assert result.exit_code == 2 and "name it without .bag" in result.stderr
    assert not (tmp_path / "peg.bag").exists()


@pytest.mark.parametrize(
    "topic, says",
    [
        ("arm_controller=/x", "--topic arm_controller: robot 'madar' has controllers right_arm_controller, "),
        ("right_arm_controller=relative", "not an absolute ROS topic name"),
        ("right_arm_controller=/display_planned_path", "two controllers would share the topic /display_planned_path"),
        ("right_arm_controller", "--topic takes CONTROLLER=TOPIC"),
    ],
)
def test_bad_topics_are_one_line(topic, says, planned, tmp_path):
    result = cli("export", planned / "peg.json", "-o", tmp_path / "out_bag", "--topic", topic)
    assert result.exit_code == 2 and says in result.stderr and len(result.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "out_bag").exists()


def test_controllers_come_from_the_description_a_grippers_too(module_robot_registry):
    from hriplan.formats.rosbag import controllers, finger_values
    from hriplan.robots.descriptions.registry import load_robot_file

    panda = load_robot_file(EXAMPLES / "robots" / "panda.yaml")
    found = {c.name: (c.topic, c.joints) for c in controllers(panda)}
    assert found == {
        "arm_controller": ("/arm_controller/joint_trajectory", tuple(f"panda_joint{k}" for k in range(1, 8))),
        "arm_hand_controller": (
            "/arm_hand_controller/joint_trajectory",
            ("panda_finger_joint1", "panda_finger_joint2"),
        ),
    }
    # the robot file's gripper: open 0.04 m per finger, closed 0
    assert finger_values(panda, "arm", "release") == {"panda_finger_joint1": 0.04, "panda_finger_joint2": 0.04}
    assert finger_values(panda, "arm", "closed") == {"panda_finger_joint1": 0.0, "panda_finger_joint2": 0.0}


def test_a_failed_write_leaves_the_old_bag_and_no_temporary(planned, tmp_path, monkeypatch):
    from hriplan.cli import outputs
    from hriplan.formats import rosbag

    out = tmp_path / "out_bag"
    assert cli("export", planned / "peg.json", "-o", out).exit_code == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}

    def broken(self, connection, timestamp, data):
        raise OSError("disk full")

    monkeypatch.setattr(rosbag.Writer, "write", broken)
    with pytest.raises(OSError, match="disk full"):
        rosbag.export_bag(can_files(planned), out, force=True)
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out_bag"]
    # an interrupted export: Ctrl-C removes the bag being made beside the output
    half = tmp_path / ".out_bag.0123456789abcdef.tmp" / "out_bag"
    half.mkdir(parents=True)
    (half / "metadata.yaml").write_text("half")
    monkeypatch.setattr(outputs, "_NAMED", [])
    outputs.directory_output(out)
    outputs.remove_partial_outputs()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out_bag"]
