"""Every moving robot part against one person's bare capsules, at many robot states at once.

Why: speed and separation monitoring asks, at every point of a path, how far each moved part is
from each capsule of a person and how fast its closest point moves. `CollisionChecker.
person_pairs` answers one configuration through coal, and reading ~500 results from Python per
point dominated the timing. Here forward kinematics runs per state in pinocchio, the capsule
pairs (nearly all of them) go through one vectorised pass of `capsule_distances`, and only the
other shapes (palm boxes, adapters, carried objects) through coal, on a model holding just them,
and only the rows the caller cannot rule out from cheap bounds: the part's bounding sphere gives
a lower bound on its distance and its joint's twist an upper bound on its speed. Reading coal's
results from Python cost more than the rest of a timing call's monitor.
"""

from __future__ import annotations

from collections.abc import Callable, Collection
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
    distance: np.ndarray  # (N, k) to the bare capsule, m; negative when they overlap; inf: not measured
    robot_point: np.ndarray  # (N, k, 3) world: the part's closest point
    person_point: np.ndarray  # (N, k, 3) world: the capsule's closest point
    robot_velocity: np.ndarray  # (N, k, 3) world: the velocity of robot_point for the state's joint velocity


# What `PersonDistances.at` asks a caller: given the capsule rows measured, the non-capsule rows'
# indices (m), a lower bound on each one's distance and an upper bound on its part's speed (N, m),
# which of them to measure (N, m).
Select = Callable[[StatePairs, np.ndarray, np.ndarray, np.ndarray], np.ndarray]
# A lower bound is lowered by this (m) to stay below coal's answer: its GJK stops when the squared
# distance is within 1e-6, ~1e-5 m at 2 cm (the same pair differs by 9e-6 m from another start).
_COAL_TOLERANCE = 1e-4
# An upper bound on a speed is raised by this, relatively and absolutely (m/s): float rounding.
_ROUNDING = 1e-9
# A sphere's axis (any unit vector: its half length is 0).
_ANY_AXIS = np.array([0.0, 0.0, 1.0])

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
        # Each non-capsule part's bounding sphere: centre in its joint's frame (m, 3, 1), radius (m).
        spheres = [_bounding_sphere(objects[pairs[k][0]]) for k in self._other_rows]
        self._other_centre = np.array([c for c, _ in spheres]).reshape(-1, 3, 1)
        self._other_radius = np.array([r for _, r in spheres])

    def at(self, qs: np.ndarray, dqs: np.ndarray, select: Select | None = None) -> StatePairs:
        """Every row at configurations `qs` (N, nq) moving with joint velocities `dqs` (N, nv).

        The non-capsule rows go through coal, one pair per call, only where `select` (default:
        everywhere) asks: it gets the capsule rows measured (the others at distance inf), the
        non-capsule rows' indices, a lower bound on each one's distance and an upper bound on the
        speed of any point of its part, both (N, m), and returns which to measure, (N, m). A row
        left out stays at distance inf with both points at its joint's origin: a caller selects
        every row that could change its answer (reading coal's results from Python is most of
        the cost)."""
        frames, twists = self._walk(qs, dqs)
        rotation, origin = frames[..., :3, :3], frames[..., :3, 3]
        # data.v is the joint's spatial velocity in its own frame: rotate it to the world.
        linear, angular = (rotation @ twists[..., :3, None])[..., 0], (rotation @ twists[..., 3:, None])[..., 0]
        distance = np.full((len(qs), len(self.parts)), np.inf)
        robot_point = origin[:, self._frame].copy()
        person_point = robot_point.copy()
        if self._capsule_rows.size:
            rows = self._capsule_rows
            distance[:, rows], robot_point[:, rows], person_point[:, rows] = self._capsule_pairs(rotation, origin)
        frame = self._frame
        velocity = _point_velocity(linear[:, frame], angular[:, frame], origin[:, frame], robot_point)
        pairs = StatePairs(self.parts, self.capsules, distance, robot_point, person_point, velocity)
        if self._other_rows.size:
            measure = np.ones((len(qs), self._other_rows.size), dtype=bool)
            if select is not None:
                measure = select(pairs, self._other_rows, *self._bounds(rotation, origin, linear, angular))
            states, rows = self._measure(qs, measure, (distance, robot_point, person_point))
            at = states, frame[rows]
            velocity[states, rows] = _point_velocity(linear[at], angular[at], origin[at], robot_point[states, rows])
        return pairs

    def _walk(self, qs: np.ndarray, dqs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per state: the carrying joints' placements (N, F, 4, 4) and local twists (N, F, 6)."""
        frames, twists = np.empty((len(qs), len(self._frames), 4, 4)), np.empty((len(qs), len(self._frames), 6))
        model, data = self.robot_model, self.robot_data
        placements, velocities = data.oMi, data.v
        for i, (q, dq) in enumerate(zip(qs, dqs)):
            pin.forwardKinematics(model, data, q, dq)
            for f, j in enumerate(self._frames):
                frames[i, f], twists[i, f] = placements[j].homogeneous, velocities[j].vector
        return frames, twists

    def _measure(
        self, qs: np.ndarray, measure: np.ndarray, out: tuple[np.ndarray, np.ndarray, np.ndarray]
    ) -> tuple[np.ndarray, np.ndarray]:
        """The non-capsule rows `measure` (N, m) asks for, by coal, into `out` (distance, robot
        point, person point); returns the (state, row) of each. Each result is read once and all of
        them turned into arrays at the end."""
        (others, other_data, copies), model, data = self._others, self.robot_model, self.robot_data
        for original, copy in copies.items():
            others.geometryObjects[copy].placement = self.person_model.geometryObjects[original].placement
        found = []
        for n in np.flatnonzero(measure.any(axis=1)):
            pin.updateGeometryPlacements(model, data, others, other_data, qs[n])
            for m in np.flatnonzero(measure[n]).tolist():
                r = pin.computeDistance(others, other_data, m)
                found.append((r.min_distance, r.getNearestPoint1(), r.getNearestPoint2()))
        states, rows = np.nonzero(measure)  # row-major: the order measured
        rows = self._other_rows[rows]
        if found:
            distance, robot_point, person_point = out
            distance[states, rows] = [d for d, _, _ in found]
            robot_point[states, rows] = [p for _, p, _ in found]
            person_point[states, rows] = [p for _, _, p in found]
        return states, rows

    def _bounds(
        self, rotation: np.ndarray, origin: np.ndarray, linear: np.ndarray, angular: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Per state and non-capsule row (N, m): a lower bound on its distance (its part's
        bounding sphere against the capsule, less coal's tolerance) and an upper bound on the
        speed of any point of the part (the sphere centre's speed plus spin times radius)."""
        frame, rows = self._frame[self._other_rows], self._other_rows
        centre = (rotation[:, frame] @ self._other_centre)[..., 0] + origin[:, frame]
        person_centre, person_axis = self._person_capsules(self._slot[rows])
        gap, _, _ = capsule_distances(
            centre,
            _ANY_AXIS,
            0.0,
            self._other_radius,
            person_centre,
            person_axis,
            self._person_half[rows],
            self._person_radius[rows],
        )
        spin = angular[:, frame]
        speed = np.linalg.norm(_point_velocity(linear[:, frame], spin, origin[:, frame], centre), axis=2)
        speed += np.linalg.norm(spin, axis=2) * self._other_radius
        return gap - _COAL_TOLERANCE, speed * (1.0 + _ROUNDING) + _ROUNDING

    def _person_capsules(self, slots: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World centres and axes of the person's capsules `slots` (indices into the person's
        capsules), read afresh from the model: the person may have been re-posed."""
        person = [self.person_model.geometryObjects[b].placement for b in self._slots]
        return np.array([m.translation for m in person])[slots], np.array([m.rotation[:, 2] for m in person])[slots]

    def _capsule_pairs(self, rotation: np.ndarray, origin: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The capsule rows from the carrying joints' world rotations and origins, in one pass."""
        placed = rotation[:, self._capsule_frame]
        centre = (placed @ self._local_centre)[..., 0] + origin[:, self._capsule_frame]
        axis = (placed @ self._local_axis)[..., 0]
        person_centre, person_axis = self._person_capsules(self._slot[self._capsule_rows])
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


def _point_velocity(linear: np.ndarray, angular: np.ndarray, origin: np.ndarray, point: np.ndarray) -> np.ndarray:
    """The world velocity of `point` on a body whose `origin` moves at `linear` and turns at
    `angular` (all (..., 3), world)."""
    return linear + np.cross(angular, point - origin)


def _bounding_sphere(part: pin.GeometryObject) -> tuple[np.ndarray, float]:
    """A sphere holding the part's shape (about its local bounding box): centre in the part's
    joint frame, radius."""
    shape = part.geometry.clone()  # computing the box on the model's own shape would change it
    shape.computeLocalAABB()
    return part.placement.act(np.asarray(shape.aabb_center, dtype=float)), float(shape.aabb_radius)


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
