"""Task files to trajectories: loading, the rules deciding per example, planning end to end."""

from pathlib import Path

import numpy as np
import pytest

from hriplan import HriplanError
from hriplan.planner.replay import PlannedWorld
from hriplan.tasks.load import load_task
from hriplan.tasks.pipeline import TaskRunner
from independent import constraint_violations

EXAMPLES = Path(__file__).parents[2] / "examples"


def derived(name):
    outcome = TaskRunner(load_task(EXAMPLES / f"{name}.yaml")).run(plan=False)
    return {s.name: {c.spec.id: c for c in s.derivation.constraints} for s in outcome.steps}


def test_rules_decide_differently_per_example():
    full = derived("handover_full_can_receiver")["hand_over"]
    empty = derived("handover_empty_can")["hand_over"]
    assert {"upright_can", "approach_cone_bob", "shared_workspace_bob", "exclusion_box_bob"} <= set(full)
    assert "upright_can" not in empty and "approach_cone_bob" in empty  # an empty can cannot spill
    assert (
        full["upright_can"].spec.tolerance < derived("transport_cup_bystander")["carry"]["upright_cup"].spec.tolerance
    )
    bystander = derived("transport_cup_bystander")["carry"]["keep_out_dana"].spec
    assert bystander.region == "outside" and bystander.keep_out_all_links and bystander.frame.entity == "dana/base"
    scissors = derived("handover_scissors")
    assert "sharp_end_away_scissors" in scissors["hand_over"]
    # bob waits for the handover: kept out meanwhile, the blades carried near him pointing down and away
    assert set(scissors["turn_blades"]) == {"keep_out_bob", "sharp_end_down_scissors"}
    pegs = derived("peg_in_hole_supervised")["bring_pegs"]
    for side in ("right", "left"):
        alignment = pegs[f"{side}_alignment_peg_{side}"].spec
        assert alignment.tolerance_gradient > 0 and alignment.joints[0] == f"{side}_shoulder_pan_joint"
        assert f"{side}_keep_out_sam" in pegs


def test_hot_object_near_a_person_slows_the_trajectory():
    outcome = TaskRunner(load_task(EXAMPLES / "handover_hot_coffee.yaml")).run(plan=False)
    assert outcome.steps[0].derivation.velocity_scale == 0.5
    assert (
        TaskRunner(load_task(EXAMPLES / "handover_empty_can.yaml")).run(plan=False).steps[0].derivation.velocity_scale
        == 1.0
    )


def test_provenance_names_rules_and_facts():
    upright = derived("handover_full_can_receiver")["hand_over"]["upright_can"]
    assert "upright_full_open_container" in upright.rules
    assert any("Full" in fact for fact in upright.facts) and upright.reason.startswith("A full open container")


def test_handover_task_plans_both_steps_and_every_trajectory_validates():
    runner = TaskRunner(load_task(EXAMPLES / "handover_full_can.yaml"))
    outcome = runner.run(plan=True)
    assert outcome.solved and [s.name for s in outcome.steps] == ["take_can", "place_can", "place_can_release"]
    take, place, _ = outcome.steps
    assert take.trajectory.scene.attached == [] and [a.name for a in place.trajectory.scene.attached] == ["coke_can"]
    reasons = {c.spec.id: c.reason for c in place.trajectory.constraints}
    assert reasons["upright_coke_can"].startswith("A full open container")
    assert reasons["keep_out_alice"].startswith("A giver whose object was taken")  # alice is protected once she gave
    # the second step starts where the first ended
    assert np.allclose(place.trajectory.points[0].positions, take.trajectory.points[-1].positions, atol=1e-9)
    for step in outcome.steps:
        check = PlannedWorld.load(step.trajectory).validate()
        assert check.valid, check.message
        assert constraint_violations(step.trajectory) == []
    # where the can was put: upright, above the requested place, released 4 cm higher
    robot = runner.session.robot
    end = dict(place.trajectory.start) | dict(zip(place.trajectory.joint_names, place.trajectory.points[-1].positions))
    tool = robot.frame_pose("right_tool", robot.configuration(end))
    assert np.allclose(tool[:3, 3], (0.45, 0.75, 0.785 + 0.04), atol=1e-5) and tool[2, 1] > np.cos(0.05)


@pytest.mark.parametrize(
    "text, message",
    [
        ("steps: []", "steps: List should have at least 1 item"),
        ("robot: pr2\nsteps: [{goal: {joints: {}}}]", "robot: unknown robot 'pr2'; known robots: madar, ur5"),
        (
            "robot: ur5\nstart: {posture: sitting}\nsteps: [{goal: {joints: {}}}]",
            "start.posture: robot 'ur5' has no posture 'sitting'; postures: home, ready",
        ),
        (
            "robot: ur5\nhands: {right: power}\nsteps: [{goal: {joints: {}}}]",
            "hands: robot 'ur5' has no hand 'right'; hands: none",
        ),
        (
            "hands: {right: fist}\nsteps: [{goal: {joints: {}}}]",
            "hands.right: unknown hand posture 'fist'; choose one of",
        ),
        (
            "objects: [{name: cup, kind: Cup}]\nsteps: [{goal: {grasp: mug}}]",
            "steps.0: grasp 'mug' is not among the objects",
        ),
        ("steps: [{goal: {joints: {}}, goals: [{joints: {}}]}]", "a step has either `goal` or `goals`"),
        (
            "steps: [{goal: {arms: [right, left], goals: [{posture: home}, {posture: home}]}}]",
            "steps.0: `arms` and `goals` are keys of the step, beside its name, not of its `goal`",
        ),
        ("steps: [{goal: {joints: {}}}\n", "line 2: not valid YAML"),
    ],
)
def test_bad_task_files_are_one_line_errors(tmp_path, text, message):
    path = tmp_path / "task.yaml"
    path.write_text(text)
    with pytest.raises(HriplanError, match=message) as info:
        load_task(path)
    assert str(info.value).startswith(str(path)) and "\n" not in str(info.value)


def test_unknown_ontology_class_or_arm_is_reported(tmp_path):
    path = tmp_path / "task.yaml"
    path.write_text(
        "objects: [{name: thing, kind: Teapot, held_by: right}]\nsteps: [{goal: {place: thing, at: {xyz: [0.4, 0.7, 0.9]}}}]"
    )
    with pytest.raises(
        HriplanError, match="object 'thing' has kind 'Teapot', not a PhysicalObject class of the ontology"
    ):
        TaskRunner(load_task(path)).run(plan=False)


def test_taking_from_a_giver_gets_the_handover_constraints_and_the_upright_once_held(tmp_path):
    # Before: the take's empty hand was already held upright (the can counted as carried on the way to it).
    steps = derived("handover_full_can")
    take = steps["take_can"]
    assert {"approach_cone_alice", "shared_workspace_alice", "exclusion_box_alice"} == set(take)
    assert "upright_coke_can" in steps["place_can"]
    assert "take_approach_cone" in take["approach_cone_alice"].rules
    # the same task with a collaborator instead of a giver: no handover constraints
    text = (EXAMPLES / "handover_full_can.yaml").read_text().replace("role: Giver", "role: Collaborator")
    path = tmp_path / "collaborator.yaml"
    path.write_text(text)
    outcome = TaskRunner(load_task(path)).run(plan=False)
    take, place = ({c.spec.id for c in s.derivation.constraints} for s in outcome.steps)
    assert "approach_cone_alice" not in take and "upright_coke_can" in place


@pytest.mark.parametrize("example", sorted(p.stem for p in EXAMPLES.glob("*.yaml")))
def test_every_shipped_example_plans_and_validates(example, robot_registry):
    outcome = TaskRunner(load_task(EXAMPLES / f"{example}.yaml")).run(plan=True)
    assert outcome.solved, [(s.name, s.status, s.message) for s in outcome.steps]
    for step in outcome.steps:
        assert PlannedWorld.load(step.trajectory).validate().valid
        assert constraint_violations(step.trajectory) == []
