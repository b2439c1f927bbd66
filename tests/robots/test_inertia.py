"""Every link of an exported URDF has a physical inertia (robots/inertia.py, `hriplan robot urdf`).

Checked on the XML with numpy alone: a positive mass, a positive definite inertia whose principal
moments keep the triangle inequality; the masses of solid primitives from their textbook
formulas (parallel axes written here); and pinocchio loads every exported file.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from typer.testing import CliRunner

from hriplan.cli.main import app
from hriplan.robots.inertia import DENSITY, FRAME_MASS, with_inertias

ROBOTS = ("madar", "ur5", str(Path(__file__).parents[2] / "examples" / "robots" / "panda.yaml"))


@pytest.fixture(scope="module")
def exported(module_robot_registry) -> dict[str, str]:
    texts = {}
    for robot in ROBOTS:
        result = CliRunner().invoke(app, ["robot", "urdf", robot])
        assert result.exit_code == 0, result.stderr
        texts[Path(robot).stem] = result.stdout
    return texts


def inertials(urdf: str) -> dict[str, tuple[float, np.ndarray, np.ndarray]]:
    """Link -> (mass, centre of mass, inertia matrix) as the URDF states them."""
    found = {}
    for link in ET.fromstring(urdf).findall("link"):
        el = link.find("inertial")
        if el is None:
            found[link.get("name")] = None
            continue
        a = {k: float(v) for k, v in el.find("inertia").attrib.items()}
        matrix = np.array(
            [[a["ixx"], a["ixy"], a["ixz"]], [a["ixy"], a["iyy"], a["iyz"]], [a["ixz"], a["iyz"], a["izz"]]]
        )
        origin = el.find("origin")
        com = np.array([float(v) for v in origin.get("xyz").split()]) if origin is not None else np.zeros(3)
        found[link.get("name")] = (float(el.find("mass").get("value")), com, matrix)
    return found


@pytest.mark.parametrize("robot", ["madar", "ur5", "panda"])
def test_every_link_has_a_physical_inertia_and_pinocchio_loads_it(exported, robot):
    urdf = exported[robot]
    links = inertials(urdf)
    assert links and not [name for name, i in links.items() if i is None]
    for name, (mass, _, matrix) in links.items():
        moments = np.sort(np.linalg.eigvalsh(matrix))
        assert mass > 0, name
        assert moments[0] > 0, (name, moments)
        assert moments[0] + moments[1] >= moments[2] * (1 - 1e-9), (name, moments)
    model = pin.buildModelFromXML(urdf)
    assert sum(i.mass for i in model.inertias) == pytest.approx(sum(m for m, _, _ in links.values()), rel=1e-9)


def test_solid_primitives_weigh_their_volume_at_the_stated_density(exported):
    links = inertials(exported["madar"])
    # a wheel: a solid sphere of radius 0.1 m at its link's origin
    mass, com, matrix = links["madar_wheel_1"]
    sphere = DENSITY * 4 / 3 * math.pi * 0.1**3
    assert mass == pytest.approx(sphere) and np.allclose(com, 0)
    assert np.allclose(matrix, np.eye(3) * 0.4 * sphere * 0.1**2)
    # the torso: a cylinder and three boxes (tools/builtin_robot_urdfs.py TORSO), parallel axes by hand
    parts = [  # (mass, centre, inertia about the centre)
        (DENSITY * math.pi * 0.4**2 * 0.75, (0, 0, 0.375), None),
        (DENSITY * 0.5 * 0.08 * 0.05, (0, 0, 1.395), (0.5, 0.08, 0.05)),
        (DENSITY * 0.08 * 0.08 * 0.63, (0, 0, 1.056), (0.08, 0.08, 0.63)),
        (DENSITY * 0.43 * 0.2 * 0.33, (0, -0.14, 0.916), (0.43, 0.2, 0.33)),
    ]
    total = sum(m for m, _, _ in parts)
    centre = sum(m * np.array(c) for m, c, _ in parts) / total
    expected = np.zeros((3, 3))
    for m, c, size in parts:
        if size is None:  # the cylinder, its axis z
            own = np.diag([m * (3 * 0.4**2 + 0.75**2) / 12] * 2 + [m * 0.4**2 / 2])
        else:
            x, y, z = size
            own = m / 12 * np.diag([y * y + z * z, x * x + z * z, x * x + y * y])
        d = np.array(c) - centre
        expected += own + m * (d @ d * np.eye(3) - np.outer(d, d))
    mass, com, matrix = links["madar_base_link"]
    assert mass == pytest.approx(total) and np.allclose(com, centre)
    assert np.allclose(matrix, expected, rtol=1e-9, atol=1e-9)
    # a frame with no shape; an Allegro finger link keeps its stated 9.6 g (its stated inertia
    # breaks the triangle inequality: its principal moments are replaced by its box's, scaled);
    # the palm's and the fingertip's stated inertias are kept as they are
    assert links["right_tool"][0] == FRAME_MASS
    mass, com, matrix = links["right_hand_link_3.0"]
    x, y, z = 0.0196, 0.0275, 0.0267
    assert mass == 0.0096 and np.allclose(com, (0, 0, 0.01335))
    assert np.allclose(matrix, mass / 12 * np.diag([y * y + z * z, x * x + z * z, x * x + y * y]))
    assert links["right_hand_link_3.0_tip"][0] == 0.0168 and np.allclose(
        links["right_hand_link_3.0_tip"][2], np.eye(3) * 9.68e-07
    )
    assert links["right_hand_palm_link"][0] == 0.4154 and np.allclose(
        links["right_hand_palm_link"][2], np.eye(3) * 1e-4
    )


BOXES = """<robot name="boxes">
  <link name="a"><collision><origin xyz="0.1 0 0" rpy="0 0 1.5707963267948966"/>
    <geometry><box size="0.2 0.1 0.05"/></geometry></collision></link>
  <link name="b"><visual><geometry><sphere radius="0.05"/></geometry></visual></link>
  <link name="c"><collision><geometry><sphere radius="0.02"/></geometry></collision></link>
  <link name="d"/>
  <joint name="ab" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0 0 0.5" rpy="0.3 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="bc" type="fixed"><parent link="b"/><child link="c"/><origin xyz="0 0.2 0"/></joint>
  <joint name="cd" type="fixed"><parent link="c"/><child link="d"/><origin xyz="0 0 0.1"/></joint>
</robot>"""


def test_a_rotated_shape_a_visual_only_link_a_fixed_link_and_a_frame():
    links = inertials(with_inertias(BOXES))
    mass, com, matrix = links["a"]  # turned a quarter about z: 0.1 along x, 0.2 along y
    assert mass == pytest.approx(DENSITY * 0.001) and np.allclose(com, (0.1, 0, 0))
    assert np.allclose(matrix, mass / 12 * np.diag([0.2**2 + 0.05**2, 0.1**2 + 0.05**2, 0.1**2 + 0.2**2]))
    mass, com, matrix = links["b"]  # visual shapes when there is no collision shape
    assert mass == pytest.approx(DENSITY * 4 / 3 * math.pi * 0.05**3) and np.allclose(com, 0)
    mass, com, _ = links["c"]  # on a fixed joint: in its own frame, not its parent joint's
    assert mass == pytest.approx(DENSITY * 4 / 3 * math.pi * 0.02**3) and np.allclose(com, 0)
    assert links["d"][0] == FRAME_MASS
