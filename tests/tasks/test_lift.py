"""A picked object is lifted straight off what it stands on (planner/lift.py), then carried on."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin

from hriplan.planner.lift import lift_path
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.model import load_robot
from hriplan.robots.scene import Obstacle, Scene, Sphere
from hriplan.robots.spatial import Pose
from hriplan.tasks.goals import LIFT
from hriplan.tasks.load import load_task
from hriplan.tasks.pipeline import TaskRunner
from madar_states import CLEAR

DATA = Path(__file__).parents[1] / "data" / "people"


def object_bottoms(robot, trajectory, name: str) -> np.ndarray:
    """World position of the held object's bottom centre at every written point (FK + its grasp)."""
    held = next(a for a in trajectory.scene.attached if a.name == name)
    half = held.shape.height / 2
    bottoms = []
    for point in trajectory.points:
        q = robot.configuration(dict(trajectory.start) | dict(zip(trajectory.joint_names, point.positions)))
        centre = pin.SE3(robot.frame_pose(robot.tool_frame(held.arm), q)) * held.grasp.se3()
        bottoms.append(centre.translation - half * centre.rotation[:, 2])
    return np.array(bottoms)


def test_pick_then_place_lifts_the_cup_off_the_table_straight_up(tmp_path):
    # Before: the place step started with the cup standing on the table, "in collision (cup - table)".
    task = DATA / "pick_cup_then_place.yaml"
    runner = TaskRunner(load_task(task))
    outcome = runner.run()
    assert [(s.name, s.status) for s in outcome.steps] == [
        ("pick", "solved"),
        ("pick_lift", "solved"),
        ("place", "solved"),
        ("place_release", "solved"),
    ]
    pick, lift, place, _ = outcome.steps
    robot = runner.session.robot
    bottoms = object_bottoms(robot, lift.trajectory, "cup")
    top = 0.72  # the table's top (the task file)
    assert abs(bottoms[0, 2] - top) < 2e-3 and bottoms[-1, 2] >= top + LIFT - 2e-3
    assert np.diff(bottoms[:, 2]).min() >= -1e-6  # rises all the way: never back into the table
    assert np.abs(bottoms[:, :2] - bottoms[0, :2]).max() < 0.006
    assert lift.trajectory.scene.attached[0].resting_on == ["table"]
    assert not place.trajectory.scene.attached[0].resting_on
    # the steps join: every joint where the pick ends is where the lift starts, and so on
    for before, after in ((pick, lift), (lift, place)):
        end = dict(before.trajectory.start) | dict(
            zip(before.trajectory.joint_names, before.trajectory.points[-1].positions)
        )
        assert all(abs(after.trajectory.start[j] - v) < 1e-9 for j, v in end.items())
    # the independent validator (from the written file) accepts the lift
    path = tmp_path / "lift.json"
    lift.trajectory.save(path)
    checked = subprocess.run(
        [sys.executable, "-m", "hriplan.cli", "validate", str(path), "-q"], capture_output=True, text=True
    )
    assert checked.returncode == 0, checked.stdout + checked.stderr
    again = subprocess.run(
        [sys.executable, "-m", "hriplan.cli", "validate", str(path), "--task", str(task), "-q"],
        capture_output=True,
        text=True,
    )
    assert again.returncode == 2 and again.stderr.strip().splitlines()[-1].startswith(
        "error: step 'pick_lift' is the lift after task step 'pick'"
    )
    assert json.loads(path.read_text())["step"] == "pick_lift"


def test_a_lift_into_something_above_fails_with_the_reason():
    robot = load_robot("madar", {"right": "power"})
    q = robot.configuration(CLEAR)
    tool = robot.frame_pose("right_tool", q)[:3, 3]
    clear = CollisionChecker(robot, Scene())
    x, why = lift_path(robot, clear, "right", q, LIFT)
    assert why == "" and x is not None
    risen = robot.frame_pose("right_tool", robot.configuration(x[-1], "right_arm", base=q))[:3, 3]
    assert np.allclose(risen, tool + [0.0, 0.0, LIFT], atol=1e-5)
    # a ball just clear of the hand above it, found by stepping it up 1 cm at a time
    for height in np.arange(0.0, 0.4, 0.01):
        above = CollisionChecker(
            robot,
            Scene(
                obstacles=[
                    Obstacle(name="ball", shape=Sphere(radius=0.03), pose=Pose(xyz=tuple(tool + [0, 0, height])))
                ]
            ),
        )
        if not above.in_collision(q):
            break
    assert not above.in_collision(q) and height > 0.0
    x, why = lift_path(robot, above, "right", q, LIFT)
    assert x is None and why.startswith(f"no valid IK solution {LIFT} m above the grasp")
    assert "collides: " in why and " - ball" in why  # what bound it (before: "rejected by is_valid")
