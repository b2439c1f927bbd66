"""Where things are while a task runs: who holds each object, and the scene that follows.

Objects move between steps (taken, handed over, placed); the task state says where each one is
and the planning scene (obstacles, carried objects, people) is rebuilt from it for every step.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from hriplan.robots.human import HELD_OBJECT_OFFSET, HumanSpec, person_frame
from hriplan.robots.scene import AttachedObject, Box, Cone, Cylinder, Obstacle, Scene, Shape, Sphere, table
from hriplan.robots.spatial import Pose, Transform
from hriplan.tasks.grasps import Grasp, object_length
from hriplan.tasks.model import TaskFile, TaskHuman, TaskObject

# A handed object's face nearest the person stays this far in front of their palm centre: an
# upright can (r 3.3 cm) held HELD_OBJECT_OFFSET in front of it.
NEAR_FACE_CLEARANCE = HELD_OBJECT_OFFSET - 0.033


def human_spec(person: TaskHuman) -> HumanSpec:
    return HumanSpec(**person.model_dump(include=set(HumanSpec.model_fields)))


def in_hand_pose(person: TaskHuman) -> Pose:
    """Upright object held in front of the person's active hand (person frames face forward)."""
    frame = person_frame(human_spec(person), f"{person.hand}_hand")
    centre = frame.translation + frame.rotation[:, 0] * HELD_OBJECT_OFFSET
    return Pose(xyz=tuple(float(v) for v in centre))


def handover_point(person: TaskHuman, shape: Shape | None, rotation: np.ndarray) -> Transform:
    """Where an object turned by `rotation` is handed to a person: in front of their active hand,
    its face nearest them as far from the palm as an upright can's (a long knife lying along the
    way they face goes further out, so it does not reach into their hand)."""
    frame = person_frame(human_spec(person), f"{person.hand}_hand")
    forward = frame.rotation[:, 0]
    offset = max(HELD_OBJECT_OFFSET, NEAR_FACE_CLEARANCE + extent_along(shape, rotation, forward))
    return Transform(rotation, frame.translation + forward * offset)


def extent_along(shape: Shape | None, rotation: np.ndarray, direction: np.ndarray) -> float:
    """How far a centred shape turned by `rotation` reaches from its centre along `direction`."""
    c = np.abs(rotation.T @ direction)  # direction in the shape's frame, by magnitude
    if isinstance(shape, (Cylinder, Cone)):
        return float(c[2] * shape.height / 2.0 + np.sqrt(max(0.0, 1.0 - c[2] ** 2)) * shape.radius)
    if isinstance(shape, Box):
        return float(c @ np.array(shape.size) / 2.0)
    if isinstance(shape, Sphere):
        return shape.radius
    return 0.0


@dataclass
class TaskState:
    """Per object: held by a robot arm, by a person, or standing at a pose; per arm, where its
    tool frame is (held objects move with it)."""

    task: TaskFile
    held_by_arm: dict[str, str] = field(default_factory=dict)
    held_by_person: dict[str, str] = field(default_factory=dict)
    poses: dict[str, Pose] = field(default_factory=dict)
    tools: dict[str, Pose] = field(default_factory=dict)  # world pose of each arm's tool frame now
    grasps: dict[str, Grasp] = field(default_factory=dict)  # how each held object is held

    @classmethod
    def initial(cls, task: TaskFile) -> TaskState:
        state = cls(task)
        for obj in task.objects:
            if obj.holding_arm:
                state.held_by_arm[obj.name] = obj.holding_arm
            elif obj.in_hand_of:
                state.held_by_person[obj.name] = obj.in_hand_of
            state.poses[obj.name] = obj.pose
        return state

    def copied(self) -> TaskState:
        """A copy to change (what a motion added to a step sees) without changing this state."""
        return replace(
            self,
            held_by_arm=dict(self.held_by_arm),
            held_by_person=dict(self.held_by_person),
            poses=dict(self.poses),
            tools=dict(self.tools),
            grasps=dict(self.grasps),
        )

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
        if arm is not None and arm in self.tools and name in self.grasps:
            return Pose.from_se3(self.tools[arm].se3() * self.in_tool(name))
        return self.poses[name]

    def in_tool(self, name: str) -> Transform:
        """Pose of a held (or about to be held) object in its arm's tool frame, by its grasp."""
        return self.grasps[name].object_in_tool(object_length(self.object(name).shape))

    def scene(self, touched: dict[str, str] | None = None) -> Scene:
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
                attached.append(
                    AttachedObject(name=obj.name, shape=obj.shape, arm=arm, grasp=Pose.from_se3(self.in_tool(obj.name)))
                )
            else:
                obstacles.append(
                    Obstacle(name=obj.name, shape=obj.shape, pose=self.pose(obj.name), touched_by=touched.get(obj.name))
                )
        return Scene(obstacles=obstacles, attached=attached, humans=[human_spec(h) for h in self.task.humans])
