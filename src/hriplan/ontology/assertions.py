"""The facts a situation asserts, as plain data: what the reasoner gets and what keys its cache.

An assertion is (subject, predicate, object): predicate `a` states a class, any other predicate
is an ontology property whose object is an individual's name or a data value. Geometry the
rules never see (orientations, sizes, body height) stays out, so changing it reuses the cache;
so do positions and headings unless a rule reads them (relations that depend on numbers are
computed from the geometry and asserted qualitatively instead: `relations`).
Only the person the task hands to or takes from gets body-part individuals (with the hand they
use): every individual costs reasoning time, and nobody else's parts are needed by name.
"""

from __future__ import annotations

from collections.abc import Sequence

from hriplan import HriplanError
from hriplan.ontology.ruleset import Rule, read_predicates
from hriplan.ontology.situation import Situation, SituationHuman

Assertion = tuple[str, str, bool | int | float | str]
TYPE = "a"
GEOMETRY = ("hasX", "hasY", "hasZ", "hasYaw")  # asserted only for rules that read them
BODY_PARTS = {"head": "Head", "torso": "Torso", "left_hand": "HumanHand", "right_hand": "HumanHand"}


def arm_individual(robot: str, arm: str) -> str:
    """The ontology individual of an arm: `madar_right`, `ur5_arm`."""
    return f"{robot}_{arm}"


def body_part_individual(person: str, part: str) -> str:
    return f"{person}_{part}"


def situation_assertions(situation: Situation, rules: Sequence[Rule] = ()) -> list[Assertion]:
    """Every fact the situation states, sorted (the order must not change the cache key);
    positions and headings only if one of `rules` reads them."""
    facts: list[Assertion] = [*_task(situation)]
    for obj in situation.objects:
        facts += [(obj.name, TYPE, obj.kind), *_position(obj.name, obj.pose.xyz)]
        if obj.fill_level is not None:
            facts.append((obj.name, "hasFillLevel", obj.fill_level))
        for prop, value in (
            ("isOpen", obj.open),
            ("isSharp", obj.sharp),
            ("isFragile", obj.fragile),
            ("isHot", obj.hot),
        ):
            if value is not None:
                facts.append((obj.name, prop, value))
    for human in situation.humans:
        facts += [
            (human.name, TYPE, "Human"),
            (human.name, "hasRole", human.role),
            (human.name, "hasYaw", float(human.yaw)),
            *_position(human.name, (*human.position, 0.0)),
        ]
    if situation.task.human is not None:
        facts += _body(situation, situation.human(situation.task.human))
    read = read_predicates(rules)
    facts = [f for f in facts if f[1] not in GEOMETRY or f[1] in read] + list(situation.facts)
    return sorted(set(facts), key=repr)


def _body(situation: Situation, human: SituationHuman) -> list[Assertion]:
    """The person's head, torso and hands with their planner frames, and the hand they use."""
    names = {situation.task.name} | situation.object_names() | {h.name for h in situation.humans}
    facts: list[Assertion] = []
    for part, cls in BODY_PARTS.items():
        individual = body_part_individual(human.name, part)
        if individual in names:
            raise HriplanError(f"the name {individual!r} is taken by {human.name}'s {part}; rename it")
        facts += [
            (individual, TYPE, cls),
            (individual, "hasFrameName", f"{human.name}/{part}"),
            (human.name, "hasBodyPart", individual),
        ]
    return [*facts, (human.name, "hasActiveHand", body_part_individual(human.name, f"{human.hand}_hand"))]


def _task(situation: Situation) -> list[Assertion]:
    task, robot = situation.task, situation.robot
    facts: list[Assertion] = [(task.name, TYPE, task.kind), (task.name, "performedBy", robot)]
    facts += [(task.name, "usesArm", arm_individual(robot, arm)) for arm in task.arms]
    facts += [(arm_individual(robot, arm), "carries", obj) for obj, arm in task.carries.items()]
    facts += [(task.name, "involves", name) for name in situation.object_names() | {h.name for h in situation.humans}]
    if task.human is not None:
        facts.append((task.name, "hasTargetHuman", task.human))
    # Everyone else, by name, so rules can protect them (SWRL has no negation).
    facts += [(task.name, "hasOtherHuman", h.name) for h in situation.humans if h.name != task.human]
    if task.target is not None:
        facts.append((task.name, "hasTargetObject", task.target))
    facts += [(obj, "goesInto", target) for obj, target in task.goal_targets().items()]
    return facts


def _position(name: str, xyz: tuple[float, float, float]) -> list[Assertion]:
    return [(name, prop, float(v)) for prop, v in zip(("hasX", "hasY", "hasZ"), xyz)]
