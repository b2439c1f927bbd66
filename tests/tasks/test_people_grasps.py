"""Grasps a person would use, per object kind in the ontology, tried in order of preference."""

from pathlib import Path

import numpy as np
import pytest

from hriplan import HriplanError
from hriplan.ontology.knowledge_base import KnowledgeBase
from hriplan.ontology.situation import Situation
from hriplan.robots.scene import Box
from hriplan.tasks.grasps import Grasp, allowed_grasps
from hriplan.tasks.load import load_task
from hriplan.tasks.pipeline import TaskRunner
from hriplan.tasks.task_state import extent_along

DATA = Path(__file__).parents[1] / "data" / "people"


@pytest.fixture(scope="module")
def facts():
    situation = Situation.model_validate(
        {
            "task": {"kind": "Transport", "arms": ["right"], "carries": {"knife": "right"}},
            "objects": [
                {"name": "knife", "kind": "Knife"},
                {"name": "cup", "kind": "Cup", "fill_level": "Full", "open": True},
                {"name": "bowl", "kind": "Bowl", "fill_level": "Empty"},
                {"name": "peg", "kind": "Peg"},
                {"name": "screwdriver", "kind": "Screwdriver"},
            ],
        }
    )
    return KnowledgeBase(situation).facts


@pytest.mark.parametrize(
    "obj, names",
    [
        ("knife", ["HandleGrasp"]),
        ("cup", ["SideGrasp", "UpperSideGrasp"]),
        ("bowl", ["SideGrasp", "TopGrasp"]),
        ("peg", ["SideGrasp"]),
        ("screwdriver", ["HandleGrasp", "SideGrasp"]),
    ],
)
def test_the_rules_allow_the_grasps_a_person_would_use_in_order(facts, obj, names):
    assert [g.name for g in allowed_grasps(facts, obj, "madar_right", "+y")] == names


def test_an_arm_without_a_hand_holds_along_its_usual_axis(facts):
    assert allowed_grasps(facts, "knife", "ur5_arm", "-z") == [Grasp("usual", "-z")]


def test_a_handle_grasp_holds_a_tool_off_centre_towards_its_handle():
    in_tool = Grasp("HandleGrasp", "+y", -0.3).object_in_tool(0.25)
    assert np.allclose(in_tool.rotation[:, 2], (0.0, 1.0, 0.0))
    assert np.allclose(in_tool.translation, (0.0, 0.075, 0.0))  # the centre 7.5 cm towards the tip


def test_a_long_object_lying_along_the_way_a_person_faces_reaches_further():
    knife = Box(size=(0.02, 0.03, 0.25))
    lying = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # its z along world y
    assert extent_along(knife, lying, np.array([0.0, -1.0, 0.0])) == pytest.approx(0.125)
    assert extent_along(knife, np.eye(3), np.array([0.0, -1.0, 0.0])) == pytest.approx(0.015)


def test_a_low_bowl_is_placed_with_the_top_grasp_after_the_side_grasp_fails():
    runner = TaskRunner(load_task(DATA / "bowl_on_table.yaml"))
    step, release = runner.run().steps
    assert (step.status, release.status, release.name) == ("solved", "solved", "put_down_release"), release.message
    (bowl,) = step.trajectory.scene.attached
    assert np.allclose(bowl.grasp.rotation()[:, 2], (0.0, 0.0, -1.0))  # its axis into the palm: from the top
    # Independently: the bowl's bottom ends 4 cm above the table (released there), its axis up.
    robot = runner.session.robot
    end = dict(step.trajectory.start) | dict(zip(step.trajectory.joint_names, step.trajectory.points[-1].positions))
    placed = robot.frame_pose("right_tool", robot.configuration(end)) @ bowl.grasp.matrix()
    assert np.allclose(placed[:3, 3], (0.45, 0.75, 0.79), atol=1e-4) and placed[2, 2] > np.cos(0.01)


def test_a_25_cm_knife_is_handed_over_by_its_handle():
    runner = TaskRunner(load_task(DATA / "knife_handover_long.yaml"))
    outcome = runner.run()
    assert outcome.solved, [s.message for s in outcome.steps]
    hand_over = outcome.steps[-2]
    (knife,) = hand_over.trajectory.scene.attached
    assert np.allclose(knife.grasp.xyz, (0.0, 0.075, 0.0), atol=1e-9)  # held 7.5 cm towards the handle


def test_a_rule_cannot_require_a_grasp_the_kind_does_not_afford(tmp_path):
    # Before: a required grasp replaced the afforded ones, so a full open bowl got every grasp any
    # rule names; now the rules restrict what the kind affords, and nothing left is an error.
    rules = tmp_path / "top.rules"
    rules.write_text(
        "# A test rule: a grasp a peg does not afford.\n[peg_from_the_top]\n    Peg(?o) -> requiresGrasp(?o, TopGrasp)\n"
    )
    situation = Situation.model_validate(
        {
            "task": {"kind": "Transport", "arms": ["right"], "carries": {"peg": "right"}},
            "objects": [
                {"name": "peg", "kind": "Peg"},
                {"name": "bowl", "kind": "Bowl", "fill_level": "Full", "open": True},
            ],
        }
    )
    facts = KnowledgeBase(situation, rule_files=[str(rules)]).facts
    with pytest.raises(
        HriplanError, match="no grasp of peg is allowed: the rules require TopGrasp, its kind affords SideGrasp"
    ):
        allowed_grasps(facts, "peg", "madar_right", "+y")
    assert [g.name for g in allowed_grasps(facts, "bowl", "madar_right", "+y")] == [
        "SideGrasp"
    ]  # full and open: not from the top
