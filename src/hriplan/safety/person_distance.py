"""Every moving robot part against one person's bare capsules, at many robot states at once.

Why: speed and separation monitoring asks, at every point of a path, how far each moved part is
from each capsule of a person and how fast its closest point moves. `CollisionChecker.
person_pairs` answers one configuration through coal, and reading ~500 results from Python per
point dominated the timing. Here forward kinematics runs per state in pinocchio, the capsule
pairs (nearly all of them) go through one vectorised pass of `capsule_distances`, and only the
other shapes (palm boxes, adapters, carried objects) through coal, on a model holding just them.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass

import coal
import numpy as np
import pinocchio as pin

from hriplan.recent import Recent
from hriplan.safety.capsule_distance import capsule_distances


@dataclass(frozen=True)
class StatePairs:
    """Row k: one moved part against one capsule of the person, over N states (axis 0)."""

    parts: list[str]
    capsules: list[str]
    distance: np.ndarray  # (N, k) to the bare capsule, m; negative when they overlap
    robot_point: np.ndarray  # (N, k, 3) world: the part's closest point
    person_point: np.ndarray  # (N, k, 3) world: the capsule's closest point
    robot_velocity: np.ndarray  # (N, k, 3) world: the velocity of robot_point for the state's joint velocity


# PersonDistances made lately, by robot model, person model and joints (`PersonDistances.of`).
_MADE: Recent[tuple[int, int, frozenset[int]], PersonDistances] = Recent(8)


class PersonDistances:
    """The rows of a person model (`CollisionChecker.person_model`) whose part rides on one of
    `joints`, in the model's pair order, evaluated in batches of states. It reads the person's
    placements afresh at every batch, so one serves the model wherever its person moves."""

    @classmethod
    def of(cls, robot_model: pin.Model, person_model: pin.GeometryModel, joints: Collection[int]) -> PersonDistances:
        """The one made last for these models and joints, else a new one: a checker keeps a person
        model across builds and re-poses, and every timing call makes a monitor (~2.5 ms to make)."""
        key = (id(robot_model), id(person_model), frozenset(joints))
        made = _MADE.get(key)  # held here, the models' ids are not reused while it is
        if made is None or made.robot_model is not robot_model or made.person_model is not person_model:
            made = cls(robot_model, person_model, joints)
            _MADE.put(key, made)
        return made

    def __init__(self, robot_model: pin.Model, person_model: pin.GeometryModel, joints: Collection[int]) -> None:
        self.robot_model, self.robot_data, self.person_model = robot_model, robot_model.createData(), person_model
        objects = person_model.geometryObjects
        pairs = [(p.first, p.second) for p in person_model.collisionPairs if objects[p.first].parentJoint in joints]
        self.parts = [objects[a].name for a, _ in pairs]
        self.capsules = [objects[b].name for _, b in pairs]
        self._slots = sorted({b for _, b in pairs})  # the person's capsules
        self._frames = sorted({objects[a].parentJoint for a, _ in pairs})
        self._frame = np.array([self._frames.index(objects[a].parentJoint) for a, _ in pairs], dtype=int)
        self._slot = np.array([self._slots.index(b) for _, b in pairs], dtype=int)
        self._person_half = np.array([objects[b].geometry.halfLength for _, b in pairs])
        self._person_radius = np.array([objects[b].geometry.radius for _, b in pairs])
        capsule = np.array([isinstance(objects[a].geometry, coal.Capsule) for a, _ in pairs], dtype=bool)
        self._capsule_rows, self._other_rows = np.flatnonzero(capsule), np.flatnonzero(~capsule)
        # A robot capsule meets every capsule of the person: place each once, then spread it over its rows.
        robot_capsules = sorted({pairs[k][0] for k in self._capsule_rows})
        self._robot_capsule = np.array([robot_capsules.index(pairs[k][0]) for k in self._capsule_rows], dtype=int)
        self._capsule_frame = np.array([self._frames.index(objects[a].parentJoint) for a in robot_capsules], dtype=int)
        self._local_axis = np.array([objects[a].placement.rotation[:, 2] for a in robot_capsules]).reshape(-1, 3, 1)
        self._local_centre = np.array([objects[a].placement.translation for a in robot_capsules]).reshape(-1, 3, 1)
        self._robot_half = np.array([objects[pairs[k][0]].geometry.halfLength for k in self._capsule_rows])
        self._robot_radius = np.array([objects[pairs[k][0]].geometry.radius for k in self._capsule_rows])
        self._others = _coal_model(person_model, [pairs[k] for k in self._other_rows])

    def at(self, qs: np.ndarray, dqs: np.ndarray) -> StatePairs:
        """Every row at configurations `qs` (N, nq) moving with joint velocities `dqs` (N, nv)."""
        n, rows = len(qs), len(self.parts)
        distance, robot_point, person_point = np.empty((n, rows)), np.empty((n, rows, 3)), np.empty((n, rows, 3))
        frames, twists = self._walk(qs, dqs, (distance, robot_point, person_point))
        rotation, origin = frames[..., :3, :3], frames[..., :3, 3]
        if self._capsule_rows.size:
            rows_c = self._capsule_rows
            distance[:, rows_c], robot_point[:, rows_c], person_point[:, rows_c] = self._capsule_pairs(rotation, origin)
        # data.v is the joint's spatial velocity in its own frame: rotate it to the world.
        linear = (rotation @ twists[..., :3, None])[..., 0][:, self._frame]
        angular = (rotation @ twists[..., 3:, None])[..., 0][:, self._frame]
        velocity = linear + np.cross(angular, robot_point - origin[:, self._frame])
        return StatePairs(self.parts, self.capsules, distance, robot_point, person_point, velocity)

    def _walk(
        self, qs: np.ndarray, dqs: np.ndarray, out: tuple[np.ndarray, np.ndarray, np.ndarray]
    ) -> tuple[np.ndarray, np.ndarray]:
        """Per state: the carrying joints' placements (N, F, 4, 4) and local twists (N, F, 6)
        returned, the non-capsule rows measured by coal into `out` (distance, robot, person point).
        Each coal result is read once and all of them turned into arrays at the end: reading
        results from Python is most of this loop's time."""
        frames, twists = np.empty((len(qs), len(self._frames), 4, 4)), np.empty((len(qs), len(self._frames), 6))
        (others, other_data, copies), model, data = self._others, self.robot_model, self.robot_data
        for original, copy in copies.items():
            others.geometryObjects[copy].placement = self.person_model.geometryObjects[original].placement
        placements, velocities, found = data.oMi, data.v, []
        for i, (q, dq) in enumerate(zip(qs, dqs)):
            pin.forwardKinematics(model, data, q, dq)
            for f, j in enumerate(self._frames):
                frames[i, f], twists[i, f] = placements[j].homogeneous, velocities[j].vector
            if self._other_rows.size:
                pin.updateGeometryPlacements(model, data, others, other_data)
                pin.computeDistances(others, other_data)
                found += [
                    (r.min_distance, r.getNearestPoint1(), r.getNearestPoint2()) for r in other_data.distanceResults
                ]
        if found:
            distance, robot_point, person_point = out
            shape = (len(qs), self._other_rows.size)
            rows = self._other_rows
            distance[:, rows] = np.array([d for d, _, _ in found]).reshape(shape)
            robot_point[:, rows] = np.array([p for _, p, _ in found]).reshape(shape + (3,))
            person_point[:, rows] = np.array([p for _, _, p in found]).reshape(shape + (3,))
        return frames, twists

    def _capsule_pairs(self, rotation: np.ndarray, origin: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The capsule rows from the carrying joints' world rotations and origins, in one pass."""
        placed = rotation[:, self._capsule_frame]
        centre = (placed @ self._local_centre)[..., 0] + origin[:, self._capsule_frame]
        axis = (placed @ self._local_axis)[..., 0]
        person = [self.person_model.geometryObjects[b].placement for b in self._slots]  # read afresh: re-posing
        slot = self._slot[self._capsule_rows]
        person_centre = np.array([m.translation for m in person])[slot]
        person_axis = np.array([m.rotation[:, 2] for m in person])[slot]
        return capsule_distances(
            centre[:, self._robot_capsule],
            axis[:, self._robot_capsule],
            self._robot_half,
            self._robot_radius,
            person_centre,
            person_axis,
            self._person_half[self._capsule_rows],
            self._person_radius[self._capsule_rows],
        )


def _coal_model(
    source: pin.GeometryModel, pairs: list[tuple[int, int]]
) -> tuple[pin.GeometryModel, pin.GeometryData, dict[int, int]]:
    """The pairs' geometries copied from `source` into a model of their own, pairs in the given
    order; with the copy index of every person capsule (static: placed afresh per batch)."""
    model, index = pin.GeometryModel(), {}
    for pair in pairs:
        for g in pair:
            if g not in index:
                index[g] = model.addGeometryObject(pin.GeometryObject(source.geometryObjects[g]))
        model.addCollisionPair(pin.CollisionPair(index[pair[0]], index[pair[1]]))
    people = {b for _, b in pairs}
    return model, model.createData(), {g: k for g, k in index.items() if g in people}
