"""The Allegro V4 hand from example-robot-data, renamed for mounting, and its finger postures.

Finger joints are fixed during arm planning: a posture is a value per finger joint.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from typing import Literal

from hriplan.robots.assets import asset, resolve_package_uri

# `release`: how the hand lets an object go (fingers straight, the thumb still opposed but
# straight), opening without swinging the thumb out into what the object stands on.
HAND_POSTURES: tuple[str, ...] = ("open", "power", "pinch", "release")

# Per finger (index 0-3, middle 4-7, ring 8-11, thumb 12-15) the joint values in radians.
_FINGER = {
    "open": (0.0, 0.0, 0.0, 0.0),
    "release": (0.0, 0.0, 0.0, 0.0),
    "power": (0.0, 1.1, 1.1, 0.9),
    "pinch_active": (0.0, 0.9, 0.6, 0.5),
    "pinch_tucked": (0.0, 1.5, 1.6, 1.5),
}
_THUMB = {
    "open": (0.3, 0.0, 0.0, 0.0),
    "release": (1.3, 0.0, 0.0, 0.0),
    "power": (1.3, 0.6, 0.7, 0.7),
    "pinch": (1.2, 0.5, 0.8, 0.6),
}


def posture_values(posture: str) -> dict[str, float]:
    """Finger joint values (keys are the hand URDF's own joint names, e.g. `joint_1.0`)."""
    if posture not in HAND_POSTURES:
        raise ValueError(f"unknown hand posture {posture!r}; choose one of {', '.join(HAND_POSTURES)}")
    if posture == "pinch":
        fingers = [_FINGER["pinch_active"], _FINGER["pinch_tucked"], _FINGER["pinch_tucked"]]
    else:
        fingers = [_FINGER[posture]] * 3
    thumb = _THUMB[posture]
    values = {}
    for f, finger in enumerate([*fingers, thumb]):
        for k, v in enumerate(finger):
            values[f"joint_{4 * f + k}.0"] = v
    return values


def add_allegro(robot: ET.Element, prefix: str, side: Literal["right", "left"]) -> str:
    """Append the hand's links and joints renamed `{prefix}hand_*`; return the palm link's name."""
    source = ET.parse(asset(f"allegro_hand_description/urdf/allegro_{side}_hand.urdf")).getroot()
    rename = lambda name: f"{prefix}hand_{name}"  # noqa: E731
    for el in source:
        if el.tag == "link":
            el.set("name", rename(el.get("name")))
            for mesh in el.iter("mesh"):
                mesh.set("filename", resolve_package_uri(mesh.get("filename")))
            robot.append(el)
        elif el.tag == "joint":
            el.set("name", rename(el.get("name")))
            for tag in ("parent", "child"):
                el.find(tag).set("link", rename(el.find(tag).get("link")))
            robot.append(el)
    return rename("palm_link")


def hand_joint_name(prefix: str, name: str) -> str:
    return f"{prefix}hand_{name}"
