"""The main job. Today: the physical world of the handover (MADAR, a person, a table, a can).

It loads MADAR with a power grasp on the right hand, places a person reaching out, finds an arm
configuration that holds the can upright beside the person's hand, and reports collisions and
clearance. Later stages replace this with the full task-to-trajectory handover pipeline.
"""

from __future__ import annotations

import time

import numpy as np

from hriplan.robots.collision import CollisionChecker
from hriplan.robots.human import HumanSpec
from hriplan.robots.ik import solve_ik
from hriplan.robots.model import load_robot
from hriplan.robots.scene import AttachedObject, Cylinder, Scene, table
from hriplan.robots.spatial import Pose

HAND_POINT = (0.0, 1.05, 1.05)
# The can's axis is the tool's y axis; the tool's y pointing up keeps it upright.
UPRIGHT_TOOL = np.column_stack([(-1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, 1.0, 0.0)])  # x, y (up), z (to the person)


def demo_scene() -> Scene:
    person = HumanSpec(name="receiver", position=(0.0, 1.45), yaw=-np.pi / 2, reach={"right": HAND_POINT})
    can = AttachedObject(name="coke_can", shape=Cylinder(radius=0.033, height=0.12), arm="right",
                         grasp=Pose(rpy=(-np.pi / 2, 0.0, 0.0)))  # fmt: skip
    return Scene(obstacles=[table(position=(0.45, 0.9), size=(0.6, 0.6, 0.04), top=0.72)], attached=[can], humans=[person])


def run_demo() -> str:
    start = time.perf_counter()
    robot = load_robot("madar", {"right": "power"})
    checker = CollisionChecker(robot, demo_scene())
    loaded = time.perf_counter() - start
    person = checker.humans["receiver"]
    hand = person.frame("right_hand").translation
    target = np.eye(4)
    target[:3, :3] = UPRIGHT_TOOL
    target[:3, 3] = hand + np.array([0.0, -0.15, 0.0])
    q_left = robot.configuration({"left_shoulder_lift_joint": -2.2, "left_elbow_joint": 1.2})
    result = solve_ik(robot, "right", target, free_axes=("y",), base_q=q_left,
                      is_valid=lambda q: not checker.in_collision(q))  # fmt: skip
    lines = [
        f"MADAR loaded with {len(checker.parts)} collision parts, scene of {checker.geom_model.ngeoms} geometries "
        f"and {len(checker.geom_model.collisionPairs)} checked pairs in {loaded:.1f} s",
        f"receiver's right hand at {np.round(hand, 3).tolist()} (reach IK on the human arm)",
    ]
    if not result.success:
        return "\n".join([*lines, f"no collision-free reach pose: {result.message}"])
    q = robot.configuration(result.q, "right_arm", base=q_left)
    tool = robot.frame_pose("right_tool", q)
    distance, part, body = checker.human_distance(q)
    tilt = np.degrees(np.arccos(np.clip(tool[2, 1], -1.0, 1.0)))
    lines += [
        f"right arm reach pose (IK, can upright, free spin): {np.round(result.q, 3).tolist()}",
        f"tool at {np.round(tool[:3, 3], 3).tolist()}, can axis tilt {tilt:.2f} deg",
        f"in collision: {checker.in_collision(q)}; closest to the person: {part} - {body} at {distance:.3f} m",
    ]
    return "\n".join(lines)
