"""The built-in robots are robot files shipped as package data (src/hriplan/robots/data/): their
URDFs are what the maintainer script tools/builtin_robot_urdfs.py writes, and the robots hriplan
loads from them have the kinematics of those URDFs, frame by frame."""

from __future__ import annotations

import importlib.util
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from hriplan.robots.descriptions.registry import description_of
from hriplan.robots.robot_file import resolve_file

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "src" / "hriplan" / "robots" / "data"


def _script():
    spec = importlib.util.spec_from_file_location("builtin_robot_urdfs", ROOT / "tools" / "builtin_robot_urdfs.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def script():
    return _script()


def test_the_shipped_urdfs_are_what_the_maintainer_script_writes(script):
    for relative, text in script.FILES.items():
        assert (ROOT / relative).read_text() == text() + "\n", f"{relative}: run python tools/builtin_robot_urdfs.py"


@pytest.mark.parametrize("name", ["madar", "ur5"])
def test_the_loaded_robot_has_the_generated_urdfs_kinematics(script, name):
    """Every frame (links, joints, fixed frames: tools, hands, fingers, wheels) at 50 random
    configurations, to 1e-12, between the robot hriplan loads and the URDF the script generates."""
    generated = pin.buildModelFromXML(script.FILES[f"src/hriplan/robots/data/{name}.urdf"]())
    loaded = pin.buildModelFromXML(description_of(name).urdf())
    assert list(generated.names) == list(loaded.names)
    assert [f.name for f in generated.frames] == [f.name for f in loaded.frames]
    assert np.array_equal(generated.lowerPositionLimit, loaded.lowerPositionLimit)
    assert np.array_equal(generated.upperPositionLimit, loaded.upperPositionLimit)
    assert np.array_equal(generated.velocityLimit, loaded.velocityLimit)
    pin.seed(20)
    worst = 0.0
    for _ in range(50):
        q = pin.randomConfiguration(generated)
        a, b = generated.createData(), loaded.createData()
        pin.framesForwardKinematics(generated, a, q)
        pin.framesForwardKinematics(loaded, b, q)
        for fa, fb in zip(a.oMf, b.oMf):
            worst = max(worst, float(np.abs(fa.homogeneous - fb.homogeneous).max()))
    assert worst <= 1e-12


def test_the_built_in_robots_are_read_from_their_robot_files():
    """What was Python is data: arms by SRDF group, the Allegro hands and their tool frames, the
    analytic UR5 IK, the held-object axis, Kautham's and ROS-Industrial's names, the postures
    (the SRDF's group states) and the stopping data; a built-in names no source file."""
    from hriplan.robots.descriptions.registry import BUILT_IN, DATA

    assert BUILT_IN == ("madar", "ur5") and {p.stem for p in DATA.glob("*.yaml")} == set(BUILT_IN)
    madar, ur5 = description_of("madar"), description_of("ur5")
    assert (madar.source, ur5.source) == ("", "")
    assert madar.whole_group == "both_arms" and ur5.whole_group == "arm"
    assert list(madar.arms) == ["right", "left"] and madar.base_link == "madar_base_link"
    right = madar.arms["right"]
    assert (right.prefix, right.tool_frame, right.group, right.base_link) == (
        "right_",
        "right_tool",
        "right_arm",
        "right_base_link",
    )
    assert (right.hand, right.ik, right.model, right.object_axis, right.hand_axes) == (
        "allegro",
        "ur5_analytic",
        "UR5",
        "+y",
        ("+x", "+y", "+z"),
    )
    assert madar.link_aliases == {
        "right_hand_adapter_link": "right_hand_adapter",
        "right_hand_base_link": "right_hand_palm_link",
        "right_base": "right_base_link",
        "right_tool0": "right_wrist_3_link",
        "left_base": "left_base_link",
        "left_tool0": "left_wrist_3_link",
    }
    arm = ur5.arms["arm"]
    assert (arm.prefix, arm.tool_frame, arm.hand, arm.ik, arm.object_axis) == ("", "tool", None, "ur5_analytic", "-z")
    assert ur5.link_aliases == {"base": "base_link", "tool0": "wrist_3_link"}
    assert (
        madar.postures["ready"]["right_shoulder_pan_joint"] == 1.194
        and ur5.postures["home"]["shoulder_lift_joint"] == -1.57
    )
    assert madar.base_pose == ur5.base_pose == ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    stopping = {"hasReactionTime": 0.1, "hasStoppingTime": 0.2, "hasPositionUncertainty": 0.02, "hasMovingMass": 10.0}
    assert madar.stopping == ur5.stopping == stopping


def test_the_ontology_states_the_built_in_robots_stopping_data_from_their_files():
    from hriplan.ontology.robot_individuals import robot_turtle

    turtle = robot_turtle()
    for name in ("madar", "ur5"):
        line = f"hp:{name} hp:hasReactionTime 0.1 ; hp:hasStoppingTime 0.2 ; hp:hasPositionUncertainty 0.02 ; hp:hasMovingMass 10.0 ."
        assert line in turtle
    ontology = (ROOT / "src" / "hriplan" / "ontology" / "hriplan.ttl").read_text()
    assert "hp:madar hp:" not in ontology and "hp:ur5 hp:" not in ontology


@pytest.mark.parametrize("name", ["madar", "ur5"])
def test_the_shipped_srdfs_are_what_robot_srdf_writes(name):
    from hriplan.robots.model import load_robot
    from hriplan.robots.srdf_export import srdf_text

    assert srdf_text(load_robot(name)) == (DATA / f"{name}.srdf").read_text(), f"run hriplan robot srdf {name} -o ..."


def test_a_built_in_robots_own_file_is_that_robot():
    """`hriplan robot check src/hriplan/robots/data/madar.yaml` checks the built-in MADAR; the
    file names the robot, not another robot taking its name."""
    from hriplan.robots.descriptions.registry import DATA, load_robot_file

    assert load_robot_file(DATA / "ur5.yaml") is description_of("ur5")


@pytest.mark.parametrize("name", ["madar", "ur5"])
def test_each_mesh_is_the_file_its_own_uri_resolves_to(name):
    """A URDF's meshes are resolved once per distinct name (robot_file._resolve_meshes): each
    <mesh> of the loaded robot, in order, is what `resolve_file` gives its own filename in the
    shipped URDF, an existing file."""
    shipped = [el.get("filename") for el in ET.parse(DATA / f"{name}.urdf").getroot().iter("mesh")]
    loaded = [el.get("filename") for el in ET.fromstring(description_of(name).urdf()).iter("mesh")]
    assert len(loaded) == len(shipped) >= len(set(shipped))  # MADAR names 27 files 70 times
    assert loaded == [str(resolve_file(uri, {}, DATA, "mesh")) for uri in shipped]
    assert all(Path(path).is_file() and Path(path).is_absolute() for path in loaded)
