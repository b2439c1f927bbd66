"""What an SRDF says about a robot, read as MoveIt reads it (srdfdom, RobotModel): groups as sets
of joints, end effectors, named states and the pairs it disables.

A group's `joint` adds itself, a `link` its parent joint, a `chain` the parent joint of every
link from the tip up to (not including) the base, a subgroup its joints; duplicates merge and
the joints are kept in the URDF's depth-first order, not the SRDF's listing order.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

from hriplan import HriplanError
from hriplan.robots.urdf_tree import UrdfTree


@dataclass(frozen=True)
class EndEffector:
    name: str
    group: str
    parent_link: str
    parent_group: str | None


@dataclass
class Srdf:
    groups: dict[str, list[str]] = field(default_factory=dict)  # name -> joints (every joint, fixed too)
    end_effectors: list[EndEffector] = field(default_factory=list)
    states: list[tuple[str, str, dict[str, float]]] = field(default_factory=list)  # (name, group, values)
    disabled: list[tuple[str, str, str]] = field(default_factory=list)  # (link, link, reason)
    ignored: list[str] = field(default_factory=list)  # what was read past, one line each


def _number(el: ET.Element, what: str) -> float:
    try:
        return float(el.get("value", "").split()[0])
    except (ValueError, IndexError):
        raise HriplanError(f"{what}: {el.get('value')!r} is not a number") from None


def read_srdf(text: str, tree: UrdfTree) -> Srdf:
    """The SRDF in `text` against the URDF `tree`: an unknown link, joint or subgroup is one line."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise HriplanError(f"not valid SRDF XML ({exc})") from None
    elements = {el.get("name"): el for el in root.findall("group")}
    srdf = Srdf()

    def joints_of(name: str, seen: tuple[str, ...]) -> list[str]:
        if name in seen:
            raise HriplanError(f"SRDF group {name!r} contains itself")
        if name not in elements:
            raise HriplanError(f"SRDF group {seen[-1]!r}: unknown subgroup {name!r}")
        what = f"SRDF group {name!r}"
        joints: list[str] = []
        for el in elements[name]:
            if el.tag == "joint":
                joints.append(tree.joint(el.get("name"), what).name)
            elif el.tag == "link":
                parent = tree.parent_joint.get(tree.link(el.get("name"), what))
                joints += [parent.name] if parent else []
            elif el.tag == "chain":
                joints += tree.chain(el.get("base_link"), el.get("tip_link"), what)
            elif el.tag == "group":
                joints += joints_of(el.get("name"), (*seen, name))
        return list(dict.fromkeys(joints))

    for name in elements:
        srdf.groups[name] = joints_of(name, ())
    for el in root.findall("end_effector"):
        what = f"SRDF end effector {el.get('name')!r}"
        for key in ("group", "parent_group"):
            if el.get(key) is not None and el.get(key) not in srdf.groups:
                raise HriplanError(f"{what}: unknown group {el.get(key)!r}")
        link = tree.link(el.get("parent_link", ""), what)
        srdf.end_effectors.append(EndEffector(el.get("name"), el.get("group"), link, el.get("parent_group")))
    for el in root.findall("group_state"):
        what = f"SRDF group state {el.get('name')!r}"
        # A joint the URDF lacks is skipped, as srdfdom does: TALOS's half_sitting sets pinocchio's
        # floating base `root_joint`, which no URDF declares; it places no joint of the URDF.
        missing = [j.get("name") for j in el.findall("joint") if j.get("name") not in tree.joints]
        if missing:
            srdf.ignored.append(f"{what}: {', '.join(map(repr, missing))} not in the URDF, ignored")
        values = {j.get("name"): _number(j, what) for j in el.findall("joint") if j.get("name") in tree.joints}
        srdf.states.append((el.get("name"), el.get("group"), values))
    for el in root.findall("disable_collisions"):
        what = "SRDF disable_collisions"
        srdf.disabled.append(
            (tree.link(el.get("link1", ""), what), tree.link(el.get("link2", ""), what), el.get("reason", ""))
        )
    return srdf
