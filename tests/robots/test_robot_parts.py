"""Which links keep their URDF primitives as collision parts is the URDF's to say, not the
links' names: MADAR's torso renamed (`madar_*` to `cart_*`) keeps its cylinder and boxes, each
as the URDF gives it (read here from the URDF's XML), and every other part is fitted as before."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from hriplan.robots.descriptions.registry import load_robot_file
from hriplan.robots.model import load_robot
from hriplan.robots.robot_geometry import robot_parts

BARE = Path(__file__).parents[2] / "examples" / "robots" / "madar_bare.yaml"
PRIMITIVES = ("box", "cylinder", "sphere")


def _primitive_collisions(urdf: str) -> dict[str, tuple[str, list[float]]]:
    """Per <collision> of a link drawn and collided with primitives only: its kind and numbers."""
    found = {}
    for link in ET.fromstring(urdf).iter("link"):
        shapes = [g[0] for g in link.iter("geometry")]
        if not shapes or any(s.tag not in PRIMITIVES for s in shapes):
            continue
        for k, collision in enumerate(link.findall("collision")):
            shape = collision.find("geometry")[0]
            numbers = [float(v) for key in ("size", "radius", "length") for v in shape.get(key, "").split()]
            found[collision.get("name") or f"{link.get('name')}#{k}"] = (shape.tag, numbers)
    return found


@pytest.fixture
def renamed(tmp_path: Path, robot_registry):
    """madar_bare with every `madar_` name changed to `cart_`, as its own robot file."""
    urdf = (BARE.parent / "madar_bare.urdf").read_text().replace("madar_", "cart_")
    (tmp_path / "cart.urdf").write_text(urdf)
    robot_file = BARE.read_text().replace("name: madar_bare", "name: cart_bare").replace("madar_bare.urdf", "cart.urdf")
    (tmp_path / "cart.yaml").write_text(robot_file)
    load_robot_file(tmp_path / "cart.yaml")
    return load_robot("cart_bare"), urdf


def _numbers(geometry) -> tuple[str, list[float]]:
    kind = type(geometry).__name__.lower()
    if kind == "box":
        return kind, list(2 * np.asarray(geometry.halfSide))
    if kind == "cylinder":
        return kind, [geometry.radius, 2 * geometry.halfLength]
    return kind, [geometry.radius]


def test_primitive_links_keep_their_shapes_whatever_their_names(renamed):
    robot, urdf = renamed
    expected = _primitive_collisions(urdf)
    assert {"cart_base_cylinder", "cart_crossbar", "cart_column", "cart_electronics_box"} <= set(expected)
    kept = {p.name: p for p in robot_parts(robot) if p.kept}
    assert set(kept) == set(expected)
    for name, (kind, numbers) in expected.items():
        got_kind, got = _numbers(kept[name].geometry)
        assert got_kind == kind and np.allclose(got, numbers, atol=1e-12), name


def test_the_other_parts_are_fitted_as_for_madar(renamed):
    robot, _ = renamed
    bare = load_robot(load_robot_file(BARE).name)
    fitted = {p.name: p for p in robot_parts(robot) if not p.kept}
    original = {p.name.replace("madar_", "cart_"): p for p in robot_parts(bare) if not p.kept}
    assert set(fitted) == set(original) and fitted
    for name, part in fitted.items():
        assert type(part.geometry) is type(original[name].geometry)
        assert np.allclose(part.placement.homogeneous, original[name].placement.homogeneous, atol=1e-12)
