"""The UR5 arm in the DH-style frames of the MADAR / Kautham description.

Joint origins and mesh placements are the published UR5 DH-style numbers (as the Kautham
project's MADAR description has them); joint limits, velocities and efforts are read from
example-robot-data's ur5_robot.urdf so they stay the UR5's own data.
"""

from __future__ import annotations

import functools
import math
import xml.etree.ElementTree as ET

from hriplan.robots import urdf_xml as X
from hriplan.robots.assets import asset

PI = math.pi
JOINTS = ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3")
LINKS = (
    "base_link",
    "shoulder_link",
    "upper_arm_link",
    "fore_arm_link",
    "wrist_1_link",
    "wrist_2_link",
    "wrist_3_link",
)
# (xyz, rpy) of each joint's origin in its parent link, all axes local z.
JOINT_ORIGINS = (
    ((0.0, 0.0, 0.089159), (0.0, 0.0, 0.0)),
    ((0.0, 0.0, 0.0), (PI / 2, 0.0, 0.0)),
    ((-0.425, 0.0, 0.0), (0.0, 0.0, 0.0)),
    ((-0.39225, 0.0, 0.10915), (0.0, 0.0, 0.0)),
    ((0.0, -0.09465, 0.0), (PI / 2, 0.0, 0.0)),
    ((0.0, 0.0823, 0.0), (PI / 2, PI, PI)),
)
# Link -> (mesh name, xyz, rpy) placing the standard UR5 meshes in the DH-style frames.
MESHES = {
    "base_link": ("base", (0.0, 0.0, 0.0), (0.0, 0.0, PI)),
    "shoulder_link": ("shoulder", (0.0, 0.0, 0.0), (0.0, 0.0, PI)),
    "upper_arm_link": ("upperarm", (0.0, 0.0, 0.13585), (PI / 2, 0.0, -PI / 2)),
    "fore_arm_link": ("forearm", (0.0, 0.0, 0.0165), (PI / 2, 0.0, -PI / 2)),
    "wrist_1_link": ("wrist1", (0.0, 0.0, -0.093), (PI / 2, 0.0, 0.0)),
    "wrist_2_link": ("wrist2", (0.0, 0.0, -0.095), (0.0, 0.0, 0.0)),
    "wrist_3_link": ("wrist3", (0.0, 0.0, -0.0818), (PI / 2, 0.0, 0.0)),
}
MESH_DIR = "ur_description/meshes/ur5"


def joint_names(prefix: str = "") -> list[str]:
    return [f"{prefix}{j}_joint" for j in JOINTS]


@functools.cache
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
    for name in LINKS:
        el = X.link(robot, f"{prefix}{name}")
        mesh_name, xyz, rpy = MESHES[name]
        for role, folder, ext in (("visual", "visual", "dae"), ("collision", "collision", "stl")):
            path = str(asset(f"{MESH_DIR}/{folder}/{mesh_name}.{ext}"))
            X.shape(el, role, X.mesh(path), xyz, rpy)
    for i, (jname, (xyz, rpy)) in enumerate(zip(JOINTS, JOINT_ORIGINS)):
        X.joint(
            robot,
            f"{prefix}{jname}_joint",
            "revolute",
            f"{prefix}{LINKS[i]}",
            f"{prefix}{LINKS[i + 1]}",
            xyz,
            rpy,
            axis=(0.0, 0.0, 1.0),
            limit=limits[f"{jname}_joint"],
        )
