"""The kinematic tree of a URDF as its XML states it (links, joints, who is whose parent), for
reading a robot file: arms are chains of it, SRDF groups name its joints and links."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

from hriplan import HriplanError

MOVABLE = ("revolute", "prismatic", "continuous")


@dataclass(frozen=True)
class Joint:
    name: str
    type: str
    parent: str
    child: str
    mimic: str | None  # the joint it follows, if any


class UrdfTree:
    """Links and joints of one URDF; joints in depth-first order from the root (MoveIt's order)."""

    def __init__(self, root: ET.Element) -> None:
        self.links = [el.get("name") for el in root.findall("link")]
        for kind in ("link", "joint"):  # urdfdom refuses such a file with only "not a valid URDF model"
            names = [el.get("name") for el in root.findall(kind)]
            twice = sorted({n for n in names if names.count(n) > 1})
            if twice:
                raise HriplanError(f"the URDF names two {kind}s {twice[0]!r}")
        joints = {}
        for el in root.findall("joint"):
            parent, child = el.find("parent"), el.find("child")
            if parent is None or child is None:
                raise HriplanError(f"URDF joint {el.get('name')!r} has no parent or child link")
            mimic = el.find("mimic")
            joints[el.get("name")] = Joint(
                el.get("name"),
                el.get("type"),
                parent.get("link"),
                child.get("link"),
                mimic.get("joint") if mimic is not None else None,
            )
        for joint in joints.values():
            for link in (joint.parent, joint.child):
                if link not in self.links:
                    raise HriplanError(f"URDF joint {joint.name!r} names an unknown link {link!r}")
        self.parent_joint = {j.child: j for j in joints.values()}
        roots = [link for link in self.links if link not in self.parent_joint]
        if len(roots) != 1:
            raise HriplanError(f"a URDF has one root link, this one has {len(roots)}: {', '.join(roots[:5])}")
        self.root = roots[0]
        children: dict[str, list[Joint]] = {}
        for joint in joints.values():
            children.setdefault(joint.parent, []).append(joint)
        # Depth-first, each joint before its subtree and siblings in file order.
        self.joints: dict[str, Joint] = {}
        stack = list(reversed(children.get(self.root, [])))
        while stack:
            joint = stack.pop()
            self.joints[joint.name] = joint
            stack.extend(reversed(children.get(joint.child, [])))

    def link(self, name: str, what: str) -> str:
        if name not in self.links:
            raise HriplanError(f"{what}: unknown link {name!r}")
        return name

    def joint(self, name: str, what: str) -> Joint:
        if name not in self.joints:
            raise HriplanError(f"{what}: unknown joint {name!r}")
        return self.joints[name]

    def ancestors(self, link: str) -> list[Joint]:
        """The joints from `link` up to the root, nearest first."""
        path = []
        while link in self.parent_joint:
            joint = self.parent_joint[link]
            path.append(joint)
            link = joint.parent
        return path

    def moving_between(self, joint: str, link: str) -> list[str] | None:
        """The moving joints from `link` up to (not including) `joint`; None if `joint` is not above it."""
        above = [j.name for j in self.ancestors(link)]
        if joint not in above:
            return None
        return [j for j in above[: above.index(joint)] if self.joints[j].type in MOVABLE]

    def chain(self, base: str, tip: str, what: str) -> list[str]:
        """The joints from `base` down to `tip` (root first), as MoveIt reads an SRDF chain."""
        path, link = [], self.link(tip, what)
        while link != self.link(base, what):
            if link not in self.parent_joint:
                raise HriplanError(f"{what}: link {base!r} is not above link {tip!r}")
            path.append(self.parent_joint[link].name)
            link = self.parent_joint[link].parent
        return path[::-1]

    def movable(self, names: list[str]) -> list[str]:
        """The movable joints among `names`, once each, in the tree's depth-first order."""
        wanted = set(names)
        return [name for name, j in self.joints.items() if name in wanted and j.type in MOVABLE]
