"""`hriplan robot srdf`: what hriplan knows of a robot beyond its URDF, as an SRDF MoveIt reads.

A group per arm (the chain from its base link to its tool frame), the whole-robot group (the
arms as subgroups), an end effector per arm (its hand's finger joints as the group; a bare
flange's tool link, as UR's MoveIt configurations have it), a group state per named posture
(every arm joint; the ones a posture does not list are 0, as hriplan reads it), and the pairs
hriplan does not check for self-collision: links joined by a joint ("Adjacent", MoveIt's sense:
through links without geometry too) and pairs whose parts never touched in the sampled
allowed-collision matrix (acm.py; "Never", a sampling estimate as MoveIt's is). Pairs checked on
meshes, or whose parts touched, stay enabled; so does every pair with a link that a joint hriplan
locks moves (fingers, wheels): it was sampled at one finger posture only.
"""

from __future__ import annotations

import collections
import itertools
import xml.etree.ElementTree as ET

from hriplan.robots.acm import MESH, load_acm
from hriplan.robots.descriptions.description import hand_model
from hriplan.robots.model import Robot
from hriplan.robots.robot_geometry import robot_parts
from hriplan.robots.urdf_tree import MOVABLE, UrdfTree


def _groups(robot: Robot, root: ET.Element, tree: UrdfTree) -> None:
    description = robot.description
    for arm in description.arms.values():
        group = ET.SubElement(root, "group", name=arm.group)
        ET.SubElement(group, "chain", base_link=arm.base_link, tip_link=arm.tool_frame)
    if description.whole_group not in {arm.group for arm in description.arms.values()}:
        whole = ET.SubElement(root, "group", name=description.whole_group)
        for arm in description.arms.values():
            ET.SubElement(whole, "group", name=arm.group)
    for name, arm in description.arms.items():
        if arm.hand is not None:
            hand = hand_model(arm.hand)
            group = ET.SubElement(root, "group", name=f"{name}_hand")
            for joint in hand.joint_values(hand.postures[0]):
                ET.SubElement(group, "joint", name=hand.joint_name(arm.prefix, joint))
        elif tree.parent_joint[arm.tool_frame].type not in MOVABLE:
            group = ET.SubElement(root, "group", name=f"{name}_tool")
            ET.SubElement(group, "link", name=arm.tool_frame)
        else:
            continue  # the tool is the last joint's own link: no end effector group without it
        ET.SubElement(
            root,
            "end_effector",
            name=group.get("name"),
            group=group.get("name"),
            parent_link=arm.tool_frame,
            parent_group=arm.group,
        )


def _states(robot: Robot, root: ET.Element) -> None:
    joints = robot.group_joints()
    for name, values in robot.description.postures.items():
        state = ET.SubElement(root, "group_state", name=name, group=robot.description.whole_group)
        for joint in joints:
            ET.SubElement(state, "joint", name=joint, value=repr(float(values.get(joint, 0.0))))


def disabled_pairs(robot: Robot, urdf: ET.Element) -> list[tuple[str, str, str]]:
    """(link, link, reason) for every pair hriplan does not check (module docstring)."""
    tree = UrdfTree(urdf)
    with_geometry = {el.get("name") for el in urdf.findall("link") if el.find("collision") is not None}
    pairs: dict[tuple[str, str], str] = {}
    for link in with_geometry:
        above = next((j.parent for j in tree.ancestors(link) if j.parent in with_geometry), None)
        if above is not None:
            pairs[tuple(sorted((link, above)))] = "Adjacent"
    arm_joints = {j for arm in robot.description.arms.values() for j in arm.joints}
    locked = {
        link for link in tree.links if any(j.type in MOVABLE and j.name not in arm_joints for j in tree.ancestors(link))
    }
    parts = robot_parts(robot)
    acm = load_acm(robot, parts)
    by_link = collections.defaultdict(list)
    for part in parts:
        by_link[part.link].append(part.name)
    for a, b in itertools.combinations(sorted(by_link), 2):
        if (a, b) in pairs or a in locked or b in locked:
            continue
        reasons = {acm.get(f"{p}|{r}", acm.get(f"{r}|{p}")) for p in by_link[a] for r in by_link[b] if p != r}
        if reasons and None not in reasons and MESH not in reasons:
            pairs[(a, b)] = {"never": "Never", "always": "Always", "user": "User"}.get(
                min(reasons - {"adjacent"}, default=""), "Adjacent"
            )
    return [(a, b, reason) for (a, b), reason in sorted(pairs.items())]


def srdf_text(robot: Robot) -> str:
    """The robot's SRDF (module docstring), named as its URDF is."""
    urdf = ET.fromstring(robot.urdf)
    tree = UrdfTree(urdf)
    root = ET.Element("robot", name=urdf.get("name", robot.name))
    root.append(ET.Comment(f" Written by `hriplan robot srdf {robot.name}`: groups, postures, unchecked pairs. "))
    _groups(robot, root, tree)
    _states(robot, root)
    for a, b, reason in disabled_pairs(robot, urdf):
        ET.SubElement(root, "disable_collisions", link1=a, link2=b, reason=reason)
    ET.indent(root)
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"
