"""Named robot postures: collision-free configurations a task can start from."""

from __future__ import annotations

from hriplan import HriplanError

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

POSTURES: dict[str, dict[str, dict[str, float]]] = {
    "madar": {
        "home": {f"{side}_{j}": v for side in ("right", "left") for j, v in _FOLDED.items()},
        "ready": {
            **{f"right_{j}": v for j, v in _RIGHT_FORWARD.items()},
            **{f"left_{j}": v for j, v in _FOLDED.items()},
        },
    },
    "ur5": {
        "home": {"shoulder_lift_joint": -1.57},
        "ready": {"shoulder_lift_joint": -1.2, "elbow_joint": 1.5, "wrist_1_joint": -1.9, "wrist_2_joint": -1.57},
    },
}


def posture(robot: str, name: str) -> dict[str, float]:
    """Joint values of a named posture (joints not listed are 0)."""
    try:
        return dict(POSTURES[robot][name])
    except KeyError:
        raise HriplanError(
            f"robot {robot!r} has no posture {name!r}; postures: {', '.join(POSTURES.get(robot, {}))}"
        ) from None
