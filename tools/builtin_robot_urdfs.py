"""Maintainer script: write the built-in robots' URDFs from the published numbers they are made of.

    python tools/builtin_robot_urdfs.py    # rewrites the files in FILES

hriplan reads robots only from robot files (src/hriplan/robots/data/madar.yaml, ur5.yaml): this
script is how their URDFs were made, not a runtime path. MADAR is torso primitives, three omni
wheels, two UR5 arms (the published DH-style joint origins, as the Kautham project's MADAR
description has them; joint limits, velocities and efforts from example-robot-data's
ur5_robot.urdf) and an Allegro V4 hand (example-robot-data's, renamed `{side}_hand_*`) on an
adapter on each wrist. Meshes are package://example-robot-data/robots/... URIs.
tests/robots/test_builtin_robot_files.py checks that the shipped files are what this writes.
"""

from __future__ import annotations

import math
import sys
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path

from hriplan.robots import urdf_xml as X
from hriplan.robots.assets import asset

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "package://example-robot-data/robots/"
PI = math.pi

# --- the UR5 in the DH-style frames of the MADAR / Kautham description ---
UR5_JOINTS = ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3")
UR5_LINKS = (
    "base_link",
    "shoulder_link",
    "upper_arm_link",
    "fore_arm_link",
    "wrist_1_link",
    "wrist_2_link",
    "wrist_3_link",
)
# (xyz, rpy) of each joint's origin in its parent link, all axes local z.
UR5_JOINT_ORIGINS = (
    ((0.0, 0.0, 0.089159), (0.0, 0.0, 0.0)),
    ((0.0, 0.0, 0.0), (PI / 2, 0.0, 0.0)),
    ((-0.425, 0.0, 0.0), (0.0, 0.0, 0.0)),
    ((-0.39225, 0.0, 0.10915), (0.0, 0.0, 0.0)),
    ((0.0, -0.09465, 0.0), (PI / 2, 0.0, 0.0)),
    ((0.0, 0.0823, 0.0), (PI / 2, PI, PI)),
)
# Link -> (mesh name, xyz, rpy) placing the standard UR5 meshes in the DH-style frames.
UR5_MESHES = {
    "base_link": ("base", (0.0, 0.0, 0.0), (0.0, 0.0, PI)),
    "shoulder_link": ("shoulder", (0.0, 0.0, 0.0), (0.0, 0.0, PI)),
    "upper_arm_link": ("upperarm", (0.0, 0.0, 0.13585), (PI / 2, 0.0, -PI / 2)),
    "fore_arm_link": ("forearm", (0.0, 0.0, 0.0165), (PI / 2, 0.0, -PI / 2)),
    "wrist_1_link": ("wrist1", (0.0, 0.0, -0.093), (PI / 2, 0.0, 0.0)),
    "wrist_2_link": ("wrist2", (0.0, 0.0, -0.095), (0.0, 0.0, 0.0)),
    "wrist_3_link": ("wrist3", (0.0, 0.0, -0.0818), (PI / 2, 0.0, 0.0)),
}
UR5_MESH_DIR = "ur_description/meshes/ur5"

# --- MADAR, numbers from the Kautham project's MADAR description ---
MADAR_BASE = "madar_base_link"
# Arm base mounts on the MADAR base (URDF rpy), as published for the real robot.
ARM_MOUNTS = {
    "right": ((0.256, 0.0, 1.389), (3.142, -0.7874, 0.0)),
    "left": ((-0.256, 0.0, 1.389), (-3.142, 0.7874, 0.0)),
}
# wrist_3 -> adapter -> Allegro palm, and the adapter's collision cylinder.
ADAPTER_OFFSET = (0.0, 0.0, 0.0225)
ADAPTER_TO_PALM = ((0.0, 0.01, 0.1175), (0.0, 0.0, math.pi / 2))
ADAPTER_CYLINDER = (0.035, 0.045)
# Tool (TCP) frame in the palm frame: the centre of a power grasp, z = approach direction
# (out of the palm), x = along the fingers, y = z x x (the axis of a grasped cylinder).
TOOL_IN_PALM = ((0.045, 0.0, 0.035), (math.pi, -math.pi / 2, 0.0))
WHEEL_RADIUS = 0.10
WHEEL_CIRCLE = 0.29


def _fmt(values: Sequence[float]) -> str:
    return " ".join(repr(float(v)) for v in values)


def box(size: Sequence[float]) -> tuple[str, dict[str, str]]:
    return "box", {"size": _fmt(size)}


def cylinder(radius: float, length: float) -> tuple[str, dict[str, str]]:
    return "cylinder", {"radius": repr(float(radius)), "length": repr(float(length))}


def sphere(radius: float) -> tuple[str, dict[str, str]]:
    return "sphere", {"radius": repr(float(radius))}


def shape(
    link_el: ET.Element,
    role: str,
    geometry: tuple[str, dict[str, str]],
    xyz=(0.0, 0.0, 0.0),
    rpy=(0.0, 0.0, 0.0),
    name: str | None = None,
) -> None:
    """Add a <visual> or <collision> with one geometry, e.g. ("box", {"size": "1 1 1"})."""
    el = ET.SubElement(link_el, role, **({"name": name} if name else {}))
    X.origin(el, xyz, rpy)
    ET.SubElement(ET.SubElement(el, "geometry"), geometry[0], **geometry[1])


# Torso / structure primitives: (name, geometry, xyz).
TORSO = (
    ("madar_base_cylinder", cylinder(0.4, 0.75), (0.0, 0.0, 0.375)),
    ("madar_crossbar", box((0.5, 0.08, 0.05)), (0.0, 0.0, 1.395)),
    ("madar_column", box((0.08, 0.08, 0.63)), (0.0, 0.0, 1.056)),
    ("madar_electronics_box", box((0.43, 0.2, 0.33)), (0.0, -0.14, 0.916)),
)


def ur5_limits() -> dict[str, dict[str, float]]:
    """Per joint (unprefixed name) the <limit> attributes of example-robot-data's UR5."""
    root = ET.parse(asset("ur_description/urdf/ur5_robot.urdf")).getroot()
    limits = {}
    for el in root.iter("joint"):
        lim = el.find("limit")
        if el.get("type") == "revolute" and lim is not None:
            limits[el.get("name")] = {k: float(v) for k, v in lim.attrib.items()}
    return limits


def add_ur5(robot: ET.Element, prefix: str) -> None:
    """Append the UR5 links and joints, named `{prefix}base_link` ... `{prefix}wrist_3_link`."""
    limits = ur5_limits()
    for name in UR5_LINKS:
        el = X.link(robot, f"{prefix}{name}")
        mesh_name, xyz, rpy = UR5_MESHES[name]
        for role, folder, ext in (("visual", "visual", "dae"), ("collision", "collision", "stl")):
            relative = f"{UR5_MESH_DIR}/{folder}/{mesh_name}.{ext}"
            asset(relative)  # it is there
            shape(el, role, ("mesh", {"filename": PACKAGE + relative}), xyz, rpy)
    for i, (jname, (xyz, rpy)) in enumerate(zip(UR5_JOINTS, UR5_JOINT_ORIGINS)):
        X.joint(
            robot,
            f"{prefix}{jname}_joint",
            "revolute",
            f"{prefix}{UR5_LINKS[i]}",
            f"{prefix}{UR5_LINKS[i + 1]}",
            xyz,
            rpy,
            axis=(0.0, 0.0, 1.0),
            limit=limits[f"{jname}_joint"],
        )


def add_allegro(robot: ET.Element, prefix: str, side: str) -> str:
    """Append example-robot-data's Allegro hand renamed `{prefix}hand_*`; return the palm link's name."""
    source = ET.parse(asset(f"allegro_hand_description/urdf/allegro_{side}_hand.urdf")).getroot()
    rename = lambda name: f"{prefix}hand_{name}"  # noqa: E731
    for el in source:
        if el.tag == "link":
            el.set("name", rename(el.get("name")))
            for mesh in el.iter("mesh"):
                assert mesh.get("filename").startswith(PACKAGE), mesh.get("filename")
            robot.append(el)
        elif el.tag == "joint":
            el.set("name", rename(el.get("name")))
            for tag in ("parent", "child"):
                el.find(tag).set("link", rename(el.find(tag).get("link")))
            robot.append(el)
    return rename("palm_link")


def _add_structure(robot: ET.Element) -> None:
    base = X.link(robot, MADAR_BASE)
    for name, geometry, xyz in TORSO:
        for role in ("visual", "collision"):
            shape(base, role, geometry, xyz, name=name)
    for i in range(3):
        angle = 2.0 * math.pi * i / 3.0
        wheel = f"madar_wheel_{i + 1}"
        el = X.link(robot, wheel)
        for role in ("visual", "collision"):
            shape(el, role, sphere(WHEEL_RADIUS), name=wheel)
        X.joint(
            robot,
            f"motor_{i + 1}",
            "continuous",
            MADAR_BASE,
            wheel,
            xyz=(WHEEL_CIRCLE * math.cos(angle), WHEEL_CIRCLE * math.sin(angle), WHEEL_RADIUS),
            rpy=(0.0, 0.0, angle),
            axis=(1.0, 0.0, 0.0),
            limit={"effort": 50.0, "velocity": 10.0},
        )


def _add_hand(robot: ET.Element, prefix: str, side: str) -> None:
    adapter = f"{prefix}hand_adapter"
    el = X.link(robot, adapter)
    radius, length = ADAPTER_CYLINDER
    for role in ("visual", "collision"):
        shape(el, role, cylinder(radius, length), name=adapter)
    X.joint(robot, f"{prefix}hand_adapter_joint", "fixed", f"{prefix}wrist_3_link", adapter, ADAPTER_OFFSET)
    palm = add_allegro(robot, prefix, side)
    X.joint(robot, f"{prefix}hand_mount_joint", "fixed", adapter, palm, *ADAPTER_TO_PALM)
    X.link(robot, f"{prefix}tool")
    X.joint(robot, f"{prefix}tool_joint", "fixed", palm, f"{prefix}tool", *TOOL_IN_PALM)


def _text(robot: ET.Element) -> str:
    ET.indent(robot)
    return ET.tostring(robot, encoding="unicode")


def madar_urdf(hands: bool = True) -> str:
    """MADAR with an Allegro hand and a tool frame on each wrist (`hands=False`: bare flanges, as
    Kautham's madar_dual_arm)."""
    robot = ET.Element("robot", name="madar")
    _add_structure(robot)
    for side, (xyz, rpy) in ARM_MOUNTS.items():
        prefix = f"{side}_"
        add_ur5(robot, prefix)
        X.joint(robot, f"{prefix}arm_mount_joint", "fixed", MADAR_BASE, f"{prefix}base_link", xyz, rpy)
        if hands:
            _add_hand(robot, prefix, side)
    return _text(robot)


def ur5_urdf() -> str:
    """A single UR5 with a TCP frame `tool` on the flange (z out of the flange)."""
    robot = ET.Element("robot", name="ur5")
    add_ur5(robot, "")
    X.link(robot, "tool")
    X.joint(robot, "tool_joint", "fixed", "wrist_3_link", "tool")
    return _text(robot)


# Shipped file (relative to the repository) -> its text.
FILES = {
    "src/hriplan/robots/data/madar.urdf": lambda: madar_urdf(),
    "src/hriplan/robots/data/ur5.urdf": ur5_urdf,
    "examples/robots/madar_bare.urdf": lambda: madar_urdf(hands=False),
}


def main() -> None:
    for relative, text in FILES.items():
        (ROOT / relative).write_text(text() + "\n")
        print(f"wrote {relative}", file=sys.stderr)


if __name__ == "__main__":
    main()
