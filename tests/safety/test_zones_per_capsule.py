"""The S_0 zones per capsule (safety/zones.py) against their definition computed here: S_0 plus the
policy's padding and the slack, cut to the closest moving part's clearance at the start; none on a contact region; every
person of the policy, whoever else stands in the scene."""

from __future__ import annotations

import numpy as np
import pytest

from hriplan.robots.collision import CollisionChecker
from hriplan.robots.descriptions.registry import posture
from hriplan.robots.human import HumanSpec
from hriplan.robots.model import load_robot
from hriplan.robots.scene import Scene
from hriplan.safety.policy import default_policy
from hriplan.safety.separation import minimum_separation
from hriplan.safety.zones import START_CLEARANCE, ZONE_SLACK, separation_zones


@pytest.fixture(scope="module")
def robot():
    return load_robot("madar")


def expected(checker: CollisionChecker, robot, policy, group: str, q: np.ndarray, name: str) -> dict[str, float]:
    person = policy.person(name)
    s0 = minimum_separation(policy.robot, person) + policy.margin.padding
    pairs = checker.person_pairs(q, name)
    moving = robot.moved_joints(group)
    closest: dict[str, float] = {}
    for capsule, joint, distance in zip(pairs.capsules, pairs.joints, pairs.distance):
        if int(joint) in moving:
            closest[capsule] = min(closest.get(capsule, np.inf), float(distance))
    return {
        c.name: s0 + min(max(closest.get(c.name, np.inf) - s0 - START_CLEARANCE, 0.0), ZONE_SLACK)
        for c in checker.humans[name].capsules
        if person.contact_region(c.name) is None
    }


def test_each_capsule_is_grown_by_s0_and_the_slack_cut_at_the_start(robot):
    q = robot.configuration(posture("madar", "ready"))
    # dana beside the left arm (some capsules within the slack), a receiver reaching out in front
    dana = HumanSpec(name="dana", position=(-1.28, 0.37), yaw=0.0)
    rob = HumanSpec(name="rob", position=(0.0, 1.45), yaw=-np.pi / 2, reach={"right": (0.05, 1.05, 1.05)})
    ghost = HumanSpec(name="ghost", position=(3.0, 3.0))  # in the scene, not in the policy
    checker = CollisionChecker(robot, Scene(humans=[ghost, dana, rob]))
    policy = default_policy("madar", [dana, rob], roles={"rob": "Receiver"})
    zones = separation_zones(checker, robot, policy, "left_arm", q)
    assert set(zones.distances) == {"dana", "rob"}  # the ghost first does not stop the others
    for name in ("dana", "rob"):
        assert zones.distances[name] == pytest.approx(expected(checker, robot, policy, "left_arm", q, name))
    cut = [
        d
        for d in zones.distances["dana"].values()
        if d < minimum_separation(policy.robot, policy.people[0]) + policy.margin.padding + ZONE_SLACK
    ]
    assert cut, "dana stands within the slack of some capsule: the cut is tested"
    contact = {c for r in policy.person("rob").contact for c in r.capsules}
    assert contact and not contact & set(zones.distances["rob"])  # no zone where contact is the task
