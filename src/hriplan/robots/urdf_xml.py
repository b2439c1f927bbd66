"""Small helpers to write URDF elements with xml.etree (a robot file's offset tool frame; the
maintainer script that writes the built-in robots' URDFs, tools/builtin_robot_urdfs.py)."""

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
