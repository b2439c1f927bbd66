"""A Kautham obstacle's URDF (from its models folder) as hriplan scene shapes.

Every `<collision>` of every link becomes a piece placed in the obstacle's base frame (joints
at their zero value). Kautham's `scale` scales the whole model: sizes, mesh scales and every
offset. Meshes are checked through their convex hull, like every hriplan mesh obstacle.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from hriplan.formats.kautham.reader import Reader
from hriplan.robots.scene import Box, Cylinder, Mesh, Shape, Sphere


@dataclass(frozen=True)
class ObstacleModel:
    name: str  # the URDF's robot name (Kautham's name for an obstacle without <KauthamName>)
    pieces: tuple[tuple[Shape, pin.SE3], ...]  # shape and placement in the obstacle's base frame


def _origin(reader: Reader, el: ET.Element | None, scale: float, where: str) -> pin.SE3:
    if el is None:
        return pin.SE3.Identity()
    xyz = np.array(reader.floats(el.get("xyz", "0 0 0"), 3, where)) * scale
    rpy = reader.floats(el.get("rpy", "0 0 0"), 3, where)
    return pin.SE3(pin.rpy.rpyToMatrix(*rpy), xyz)


def _shape(reader: Reader, geometry: ET.Element, scale: float, where: str) -> Shape:
    kinds = [el for el in geometry if el.tag in ("box", "cylinder", "sphere", "mesh")]
    if len(kinds) != 1:
        raise reader.fail(f"{where}: <geometry> must hold one box, cylinder, sphere or mesh")
    el = kinds[0]
    if el.tag == "box":
        return Box(size=tuple(np.array(reader.floats(reader.attr(el, "size", where), 3, where)) * scale))
    if el.tag == "cylinder":
        return Cylinder(
            radius=reader.number(el, "radius", where) * scale, height=reader.number(el, "length", where) * scale
        )
    if el.tag == "sphere":
        return Sphere(radius=reader.number(el, "radius", where) * scale)
    filename = reader.attr(el, "filename", where)
    if filename.startswith("package://"):
        raise reader.fail(
            f"{where}: mesh {filename!r}: package:// paths are not supported, use a path relative to the URDF"
        )
    path = reader.path.parent / filename
    if not path.is_file():
        raise reader.fail(f"{where}: mesh file {filename!r} not found next to the URDF")
    mesh_scale = reader.floats(el.get("scale", "1 1 1"), 3, where)
    return Mesh(path=str(path.resolve()), scale=tuple(np.array(mesh_scale) * scale))


def load_obstacle_model(path: Path, scale: float) -> ObstacleModel:
    """The collision pieces of an obstacle URDF, scaled by `scale`."""
    reader = Reader(path)
    root = reader.parse()
    if root.tag != "robot":
        raise reader.fail(f"the root element is <{root.tag}>, not <robot>")
    parent_of: dict[str, tuple[str, pin.SE3]] = {}
    for joint in root.findall("joint"):
        where = f"joint {joint.get('name')!r}"
        parent = reader.attr(reader.child(joint, "parent", where), "link", where)
        child = reader.attr(reader.child(joint, "child", where), "link", where)
        parent_of[child] = (parent, _origin(reader, joint.find("origin"), scale, where))

    def link_pose(name: str, depth: int = 0) -> pin.SE3:
        if name not in parent_of:
            return pin.SE3.Identity()
        if depth > len(parent_of):
            raise reader.fail(f"the joints form a loop through link {name!r}")
        parent, placement = parent_of[name]
        return link_pose(parent, depth + 1) * placement

    pieces = []
    for link in root.findall("link"):
        name = reader.attr(link, "name", "<link>")
        for k, collision in enumerate(link.findall("collision")):
            where = f"link {name!r}, collision {k + 1}"
            shape = _shape(reader, reader.child(collision, "geometry", where), scale, where)
            pieces.append((shape, link_pose(name) * _origin(reader, collision.find("origin"), scale, where)))
    if not pieces:
        raise reader.fail("no <collision> geometry")
    return ObstacleModel(root.get("name") or path.stem, tuple(pieces))
