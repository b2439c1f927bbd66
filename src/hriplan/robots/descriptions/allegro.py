"""The Allegro V4 hand (example-robot-data's, mounted renamed `{arm prefix}hand_*` in a robot's
URDF, as MADAR's) and its finger postures: a robot file's `hand: allegro` names this model.

Finger joints are fixed during arm planning: a posture is a value per finger joint.
"""

from __future__ import annotations

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


def hand_joint_name(prefix: str, name: str) -> str:
    """A hand joint's name in the robot (`joint_0.0` on the right arm: `right_hand_joint_0.0`)."""
    return f"{prefix}hand_{name}"
