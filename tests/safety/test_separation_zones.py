"""The planner keeps ISO/TS 15066's minimum separation S_0 (safety/zones.py)."""

import pytest

from hriplan.planner.motion import with_keep_out
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.descriptions.registry import posture
from hriplan.robots.human import HumanSpec
from hriplan.robots.model import load_robot
from hriplan.robots.scene import Scene
from hriplan.safety.policy import default_policy
from hriplan.safety.separation import minimum_separation
from hriplan.safety.zones import ZONE_SLACK, separation_zones


@pytest.fixture(scope="module")
def robot():
    return load_robot("madar")


def left_arm_clearance(robot, checker, q, person: str) -> float:
    """Closest left-arm part to the person's bare capsules (pinocchio distances, no zones)."""
    pairs = checker.person_pairs(q, person)
    left = [k for k, part in enumerate(pairs.parts) if part.startswith("left_")]
    return float(pairs.distance[left].min())


def test_a_bystander_beside_the_left_arm_binds_the_left_arm_only(robot):
    # MADAR faces +y; its left hand is at x = -0.78 in the ready posture. Dana (a bystander: S_0 =
    # 1.6 m/s * 0.3 s + 0.05 + 0.02 = 0.55 m, and the default padding 0.05 m) stands 0.3 m or so to
    # its left, facing it.
    dana = HumanSpec(name="dana", position=(-1.2, 0.37), yaw=0.0)
    checker = CollisionChecker(robot, Scene(humans=[dana]))
    policy = default_policy("madar", [dana])
    assert minimum_separation(policy.robot, policy.people[0]) == pytest.approx(0.55) and policy.margin.padding == 0.05
    q = robot.configuration(posture("madar", "ready"))
    assert not checker.in_collision(q) and left_arm_clearance(robot, checker, q, "dana") < 0.6
    with with_keep_out(checker, [], separation_zones(checker, robot, policy, "right_arm", q)):
        zone_pairs = [
            (checker.geom_model.geometryObjects[p.first], checker.geom_model.geometryObjects[p.second])
            for p in checker.geom_model.collisionPairs
            if "zone" in (checker.kind[p.first], checker.kind[p.second])
        ]
        others = {b.name if "minimum separation" in a.name else a.name for a, b in zone_pairs}
        assert others and all(name.startswith("right_") for name in others)
        assert not checker.in_collision(q)  # the fixed torso and the still left arm do not count
    with with_keep_out(checker, [], separation_zones(checker, robot, policy, "left_arm", q)):
        contacts = checker.contacts(q)
        assert any(
            c.b == "dana/middle_thorax (minimum separation 0.600 m)" or c.a.startswith("dana/") for c in contacts
        )
        assert all(c.a.startswith("left_") for c in contacts)
    assert not checker.in_collision(q) and checker.zones is None  # gone after the block


def test_the_slack_beyond_s0_stops_at_the_start_so_a_start_the_timing_accepts_is_valid(robot):
    q = robot.configuration(posture("madar", "ready"))
    dana = HumanSpec(name="dana", position=(-1.2, 0.37), yaw=0.0)
    checker = CollisionChecker(robot, Scene(humans=[dana]))
    policy = default_policy("madar", [dana])
    # step dana away until the left arm is 2 mm beyond S_0 + padding (inside the 5 mm slack)
    s0 = minimum_separation(policy.robot, policy.people[0]) + policy.margin.padding
    x = -1.2
    for _ in range(5):  # the closest of her capsules may change as she steps back
        x -= s0 + 0.002 - left_arm_clearance(robot, checker, q, "dana")
        dana = dana.model_copy(update={"position": (x, 0.37)})
        checker.pose_human(dana)
    assert left_arm_clearance(robot, checker, q, "dana") == pytest.approx(s0 + 0.002, abs=2e-4)
    zones = separation_zones(checker, robot, policy, "left_arm", q)
    grown = zones.distances["dana"]
    assert s0 < min(grown.values()) < s0 + 0.002 and max(grown.values()) == pytest.approx(s0 + ZONE_SLACK)
    with with_keep_out(checker, [], separation_zones(checker, robot, policy, "left_arm", q)):
        assert not checker.in_collision(q)
        # when she steps 1 cm closer, the arm is inside the zone (it moves with her)
        checker.pose_human(dana.model_copy(update={"position": (x + 0.01, 0.37)}))
        assert checker.in_collision(q)
