"""The grasp an object is held by from the start: stated in the task file (`held_by: {arm,
grasp}`) or searched in the order the rules allow; recorded in each trajectory and used again by
`validate --task` (tests/data/whole_tasks/soup_bowl_held_*.yaml).

Before: a full soup bowl held at the start could only be held by the side grasp (every IK
solution of its place put a finger into the table), and `validate --task` re-derived a searched
grasp as the first one the rules allow, so it rejected what `plan` had just written (the upright
constraint broken by 1.49 rad)."""

import functools
from pathlib import Path

import coal
import numpy as np
import pytest
from typer.testing import CliRunner

from hriplan import HriplanError
from hriplan.cli.main import app
from hriplan.tasks.load import load_task
from hriplan.tasks.pipeline import TaskRunner, against_task
from independent import UrdfRobot, constraint_violations, hand_distances

DATA = Path(__file__).parents[1] / "data" / "whole_tasks"
# The table of both tasks, from their files: centre (0.45, 0.85), 0.5 x 0.5 x 0.04 m, top at 0.72 m.
TABLE = coal.Box(0.5, 0.5, 0.04), np.array([[1, 0, 0, 0.45], [0, 1, 0, 0.85], [0, 0, 1, 0.70], [0, 0, 0, 1.0]])


@functools.cache
def planned(name: str):
    task = load_task(DATA / f"{name}.yaml")
    runner = TaskRunner(task, DATA)
    return task, runner, runner.run()


@pytest.mark.parametrize("name", ["soup_bowl_held_top", "soup_bowl_held_searched"])
def test_a_held_bowl_is_put_down_by_the_top_grasp_fingers_clear_of_the_table(name):
    task, _, outcome = planned(name)
    assert outcome.solved, [s.message for s in outcome.steps]
    for step in outcome.steps:
        assert step.trajectory.grasps == {"soup": "TopGrasp"}, step.name
        assert constraint_violations(step.trajectory) == [], step.name
    place = next(s for s in outcome.steps if s.name == "put_down")
    (upright,) = [c for c in place.trajectory.constraints if c.spec.id == "upright_soup"]
    assert upright.spec.tolerance == {"Full": 0.05, "Partial": 0.1}[task.objects[0].fill_level]
    # Independently, on the URDF's meshes: no finger reaches the table while the bowl goes down,
    # and the bowl ends upright, its axis into the palm (held from the top), above its place.
    assert hand_distances(place.trajectory, dict(place.trajectory.hands), "right", *TABLE).min() > 0.0
    robot = UrdfRobot(place.trajectory.robot, dict(place.trajectory.hands))
    end = place.trajectory.points[-1].positions
    robot.configure(dict(place.trajectory.start) | dict(zip(place.trajectory.joint_names, end)))
    tool = robot.pose("right_tool")
    assert tool.rotation[:, 2] @ (0.0, 0.0, -1.0) > np.cos(0.05)  # the palm faces down onto the rim
    assert np.allclose(tool.translation, (0.45, 0.75, 0.75 + 0.04 + 0.03), atol=1e-3)  # the bowl's top


def test_the_old_form_holds_a_full_bowl_by_the_side_and_cannot_put_it_down(tmp_path):
    task = (DATA / "soup_bowl_held_top.yaml").read_text().replace("{arm: right, grasp: TopGrasp}", "right")
    (tmp_path / "t.yaml").write_text(task)
    (step,) = TaskRunner(load_task(tmp_path / "t.yaml")).run().steps
    assert step.status == "unreachable_goal" and "right_hand_finger_0 - table" in step.message
    assert step.message.endswith("(holding soup by SideGrasp)")


def test_validate_against_the_task_uses_the_grasp_the_trajectory_records(tmp_path):
    # Failed before: the re-derived upright assumed the side grasp and was broken by 1.49 rad.
    _, runner, outcome = planned("soup_bowl_held_searched")
    trajectory = next(s for s in outcome.steps if s.name == "put_down").trajectory
    rederived = against_task(trajectory, runner)
    assert [c.spec for c in rederived.constraints] == [c.spec for c in trajectory.constraints]
    assert constraint_violations(rederived) == []
    trajectory.save(tmp_path / "put_down.json")
    task = str(DATA / "soup_bowl_held_searched.yaml")
    result = CliRunner().invoke(app, ["validate", str(tmp_path / "put_down.json"), "--task", task, "-q"])
    assert result.exit_code == 0, result.output
    assert "upright_soup" in result.output and "kept" in result.output


def test_a_recorded_grasp_the_task_does_not_allow_is_one_error():
    _, runner, outcome = planned("soup_bowl_held_searched")
    trajectory = next(s for s in outcome.steps if s.name == "put_down").trajectory
    handled = trajectory.model_copy(update={"grasps": {"soup": "HandleGrasp"}})
    with pytest.raises(HriplanError, match="^soup is held by HandleGrasp in the trajectory, a grasp the task"):
        against_task(handled, runner)


def test_a_stated_grasp_the_kind_does_not_afford_is_one_error(tmp_path):
    task = (DATA / "soup_bowl_held_top.yaml").read_text().replace("grasp: TopGrasp", "grasp: HandleGrasp")
    (tmp_path / "t.yaml").write_text(task)
    with pytest.raises(HriplanError, match="^soup is held by HandleGrasp, which its kind does not afford; it affords "):
        TaskRunner(load_task(tmp_path / "t.yaml")).run(plan=False)


def test_a_bowl_put_down_then_picked_again_is_searched_again(tmp_path):
    # Failed before: the first step's chosen grasp was passed on as a recorded grasp name, so the
    # second step's search raised "soup is held by Grasp(...) in the trajectory".
    task = (DATA / "soup_bowl_held_searched.yaml").read_text()
    task = task.replace("planning:", "  - {name: pick_up, goal: {grasp: soup}}\nplanning:")
    (tmp_path / "t.yaml").write_text(task)
    outcome = TaskRunner(load_task(tmp_path / "t.yaml")).run(plan=False)
    assert [s.name for s in outcome.steps] == ["put_down", "pick_up"]


def test_a_failing_step_of_an_arm_without_a_hand_says_along_which_tool_axis_it_holds(tmp_path):
    """An arm without a robot hand holds objects along its usual axis (the UR10 carrier's -z):
    the failure says so, not "by usual" (a grasp name no task file uses)."""
    examples = Path(__file__).parents[2] / "examples"
    task = (examples / "ur10_carry_upright_supervisor.yaml").read_text().replace("[0.0, 0.9, 0.77]", "[0.0, 3.0, 0.77]")
    (tmp_path / "far.yaml").write_text(task.replace("robot: robots/", f"robot: {examples}/robots/"))
    (step,) = TaskRunner(load_task(tmp_path / "far.yaml"), tmp_path).run().steps
    assert step.status == "unreachable_goal"
    assert step.message.endswith("(holding tray along the tool's -z)")
