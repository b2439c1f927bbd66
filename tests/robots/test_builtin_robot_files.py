"""The built-in robots are robot files shipped as package data (src/hriplan/robots/data/): their
URDFs are what the maintainer script tools/builtin_robot_urdfs.py writes, and the robots hriplan
loads from them have the kinematics of those URDFs, frame by frame."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from hriplan.robots.descriptions.registry import description_of

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
