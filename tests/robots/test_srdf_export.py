"""`hriplan robot srdf`: the SRDF it writes, read here with xml.etree (chains walked on the URDF
`robot urdf` prints) and with hriplan's own SRDF reader, says what the description says; and a
robot file made from the two files by `robot init` checks and has the same arms, tool frames and
postures. A bad robot is one line, exit 2."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest
import yaml
from typer.testing import CliRunner

from hriplan.cli.main import app
from hriplan.robots.descriptions.allegro import hand_joint_name
from hriplan.robots.descriptions.registry import description_of, load_robot_file
from hriplan.robots.srdf import read_srdf
from hriplan.robots.urdf_tree import UrdfTree

pytestmark = pytest.mark.usefixtures("robot_registry")


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def _files(tmp_path, name):
    urdf, srdf = tmp_path / f"{name}.urdf", tmp_path / f"{name}.srdf"
    done = invoke("robot", "urdf", name)
    assert done.exit_code == 0, done.output
    urdf.write_text(done.stdout)
    done = invoke("robot", "srdf", name, "-o", srdf)
    assert done.exit_code == 0, done.output
    assert done.stdout.strip() == f"wrote {srdf}"
    return urdf, srdf


def _chain(urdf: ET.Element, base: str, tip: str) -> list[str]:
    """The moving joints from base to tip, walked up the URDF's parent links."""
    parent = {j.find("child").get("link"): j for j in urdf.findall("joint")}
    joints, link = [], tip
    while link != base:
        joint = parent[link]
        if joint.get("type") != "fixed":
            joints.append(joint.get("name"))
        link = joint.find("parent").get("link")
    return joints[::-1]


@pytest.mark.parametrize("name", ["madar", "ur5"])
def test_the_srdf_says_what_the_description_says(tmp_path, name):
    urdf_path, srdf_path = _files(tmp_path, name)
    urdf, srdf = ET.parse(urdf_path).getroot(), ET.parse(srdf_path).getroot()
    description = description_of(name)
    groups = {g.get("name"): g for g in srdf.findall("group")}
    for arm in description.arms.values():
        [chain] = groups[arm.group].findall("chain")
        assert chain.get("tip_link") == arm.tool_frame
        assert _chain(urdf, chain.get("base_link"), chain.get("tip_link")) == list(arm.joints)
    states = {s.get("name"): s for s in srdf.findall("group_state")}
    assert set(states) == set(description.postures)
    for posture, values in description.postures.items():
        written = {j.get("name"): float(j.get("value")) for j in states[posture].findall("joint")}
        arm_joints = [j for arm in description.arms.values() for j in arm.joints]
        assert written == {j: values.get(j, 0.0) for j in arm_joints}
    links = {link.get("name") for link in urdf.findall("link")}
    pairs = srdf.findall("disable_collisions")
    assert pairs and all({p.get("link1"), p.get("link2")} <= links for p in pairs)
    assert {p.get("reason") for p in pairs} <= {"Adjacent", "Never"}
    ends = srdf.findall("end_effector")
    # hriplan's own reader, against the same URDF
    semantic = read_srdf(srdf_path.read_text(), UrdfTree(urdf))
    tree = UrdfTree(urdf)
    for arm in description.arms.values():
        assert tree.movable(semantic.groups[arm.group]) == list(arm.joints)
    assert tree.movable(semantic.groups[description.whole_group]) == tree.movable(
        [j for arm in description.arms.values() for j in arm.joints]
    )
    if name == "madar":
        assert {e.get("parent_link") for e in ends} == {"right_tool", "left_tool"}
        for side in ("right", "left"):
            hand = [j.get("name") for j in groups[f"{side}_hand"].findall("joint")]
            assert len(hand) == 16 and hand_joint_name(f"{side}_", "joint_0.0") in hand
        # MoveIt's "Adjacent": joined by a joint; the hand's fingers were sampled at one posture only.
        reasons = {(p.get("link1"), p.get("link2")): p.get("reason") for p in pairs}
        assert reasons[("right_shoulder_link", "right_upper_arm_link")] == "Adjacent"
        assert not any("hand_link" in a and "hand_link" in b and r == "Never" for (a, b), r in reasons.items())


@pytest.mark.parametrize("name", ["madar", "ur5"])
def test_robot_init_from_the_written_urdf_and_srdf_round_trips(tmp_path, name):
    urdf, srdf = _files(tmp_path, name)
    out = tmp_path / f"{name}.yaml"
    done = invoke("robot", "init", "--urdf", urdf, "--srdf", srdf, "-o", out)
    assert done.exit_code == 0, done.output
    data = yaml.safe_load(out.read_text())
    data["stopping"] = {"reaction_time": 0.1, "stopping_time": 0.2, "position_uncertainty": 0.02, "moving_mass": 9.0}
    out.write_text(yaml.safe_dump(data))
    check = invoke("robot", "check", out)
    assert check.exit_code == 0, check.output
    original, copy = description_of(name), load_robot_file(out)
    assert sorted((a.joints, a.tool_frame) for a in copy.arms.values()) == sorted(
        (a.joints, a.tool_frame) for a in original.arms.values()
    )
    assert set(copy.postures) == set(original.postures)
    for posture, values in copy.postures.items():
        assert values == {j: original.postures[posture].get(j, 0.0) for j in values}


@pytest.mark.parametrize(
    "robot, message",
    [("nope", "unknown robot 'nope'"), ("missing.yaml", "missing.yaml: no such file")],
)
def test_a_bad_robot_is_one_line(tmp_path, robot, message):
    done = invoke("robot", "srdf", tmp_path / robot if robot.endswith(".yaml") else robot)
    assert done.exit_code == 2 and message in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and "Traceback" not in done.stderr


def test_a_bad_robot_file_is_one_line(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("name: bad\nurdf: nowhere.urdf\narms: {arm: {base: a, tip: b}}\n")
    done = invoke("robot", "srdf", path)
    assert done.exit_code == 2 and "missing URDF file" in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1
