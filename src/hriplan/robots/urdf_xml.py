"""Small helpers to write URDF elements with xml.etree (the assembled robots are generated)."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Sequence


def _fmt(values: Sequence[float]) -> str:
    return " ".join(repr(float(v)) for v in values)


def origin(parent: ET.Element, xyz=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0)) -> ET.Element:
    return ET.SubElement(parent, "origin", xyz=_fmt(xyz), rpy=_fmt(rpy))


def link(robot: ET.Element, name: str) -> ET.Element:
    return ET.SubElement(robot, "link", name=name)


def joint(
    robot: ET.Element,
    name: str,
    kind: str,
    parent: str,
    child: str,
    xyz=(0.0, 0.0, 0.0),
    rpy=(0.0, 0.0, 0.0),
    axis: Sequence[float] | None = None,
    limit: dict[str, float] | None = None,
) -> ET.Element:
    el = ET.SubElement(robot, "joint", name=name, type=kind)
    ET.SubElement(el, "parent", link=parent)
    ET.SubElement(el, "child", link=child)
    origin(el, xyz, rpy)
    if axis is not None:
        ET.SubElement(el, "axis", xyz=_fmt(axis))
    if limit is not None:
        ET.SubElement(el, "limit", **{k: repr(float(v)) for k, v in limit.items()})
    return el


def shape(
    link_el: ET.Element,
    role: str,
    geometry: tuple[str, dict[str, str]],
    xyz=(0.0, 0.0, 0.0),
    rpy=(0.0, 0.0, 0.0),
    name: str | None = None,
) -> ET.Element:
    """Add a <visual> or <collision> with one geometry, e.g. ("box", {"size": "1 1 1"})."""
    el = ET.SubElement(link_el, role, **({"name": name} if name else {}))
    origin(el, xyz, rpy)
    geo = ET.SubElement(el, "geometry")
    ET.SubElement(geo, geometry[0], **geometry[1])
    return el


def box(size: Sequence[float]) -> tuple[str, dict[str, str]]:
    return "box", {"size": _fmt(size)}


def cylinder(radius: float, length: float) -> tuple[str, dict[str, str]]:
    return "cylinder", {"radius": repr(float(radius)), "length": repr(float(length))}


def sphere(radius: float) -> tuple[str, dict[str, str]]:
    return "sphere", {"radius": repr(float(radius))}


def mesh(filename: str) -> tuple[str, dict[str, str]]:
    return "mesh", {"filename": filename}


def to_string(robot: ET.Element) -> str:
    ET.indent(robot)
    return ET.tostring(robot, encoding="unicode")
