"""Whole tasks: a step after a place or a handover with the same hand, both arms in sequence, a
posture goal, a step already where it goes (tests/data/whole_tasks/). Before the release, every step after a place started
"in collision: right_hand_finger_0 - cup".

Each release is re-checked on the URDF's collision meshes (tests/independent.py), apart from the
planner's capsules: the hand touches the released object at most on a first stretch, ends clear
of it with the posture the file records and with the task's closed hand, and the object stays
where it was put for every later step."""

import functools
from pathlib import Path

import coal
import numpy as np
import pytest

from hriplan import HriplanError
from hriplan.planner.lift import retreat_path
from hriplan.robots.descriptions.registry import posture
from hriplan.robots.model import load_robot
from hriplan.robots.scene import Obstacle, Sphere
from hriplan.robots.spatial import Pose
from hriplan.tasks.load import load_task
from hriplan.tasks.pipeline import TaskRunner
from independent import UrdfRobot, constraint_violations, hand_distances

DATA = Path(__file__).parents[1] / "data" / "whole_tasks"
STEPS = {
    "pick_place_home": ["pick", "pick_lift", "place", "place_release", "home"],
    "pick_place_pick_place": [
        *("pick_1", "pick_1_lift", "place_1", "place_1_release"),
        *("pick_2", "pick_2_lift", "place_2", "place_2_release"),
    ],
    "handover_then_ready": ["hand_over", "hand_over_release", "back"],
    "hot_mug_to_seated_receiver": ["hand_over", "hand_over_release", "back", "stay"],
    "two_arms_in_sequence": ["put_cup", "put_cup_release", "pick_bottle", "pick_bottle_lift"],
    "two_objects_two_arms": [
        *("pick_cup", "pick_cup_lift", "place_cup", "place_cup_release"),
        *("pick_bottle", "pick_bottle_lift", "place_bottle", "place_bottle_release", "home"),
    ],
    "take_place_ready": ["take_1", "place_1", "place_1_release", "back"],
    "pick_hand_over_ready": ["pick", "pick_lift", "give_prepare", "give", "give_release", "back"],
    "soup_bowl_held_top": ["put_down_prepare", "put_down", "put_down_release"],
    "soup_bowl_held_searched": ["put_down_prepare", "put_down", "put_down_release"],
}


@functools.cache
def run(name: str):
    task = load_task(DATA / f"{name}.yaml")
    return name, task, TaskRunner(task, DATA).run()


@pytest.fixture(params=sorted(STEPS))
def planned(request):
    return run(request.param)


def test_each_whole_task_plans_every_step_and_every_trajectory_holds_its_constraints(planned):
    name, _, outcome = planned
    assert [(s.name, s.status) for s in outcome.steps] == [(s, "solved") for s in STEPS[name]], [
        s.message for s in outcome.steps
    ]
    for step in outcome.steps:
        assert constraint_violations(step.trajectory) == [], step.name
    for before, after in zip(outcome.steps, outcome.steps[1:]):  # each starts where the one before ended
        end = dict(before.trajectory.start) | dict(
            zip(before.trajectory.joint_names, before.trajectory.points[-1].positions)
        )
        assert max(abs(after.trajectory.start[j] - v) for j, v in end.items()) < 1e-9


def test_a_released_object_is_left_where_it_was_put_and_the_hand_backs_away_clear_of_it(planned):
    _, task, outcome = planned
    for k, step in enumerate(outcome.steps):
        if not step.name.endswith("_release"):
            continue
        (arm,) = step.arms
        (released,) = [o for o in step.trajectory.scene.obstacles if o.touched_by == arm]
        recorded = dict(step.trajectory.hands)
        for hands in (recorded, recorded | {arm: task.hands[arm]}):  # as it backs away, as the next step has it
            shape = coal.Cylinder(released.shape.radius, released.shape.height)
            d = hand_distances(step.trajectory, hands, arm, shape, released.pose.matrix())
            assert d[-1] > 0.0, (step.name, hands)
            clear = int(np.argmax(d > 0.0))
            assert (d[clear:] > 0.0).all(), (step.name, hands, d)  # once clear, it stays clear
        # the released object is where it was put for every later step, as the task state has it
        for later in outcome.steps[k + 1 :]:
            there = [o for o in later.trajectory.scene.obstacles if o.name == released.name]
            if there:
                assert np.allclose(there[0].pose.matrix(), released.pose.matrix(), atol=1e-12)
                break  # a later pick moves it


def test_a_place_is_released_with_the_hand_opened_to_its_release_posture_straight_back():
    _, _, outcome = run("pick_place_home")
    (release,) = [s for s in outcome.steps if s.name.endswith("_release")]
    place = next(s for s in outcome.steps if s.name == "place")
    assert (place.trajectory.hands["right"], release.trajectory.hands["right"]) == ("power", "release")
    # it backs away at least 6 cm, straight: the tool's path is a line within 5 mm
    robot = UrdfRobot("madar", dict(release.trajectory.hands))
    tips = []
    for point in release.trajectory.points:
        robot.configure(dict(release.trajectory.start) | dict(zip(release.trajectory.joint_names, point.positions)))
        tips.append(robot.pose("right_tool").translation.copy())
    tips = np.array(tips)
    line = (tips[-1] - tips[0]) / np.linalg.norm(tips[-1] - tips[0])
    off = tips - tips[0] - np.outer((tips - tips[0]) @ line, line)
    assert np.linalg.norm(tips[-1] - tips[0]) >= 0.06 - 1e-6 and np.linalg.norm(off, axis=1).max() < 0.0055


def test_a_retreat_that_cannot_leave_the_object_or_starts_in_collision_says_why():
    _, _, outcome = run("pick_place_home")
    place, release = (next(s for s in outcome.steps if s.name == n) for n in ("place", "place_release"))
    opened, closed = (
        load_robot("madar", dict(release.trajectory.hands)),
        load_robot("madar", dict(place.trajectory.hands)),
    )
    came = place.trajectory
    arrival = [closed.configuration(dict(came.start) | dict(zip(came.joint_names, p.positions))) for p in came.points]
    scene = release.trajectory.scene
    used, path, why = retreat_path(
        [opened, closed],
        closed,
        "right",
        arrival,
        "cup",
        scene,
        scene.model_copy(update={"obstacles": [o.model_copy(update={"touched_by": None}) for o in scene.obstacles]}),
    )
    assert used is opened and path is not None and why == ""
    # a ball of a cup 40 cm wide around the hand: every way, the hand still touches it 16 cm on
    huge = [o.model_copy(update={"shape": Sphere(radius=0.2)}) if o.name == "cup" else o for o in scene.obstacles]
    touching = scene.model_copy(update={"obstacles": huge})
    free = scene.model_copy(update={"obstacles": [o.model_copy(update={"touched_by": None}) for o in huge]})
    used, path, why = retreat_path([opened], closed, "right", arrival, "cup", touching, free)
    assert used is None and path is None
    assert why.count("the hand still touches cup") == 3 and why.startswith("the hand release, away from the palm: ")
    # a ball around the hand: it collides at the release already
    tool = opened.frame_pose("right_tool", arrival[-1])[:3, 3]
    ball = Obstacle(name="ball", shape=Sphere(radius=0.15), pose=Pose(xyz=tuple(tool)))
    boxed = scene.model_copy(update={"obstacles": [*scene.obstacles, ball]})
    used, path, why = retreat_path([opened], closed, "right", arrival, "cup", boxed, boxed)
    assert path is None and why.startswith("the hand release at the release collides: ") and "ball" in why


def test_an_unknown_posture_goal_is_one_line_naming_the_step(tmp_path):
    text = (DATA / "pick_place_home.yaml").read_text().replace("{posture: home}", "{posture: dance}")
    (tmp_path / "t.yaml").write_text(text)
    with pytest.raises(HriplanError) as info:
        load_task(tmp_path / "t.yaml")
    assert (
        str(info.value)
        == f"{tmp_path / 't.yaml'}: steps.2: robot 'madar' has no posture 'dance'; postures: home, ready"
    )


def test_a_posture_goal_ends_at_the_posture_for_the_arm_it_moves():
    _, _, outcome = run("pick_place_home")
    home, last = posture("madar", "home"), outcome.steps[-1].trajectory
    end = dict(zip(last.joint_names, last.points[-1].positions))
    assert set(end) == {j for j in end if j.startswith("right_")} and len(end) == 6
    assert all(abs(v - home.get(j, 0.0)) < 1e-6 for j, v in end.items()), end
    assert abs(end["right_shoulder_lift_joint"] - home["right_shoulder_lift_joint"]) < 1e-6


def test_both_arms_go_to_a_posture_in_one_step():
    """Two posture goals in one step were refused ("needs a tool or object goal for each arm")."""
    _, _, outcome = run("two_objects_two_arms")
    last, home = outcome.steps[-1].trajectory, posture("madar", "home")
    end = dict(last.start) | dict(zip(last.joint_names, last.points[-1].positions))
    arm_joints = [j for j in end if j.startswith(("right_", "left_")) and "hand" not in j]
    assert len(arm_joints) == 12 and max(abs(end[j] - home.get(j, 0.0)) for j in arm_joints) < 1e-6
