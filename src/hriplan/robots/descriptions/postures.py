"""Named robot postures, each robot's own (`RobotDescription.postures`): collision-free
configurations a task can start from (joints not listed are 0)."""

from __future__ import annotations

_FOLDED = {"shoulder_lift_joint": -2.2, "elbow_joint": 1.2}  # arm folded to its side, clear of the torso
# Right tool 0.6 m in front of MADAR at table height, a held can upright (from the handover scenario).
_RIGHT_FORWARD = {
    "shoulder_pan_joint": 1.194,
    "shoulder_lift_joint": 0.141,
    "elbow_joint": -1.628,
    "wrist_1_joint": -0.436,
    "wrist_2_joint": -2.286,
    "wrist_3_joint": 2.632,
}

MADAR_POSTURES: dict[str, dict[str, float]] = {
    "home": {f"{side}_{j}": v for side in ("right", "left") for j, v in _FOLDED.items()},
    "ready": {
        **{f"right_{j}": v for j, v in _RIGHT_FORWARD.items()},
        **{f"left_{j}": v for j, v in _FOLDED.items()},
    },
}
UR5_POSTURES: dict[str, dict[str, float]] = {
    "home": {"shoulder_lift_joint": -1.57},
    "ready": {"shoulder_lift_joint": -1.2, "elbow_joint": 1.5, "wrist_1_joint": -1.9, "wrist_2_joint": -1.57},
}
