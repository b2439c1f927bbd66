"""The separation zones of a start are made once for the leave check and the plan after it
(planner/start_zones.py): asked again for the same, the same zones; asked after the person moved,
or for another start, group or policy, the zones made afresh for that (safety/zones.py, whose own
tests check the zones against their definition)."""

from __future__ import annotations

from hriplan.planner.start_zones import start_zones
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.descriptions.registry import posture
from hriplan.robots.human import HumanSpec
from hriplan.robots.scene import Scene
from hriplan.safety.policy import default_policy
from hriplan.safety.zones import separation_zones


def test_zones_are_made_again_when_what_they_depend_on_changes(madar):
    robot = madar  # the session's MADAR: its collision model is built once for every test
    q = robot.configuration(posture("madar", "ready"))
    dana = HumanSpec(name="dana", position=(-1.28, 0.37), yaw=0.0)  # beside the left arm: zones cut
    checker = CollisionChecker(robot, Scene(humans=[dana]))
    policy = default_policy("madar", [dana])
    first = start_zones(checker, robot, policy, "left_arm", q)
    assert first == separation_zones(checker, robot, policy, "left_arm", q)
    assert start_zones(checker, robot, policy, "left_arm", q.copy()) is first  # the plan after the leave check
    # Each asked after one that differs from it only in that: another start (the shoulder turned
    # towards her), another group, another policy.
    turned = robot.configuration(robot.group_values(q, "left_arm") + [0.5, 0.0, 0.0, 0.0, 0.0, 0.0], "left_arm", base=q)
    made = start_zones(checker, robot, policy, "left_arm", turned)
    assert made == separation_zones(checker, robot, policy, "left_arm", turned) and made != first
    other = start_zones(checker, robot, policy, "right_arm", turned)
    assert other == separation_zones(checker, robot, policy, "right_arm", turned) and other != made
    wider = policy.model_copy(update={"margin": policy.margin.model_copy(update={"padding": 0.2})})
    made = start_zones(checker, robot, wider, "right_arm", turned)
    assert made == separation_zones(checker, robot, wider, "right_arm", turned) and made != other
    assert start_zones(checker, robot, policy, "left_arm", q) == first  # made again: the last were wider's
    # She walks 72 cm away: the checker given the new scene, no zone of hers is cut by the start now.
    checker.set_scene(Scene(humans=[dana.model_copy(update={"position": (-2.0, 0.37)})]))
    moved = start_zones(checker, robot, policy, "left_arm", q)
    assert moved == separation_zones(checker, robot, policy, "left_arm", q) and moved != first
    assert start_zones(checker, robot, None, "left_arm", q) is None
    assert start_zones(CollisionChecker(robot, Scene()), robot, policy, "left_arm", q) is None
