"""Collision checking and clearance for a robot in a scene with people.

One pinocchio GeometryModel holds the robot's parts, the carried objects, the obstacles and the
people's capsules; the pairs to check are fixed when the scene's *contents* change. Moving an
obstacle or re-posing a person only rewrites placements, so the robot is never rebuilt.
"""

from __future__ import annotations

from dataclasses import dataclass

import coal
import numpy as np
import pinocchio as pin

from hriplan import HriplanError

from .acm import load_acm
from .human import Human, HumanSpec
from .model import Robot
from .robot_geometry import robot_parts
from .scene import Scene
from .spatial import Pose


@dataclass(frozen=True)
class Contact:
    a: str
    b: str


class CollisionChecker:
    """Robot vs scene, robot vs people, robot self-collision and carried objects vs the rest."""

    def __init__(self, robot: Robot, scene: Scene | None = None, padding: float = 0.0) -> None:
        self.robot = robot
        self.parts = robot_parts(robot, padding)
        self.acm = load_acm(robot, robot_parts(robot))
        self.humans: dict[str, Human] = {}
        self.set_scene(scene or Scene())

    # -- building ---------------------------------------------------------------------------
    def set_scene(self, scene: Scene) -> None:
        """Replace the scene's contents (pairs are recomputed; the robot model is kept)."""
        self.scene = scene
        gm = pin.GeometryModel()
        self.kind: list[str] = []  # per geometry: robot, attached:<arm>, obstacle, human
        for part in self.parts:
            gm.addGeometryObject(pin.GeometryObject(part.name, part.joint, part.placement, part.geometry))
            self.kind.append("robot")
        for obj in scene.attached:
            tool = self.robot.frame_id(self.robot.tool_frame(obj.arm))
            frame = self.robot.model.frames[tool]
            gm.addGeometryObject(
                pin.GeometryObject(obj.name, frame.parentJoint, frame.placement * obj.grasp.se3(), obj.shape.geometry())
            )
            self.kind.append(f"attached:{obj.arm}")
        self._touched_by = {o.name: o.touched_by for o in scene.obstacles if o.touched_by is not None}
        for obstacle in scene.obstacles:
            gm.addGeometryObject(pin.GeometryObject(obstacle.name, 0, obstacle.pose.se3(), obstacle.shape.geometry()))
            self.kind.append("obstacle")
        self._human_slots: dict[str, list[int]] = {}
        kept = {h.name: self.humans[h.name] for h in scene.humans if h.name in self.humans and self.humans[h.name].spec.height == h.height}
        self.humans = {}
        for spec in scene.humans:
            human = kept.get(spec.name) or Human(spec)
            human.pose(spec)
            self.humans[spec.name] = human
            slots = []
            for capsule, placement in zip(human.capsules, human.capsule_placements()):
                geometry = coal.Capsule(capsule.radius + spec.margin, capsule.length)
                slots.append(gm.addGeometryObject(pin.GeometryObject(f"{spec.name}/{capsule.name}", 0, placement, geometry)))
                self.kind.append("human")
            self._human_slots[spec.name] = slots
        self.geom_model = gm
        self._add_pairs()
        self.geom_data = gm.createData()
        # The naive manager loops over the pairs with an AABB test first: fastest here (benchmark).
        self._broadphase = pin.BroadPhaseManager_NaiveCollisionManager(self.robot.model, gm, self.geom_data)
        self._index = {g.name: i for i, g in enumerate(gm.geometryObjects)}
        self._build_distance_model()

    def _build_distance_model(self) -> None:
        """Robot parts and people only, with robot-person pairs: distances in one C++ call."""
        dm = pin.GeometryModel()
        robot_ids = [i for i, k in enumerate(self.kind) if k == "robot"]
        human_ids = [i for i, k in enumerate(self.kind) if k == "human"]
        for i in robot_ids + human_ids:
            dm.addGeometryObject(pin.GeometryObject(self.geom_model.geometryObjects[i]))
        for a in range(len(robot_ids)):
            for b in range(len(robot_ids), len(robot_ids) + len(human_ids)):
                dm.addCollisionPair(pin.CollisionPair(a, b))
        self._distance_model, self._distance_data = dm, dm.createData()
        self._distance_slots = {i: k for k, i in enumerate(robot_ids + human_ids)}

    def _checked(self, i: int, j: int) -> bool:
        ki, kj = self.kind[i], self.kind[j]
        names = (self.geom_model.geometryObjects[i].name, self.geom_model.geometryObjects[j].name)
        static = ("obstacle", "human")
        if ki in static and kj in static:
            return False
        if ki == "robot" and kj == "robot":
            return f"{names[0]}|{names[1]}" not in self.acm and f"{names[1]}|{names[0]}" not in self.acm
        for k, this, other in ((ki, i, j), (kj, j, i)):
            if self.kind[other] != "robot":
                continue
            # A carried object touches its own hand and wrist by design, and so does an object
            # the hand is closing on.
            arm = k.split(":", 1)[1] if k.startswith("attached:") else self._touched_by.get(self.geom_model.geometryObjects[this].name)
            if arm is not None:
                return not self._on_hand(other, arm)
        return True

    def _on_hand(self, part_index: int, arm: str) -> bool:
        part = self.geom_model.geometryObjects[part_index]
        return part.parentJoint == self._tool_joint(arm) and part.name.startswith(self.robot.arms[arm][0])

    def _tool_joint(self, arm: str) -> int:
        return self.robot.model.frames[self.robot.frame_id(self.robot.tool_frame(arm))].parentJoint

    def _add_pairs(self) -> None:
        n = self.geom_model.ngeoms
        for i in range(n):
            for j in range(i + 1, n):
                if self._checked(i, j):
                    self.geom_model.addCollisionPair(pin.CollisionPair(i, j))

    # -- updates (no rebuild) -------------------------------------------------------------
    def move_obstacle(self, name: str, pose: Pose) -> None:
        i = self._index.get(name)
        if i is None or self.kind[i] != "obstacle":
            raise HriplanError(f"the scene has no obstacle {name!r}")
        self.geom_model.geometryObjects[i].placement = pose.se3()

    def pose_human(self, spec: HumanSpec) -> None:
        """Re-pose a person already in the scene: only capsule placements change."""
        if spec.name not in self.humans:
            raise HriplanError(f"the scene has no person {spec.name!r}")
        human = self.humans[spec.name]
        human.pose(spec)
        for slot, placement in zip(self._human_slots[spec.name], human.capsule_placements()):
            self.geom_model.geometryObjects[slot].placement = placement
            self._distance_model.geometryObjects[self._distance_slots[slot]].placement = placement

    # -- queries --------------------------------------------------------------------------
    def in_collision(self, q: np.ndarray) -> bool:
        """True if any checked pair collides at planning configuration `q`."""
        return bool(pin.computeCollisions(self.robot.model, self.robot.data, self._broadphase, q, True))

    def contacts(self, q: np.ndarray) -> list[Contact]:
        """Every colliding pair at `q`, by name (for error messages and reports)."""
        pin.computeCollisions(self.robot.model, self.robot.data, self.geom_model, self.geom_data, q, False)
        names = self.geom_model.geometryObjects
        return [
            Contact(names[p.first].name, names[p.second].name)
            for p, r in zip(self.geom_model.collisionPairs, self.geom_data.collisionResults)
            if r.isCollision()
        ]

    def human_distance(self, q: np.ndarray) -> tuple[float, str, str]:
        """(distance, robot part, human part) of the closest robot-human pair; inf without people."""
        dm = self._distance_model
        if not dm.collisionPairs:
            return float("inf"), "", ""
        pin.computeDistances(self.robot.model, self.robot.data, dm, self._distance_data, q)
        distances = [r.min_distance for r in self._distance_data.distanceResults]
        k = int(np.argmin(distances))
        pair = dm.collisionPairs[k]
        return float(distances[k]), dm.geometryObjects[pair.first].name, dm.geometryObjects[pair.second].name
