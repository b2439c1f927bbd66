"""Each goal of a step gets its own target; a peg into a cup is not an insertion into a hole."""

import numpy as np
import pytest

from hriplan.ontology.cache import ReasoningCache
from hriplan.ontology.knowledge_base import KnowledgeBase
from hriplan.ontology.situation import Situation
from hriplan.robots.spatial import Pose
from hriplan.rules.infer import derive


@pytest.fixture(scope="module")
def cache(tmp_path_factory) -> ReasoningCache:
    return ReasoningCache(tmp_path_factory.getbasetemp() / "kb-cache-goals")


def two_pegs(left_target_kind: str = "Hole") -> Situation:
    return Situation.model_validate(
        {
            "task": {
                "name": "insert",
                "kind": "Insertion",
                "arms": ["right", "left"],
                "carries": {"peg_r": "right", "peg_l": "left"},
                "targets": {"peg_r": "hole_r", "peg_l": "hole_l"},
            },
            "objects": [
                {"name": "peg_r", "kind": "Peg"},
                {"name": "peg_l", "kind": "Peg"},
                {"name": "hole_r", "kind": "Hole", "pose": {"xyz": [0.2, 0.8, 0.75], "rpy": [0.3, 0.0, 0.0]}},
                {
                    "name": "hole_l",
                    "kind": left_target_kind,
                    "pose": {"xyz": [-0.2, 0.8, 0.75], "rpy": [0.0, -0.4, 0.0]},
                },
            ],
        }
    )


def test_each_peg_is_aligned_with_its_own_hole(cache):
    derivation = derive(KnowledgeBase(two_pegs(), cache=cache))
    by_id = {c.spec.id: c for c in derivation.constraints}
    for side, hole_rpy in (("right", (0.3, 0.0, 0.0)), ("left", (0.0, -0.4, 0.0))):
        alignment = by_id[f"{side}_alignment_peg_{side[0]}"]
        hole_axis = Pose(rpy=hole_rpy).rotation()[:, 2]
        # The peg's axis (tool +y on MADAR) in the target orientation is the hole's axis.
        assert np.allclose(alignment.spec.target.rotation()[:, 1], hole_axis, atol=1e-9)
        assert f"peg_{side[0]} goes into hole_{side[0]}" in alignment.facts


def test_a_peg_whose_target_is_a_cup_gets_no_insertion_alignment(cache):
    derivation = derive(KnowledgeBase(two_pegs(left_target_kind="Cup"), cache=cache))
    kinds = {c.spec.id: c.kind for c in derivation.constraints}
    assert kinds == {"right_alignment_peg_r": "InsertionAlignment"}


def test_a_situation_with_one_target_applies_it_to_its_carried_object():
    situation = Situation.model_validate(
        {
            "robot": "ur5",
            "task": {"kind": "Insertion", "arms": ["arm"], "carries": {"peg": "arm"}, "target": "hole"},
            "objects": [{"name": "peg", "kind": "Peg"}, {"name": "hole", "kind": "Hole"}],
        }
    )
    assert situation.task.goal_targets() == {"peg": "hole"}


def test_the_task_pipeline_gives_each_insert_goal_its_own_hole():
    from hriplan.tasks.load import load_task
    from hriplan.tasks.pipeline import situation_for
    from hriplan.tasks.task_state import TaskState

    task = load_task("examples/peg_in_hole_supervised.yaml")
    situation = situation_for(task, task.steps[0], 0, TaskState.initial(task))
    assert situation.task.goal_targets() == {"peg_right": "hole_right", "peg_left": "hole_left"}
    assert situation.task.target is None  # two holes: no single target object of the task


def test_a_person_hands_with_the_hand_they_reach_out():
    # Before: the active hand was the right one unless named, so a receiver reaching out her left
    # hand was handed the object at her hanging right hand (behind and below where she reached).
    from hriplan.tasks.goals import resolve_goal
    from hriplan.tasks.grasps import Grasp
    from hriplan.tasks.model import TaskFile
    from hriplan.tasks.task_state import TaskState

    task = TaskFile.model_validate(
        {
            "robot": "madar",
            "objects": [
                {
                    "name": "can",
                    "kind": "Can",
                    "held_by": "left",
                    "shape": {"type": "cylinder", "radius": 0.033, "height": 0.12},
                }
            ],
            "humans": [
                {
                    "name": "eve",
                    "role": "Receiver",
                    "position": [-0.5, 1.5],
                    "yaw": -1.5708,
                    "reach": {"left": [-0.45, 1.1, 1.05]},
                }
            ],
            "steps": [{"goal": {"hand_over": "can", "to": "eve"}}],
        }
    )
    assert task.humans[0].hand == "left"
    state = TaskState.initial(task)
    state.grasps["can"] = Grasp("SideGrasp", "+y")
    goal = resolve_goal(task.steps[0].goal, "left", state).goal
    # independently: she faces -y (towards the robot), so the can is 19 cm in front of that palm
    assert np.allclose(goal.pose.xyz, (-0.45, 1.1 - 0.19, 1.05), atol=0.02)
    with pytest.raises(ValueError, match="eve hands with the right hand but reaches out only the left one"):
        TaskFile.model_validate(task.model_dump() | {"humans": [task.humans[0].model_dump() | {"hand": "right"}]})


@pytest.mark.parametrize(
    "reach, hand",
    [({}, "right"), ({"left": (-0.45, 1.1, 1.05)}, "left"), ({"right": (0.4, 1.1, 1.0)}, "right"),
     ({"left": (-0.45, 1.1, 1.05), "right": (0.4, 1.1, 1.0)}, "right")],
)  # fmt: skip
def test_a_task_a_situation_and_a_bare_problem_choose_the_same_handing_hand(reach, hand):
    """One rule (robots.human.handing_hand) for a task's person, a situation's and the ISO/TS 15066
    policy of a bare planning problem, whose contact region lies on that hand's side."""
    from hriplan.ontology.situation import SituationHuman
    from hriplan.robots.human import HumanSpec
    from hriplan.safety.policy import default_policy
    from hriplan.tasks.model import TaskHuman

    person = {"name": "eve", "role": "Receiver", "reach": reach}
    assert TaskHuman.model_validate(person).hand == SituationHuman.model_validate(person).hand == hand
    (policy,) = default_policy("madar", [HumanSpec(name="eve", reach=reach)], {"eve": "Receiver"}).people
    sides = {capsule.split("_")[0] for region in policy.contact for capsule in region.capsules}
    assert sides == {hand}
    if len(reach) == 1:
        other = "right" if hand == "left" else "left"
        with pytest.raises(ValueError, match=f"eve hands with the {other} hand but reaches out only the {hand} one"):
            SituationHuman.model_validate(person | {"hand": other})
