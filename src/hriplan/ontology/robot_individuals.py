"""The ontology's robot individuals, generated from the robot descriptions (one home per robot).

Each `RobotDescription` (a robot file's: the built-in MADAR and UR5 are robot files too) becomes
a `hp:Robot` with its arms, each arm its tool link, its joints (URDF names, chain order) and its
robot hand, and the robot its ISO/TS 15066 stopping data, so the ontology and the planner cannot
disagree about a robot; hriplan.ttl names no robot.
"""

from __future__ import annotations

from hriplan.robots.descriptions.description import RobotDescription, hand_model
from hriplan.robots.descriptions.registry import DESCRIPTIONS

PREFIXES = """@prefix hp: <https://hriplan.org/ontology#> .
@prefix owl: <http://www.w3.org/2002/07/owl#> .
@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .
"""
COUNTS = {1: "one", 2: "two", 3: "three", 4: "four"}
_made: tuple[tuple[RobotDescription, ...], str] | None = None  # the descriptions last made, and their Turtle


def _text(value: str) -> str:
    return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _robot(d: RobotDescription) -> list[str]:
    """Turtle statements of one robot: `hp:NAME`, `hp:NAME_ARM`, their tools, joints and hands."""
    models = sorted({a.model for a in d.arms.values()})
    hands = sorted({hand_model(a.hand).label for a in d.arms.values() if a.hand is not None})
    count = COUNTS.get(len(d.arms), str(len(d.arms)))
    arms = f"{count} {' and '.join(models)} arm{'s' if len(d.arms) > 1 else ''}"
    with_hands = f" with {' and '.join(hands)} hand{'s' if len(d.hands) > 1 else ''}" if hands else ""
    arm_ids = [f"hp:{d.name}_{arm}" for arm in d.arms]
    lines = [
        f"hp:{d.name} a owl:NamedIndividual , hp:Robot ; rdfs:label {_text(d.label)} ;",
        f"    rdfs:comment {_text(f'{d.summary}: {arms}{with_hands}.')} ;",
        f"    hp:hasUrdfName {_text(d.name)} ; hp:hasArm {' , '.join(arm_ids)} .",
    ]
    if d.stopping:
        lines.append(f"hp:{d.name} " + " ; ".join(f"hp:{key} {value!r}" for key, value in d.stopping.items()) + " .")
    for (arm, a), arm_id in zip(d.arms.items(), arm_ids):
        # A one-armed robot's parts are the robot's ("UR5 arm"), a many-armed one's the arm's ("MADAR right arm").
        owner = d.label if len(d.arms) == 1 else f"{d.label} {arm}"
        tool_id, hand_id = f"hp:{d.name}_{a.tool_frame}", f"hp:{d.name}_{a.prefix}hand"
        joints = a.joints
        hand = (
            f" hp:hasRobotHand {hand_id} ; hp:hasHandAxesInTool {_text(' '.join(a.hand_axes))} ;"
            if a.hand is not None
            else ""
        )
        lines += [
            f"{arm_id} a owl:NamedIndividual , hp:Arm ; rdfs:label {_text(f'{owner} arm')} ;",
            f"    hp:hasArmName {_text(arm)} ; hp:hasObjectAxisInTool {_text(a.object_axis)} ;",
            f"    hp:hasToolLink {tool_id} ;{hand}",
            f"    hp:hasJoint {' , '.join(f'hp:{d.name}_{j}' for j in joints)} .",
            f"{tool_id} a owl:NamedIndividual , hp:Link ; rdfs:label {_text(f'{owner} tool frame')} ;"
            f" hp:hasUrdfName {_text(a.tool_frame)} .",
        ]
        if a.hand is not None:
            label = f"{owner} {hand_model(a.hand).label} hand"
            lines.append(f"{hand_id} a owl:NamedIndividual , hp:RobotHand ; rdfs:label {_text(label)} .")
        lines += [
            f"hp:{d.name}_{j} a owl:NamedIndividual , hp:Joint ; hp:hasUrdfName {_text(j)} ; hp:hasChainIndex {k} ."
            for k, j in enumerate(joints, start=1)
        ]
    return lines


def robot_turtle() -> str:
    """Every described robot's individuals, as Turtle (parsed with the ontology file). Made again
    only when the registry holds other descriptions (they are frozen): every knowledge base asks."""
    global _made
    described = tuple(DESCRIPTIONS.values())
    if _made is None or len(_made[0]) != len(described) or any(a is not b for a, b in zip(_made[0], described)):
        _made = described, PREFIXES + "\n".join(line for d in described for line in _robot(d)) + "\n"
    return _made[1]
