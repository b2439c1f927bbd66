"""Rules about a carried object apply from the moment the hand holds it, and a sharp tool carried
near people (not handed to them) points down and away from them at half speed.

Before: the hand on its way to grasp a hot cup was held upright and slowed (the cup counted as
carried before it was grasped), and a knife carried past a collaborator had no orientation rule
and no slow-down (tests/data/whole_tasks/knife_past_collaborator.yaml)."""

import functools
import math
from pathlib import Path

import numpy as np

from hriplan.robots.human import Human, HumanSpec
from hriplan.tasks.load import load_task
from hriplan.tasks.pipeline import TaskRunner
from independent import UrdfRobot, constraint_violations

ROOT = Path(__file__).parents[1] / "data"
HOT_CUP = (ROOT / "people" / "hot_cup_near_collaborator.yaml").read_text()


def test_a_hot_cup_is_upright_and_slow_once_grasped_not_on_the_way_to_it(tmp_path):
    # The cup stands on the table near carl; the pick's hand is empty until it closes.
    task = HOT_CUP.replace("  held_by: right\n", "  pose: {xyz: [0.45, 0.75, 0.77]}\n").replace(
        "- name: place\n  goal:\n    place: coffee\n    at:\n      xyz: [0.35, 0.8, 0.77]",
        "- name: pick\n  goal: {grasp: coffee}",
    )
    (tmp_path / "t.yaml").write_text(task)
    outcome = TaskRunner(load_task(tmp_path / "t.yaml")).run()
    assert [(s.name, s.status) for s in outcome.steps] == [("pick", "solved"), ("pick_lift", "solved")], [
        s.message for s in outcome.steps
    ]
    pick, lift = outcome.steps
    assert {c.kind for c in pick.derivation.constraints} == {"HeadKeepOutSphere"}
    assert pick.derivation.velocity == [] and pick.trajectory.report.velocity_scale == 1.0
    assert {c.kind for c in lift.derivation.constraints} == {"HeadKeepOutSphere", "UprightPartial"}
    assert lift.trajectory.report.velocity_scale == 0.5
    for step in outcome.steps:
        assert constraint_violations(step.trajectory) == [], step.name


@functools.cache
def knife_task():
    task = load_task(ROOT / "whole_tasks" / "knife_past_collaborator.yaml")
    return task, TaskRunner(task).run()


def test_a_knife_carried_past_a_collaborator_points_down_and_away_from_him_at_half_speed():
    task, outcome = knife_task()
    assert [(s.name, s.status) for s in outcome.steps] == [
        (name, "solved") for name in ("carry_prepare", "carry", "hang_up", "hang_up_release")
    ], [s.message for s in outcome.steps]
    for name in ("carry", "hang_up"):
        step = next(s for s in outcome.steps if s.name == name)
        assert {c.kind for c in step.derivation.constraints} == {"HeadKeepOutSphere", "SharpEndDown"}
        assert (
            "sharp_end_down_near_human"
            in next(c for c in step.derivation.constraints if c.kind == "SharpEndDown").rules
        )
        assert step.trajectory.report.velocity_scale == 0.5
    for step in outcome.steps:
        assert constraint_violations(step.trajectory) == [], step.name


def test_the_carried_blade_points_below_and_away_from_his_head_and_chest_at_every_point():
    # Independently: the knife's axis from the URDF's forward kinematics (the handle grasp holds
    # it along the tool's +y), his head and chest from the person model, at every written point.
    task, outcome = knife_task()
    carl = Human(HumanSpec(**task.humans[0].model_dump(include=set(HumanSpec.model_fields))))
    head, chest = carl.frame("head").translation, carl.frame("torso").translation
    for step in (s for s in outcome.steps if s.name in ("carry", "hang_up")):
        trajectory = step.trajectory
        robot = UrdfRobot(trajectory.robot, dict(trajectory.hands))
        for point in trajectory.points:
            robot.configure(dict(trajectory.start) | dict(zip(trajectory.joint_names, point.positions)))
            tool = robot.pose("right_tool")
            blade, knife = tool.rotation[:, 1], tool.translation
            assert blade[2] < -math.cos(1.0) + 1e-3, (step.name, point.time_from_start)  # >= 33 deg below level
            for part in (head, chest):
                assert blade @ (part - knife) < 0.0, (step.name, point.time_from_start)
            towards_him = np.append(np.array(task.humans[0].position) - knife[:2], 0.0)
            assert blade @ towards_him <= 1e-3, (step.name, point.time_from_start)  # never towards him
