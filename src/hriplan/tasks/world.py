"""Where things are while a task runs: who holds each object, and the scene that follows.

Objects move between steps (taken, handed over, placed); the task state says where each one is
and the planning scene (obstacles, carried objects, people) is rebuilt from it for every step.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from hriplan.robots.bounding import frame_with_z
from hriplan.robots.human import HELD_OBJECT_OFFSET, Human, HumanSpec
from hriplan.robots.scene import AttachedObject, Obstacle, Scene, table
from hriplan.robots.spatial import Pose

from .model import TaskFile, TaskHuman, TaskObject

AXIS_INDEX = {"x": 0, "y": 1, "z": 2}


def human_spec(person: TaskHuman) -> HumanSpec:
    return HumanSpec(**person.model_dump(include=set(HumanSpec.model_fields)))


def in_hand_pose(person: TaskHuman) -> Pose:
    """Upright object held in front of the person's active hand (person frames face forward)."""
    frame = Human(human_spec(person)).frame(f"{person.hand}_hand")
    centre = frame.translation + frame.rotation[:, 0] * HELD_OBJECT_OFFSET
    return Pose(xyz=tuple(float(v) for v in centre))


def object_in_tool(object_axis: str) -> pin.SE3:
    """Pose of a held object in the tool frame: its z axis along the arm's signed object axis."""
    axis = np.zeros(3)
    axis[AXIS_INDEX[object_axis[1]]] = -1.0 if object_axis[0] == "-" else 1.0
    return pin.SE3(frame_with_z(axis), np.zeros(3))


@dataclass
class TaskState:
    """Per object: held by a robot arm, by a person, or standing at a pose; per arm, where its
    tool frame is (held objects move with it)."""

    task: TaskFile
    held_by_arm: dict[str, str] = field(default_factory=dict)
    held_by_person: dict[str, str] = field(default_factory=dict)
    poses: dict[str, Pose] = field(default_factory=dict)
    tools: dict[str, Pose] = field(default_factory=dict)  # world pose of each arm's tool frame now

    @classmethod
    def initial(cls, task: TaskFile) -> "TaskState":
        state = cls(task)
        for obj in task.objects:
            if obj.held_by:
                state.held_by_arm[obj.name] = obj.held_by
            elif obj.in_hand_of:
                state.held_by_person[obj.name] = obj.in_hand_of
            state.poses[obj.name] = obj.pose
        return state

    def object(self, name: str) -> TaskObject:
        return next(o for o in self.task.objects if o.name == name)

    def person(self, name: str) -> TaskHuman:
        return next(h for h in self.task.humans if h.name == name)

    def pose(self, name: str) -> Pose:
        """Where the object is now: in a person's hand, in front of it; in a robot's hand, its
        centre at the tool frame (a position: the grasp says how it is turned); else its pose."""
        if name in self.held_by_person:
            return in_hand_pose(self.person(self.held_by_person[name]))
        arm = self.held_by_arm.get(name)
        if arm is not None and arm in self.tools:
            return Pose(xyz=self.tools[arm].xyz)
        return self.poses[name]

    def scene(self, object_axes: dict[str, str], touched: dict[str, str] | None = None) -> Scene:
        """The planning scene now: every object wherever it is (on a table, in a person's hand, in
        the robot's hand). `touched`: object -> the arm whose hand closes on it in this step,
        which alone may touch it."""
        touched = touched or {}
        obstacles = [table(t.name, t.size, t.top, t.position) for t in self.task.scene.tables]
        obstacles += list(self.task.scene.obstacles)
        attached = []
        for obj in self.task.objects:
            if obj.shape is None:
                continue
            if obj.name in self.held_by_arm:
                arm = self.held_by_arm[obj.name]
                grasp = Pose.from_se3(object_in_tool(object_axes[arm]))
                attached.append(AttachedObject(name=obj.name, shape=obj.shape, arm=arm, grasp=grasp))
            else:
                obstacles.append(Obstacle(name=obj.name, shape=obj.shape, pose=self.pose(obj.name), touched_by=touched.get(obj.name)))
        return Scene(obstacles=obstacles, attached=attached, humans=[human_spec(h) for h in self.task.humans])
