"""Every moving robot part against one person's bare capsules, at many robot states at once.

Why: speed and separation monitoring asks, at every point of a path, how far each moved part is
from each capsule of a person and how fast its closest point moves. `CollisionChecker.
person_pairs` answers one configuration through coal, and reading ~500 results from Python per
point dominated the timing. Here the joints are placed for all states at once
(`robots/batch_kinematics.py`) and every row gets two cheap bounds, its part's bounding sphere
against the capsule's axis (a lower bound on its distance) and its joint's twist (an upper bound
on its speed); only the rows the caller cannot rule out from them are measured: capsule pairs
(nearly all rows) in one vectorised pass of `capsule_distances`, the other shapes (palm boxes,
adapters, carried objects) through coal, on a model holding just them. Computing rows that
cannot change the answer, and reading coal's results from Python, were most of the cost.
"""

from __future__ import annotations

from collections.abc import Callable, Collection
from dataclasses import dataclass
from functools import cached_property

import coal
import numpy as np
import pinocchio as pin

from hriplan.recent import MadeFor
from hriplan.robots.batch_kinematics import BatchKinematics, cross
from hriplan.robots.collision import person_distance_data
from hriplan.robots.part_spheres import BOUND_TOLERANCE, axis_gaps, bounding_sphere
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


@dataclass(frozen=True)
class Select:
    """What `PersonDistances.at` asks a caller, given a lower bound on every row's distance and an
    upper bound on the speed of any point of its part, both (N, k): first which rows are likely
    to decide each state (measured first: a few a state), then, given the rows measured so far
    (the others at distance inf), which could still change the answer. Both answer (N, k) flags."""

    likely: Callable[[np.ndarray, np.ndarray], np.ndarray]
    needed: Callable[[StatePairs, np.ndarray, np.ndarray], np.ndarray]


# An upper bound on a speed is raised by this, relatively and absolutely (m/s): float rounding.
ROUNDING = 1e-9

# PersonDistances made lately, by robot model, person model and joints (`PersonDistances.of`).
_MADE: MadeFor[PersonDistances] = MadeFor(8)


class PersonDistances:
    """The rows of a person model (`CollisionChecker.person_model`) whose part rides on one of
    `joints`, in the model's pair order, evaluated in batches of states. It reads the person's
    placements afresh at every batch, so one serves the model wherever its person moves."""

    @classmethod
    def of(cls, robot_model: pin.Model, person_model: pin.GeometryModel, joints: Collection[int]) -> PersonDistances:
        """The one made last for these models and joints, else a new one: a checker keeps a person
        model across builds and re-poses, and every timing call makes a monitor (~2.5 ms to make)."""
        return _MADE.made(
            (robot_model, person_model), lambda: cls(robot_model, person_model, joints), frozenset(joints)
        )

    def __init__(self, robot_model: pin.Model, person_model: pin.GeometryModel, joints: Collection[int]) -> None:
        self.robot_model, self.robot_data, self.person_model = robot_model, robot_model.createData(), person_model
        objects = person_model.geometryObjects
        chosen = [k for k, p in enumerate(person_model.collisionPairs) if objects[p.first].parentJoint in joints]
        self.pair_index = np.array(chosen, dtype=int)  # each row's pair in the model
        pairs = [(person_model.collisionPairs[k].first, person_model.collisionPairs[k].second) for k in chosen]
        self.parts = [objects[a].name for a, _ in pairs]
        self.capsules = [objects[b].name for _, b in pairs]
        self._slots = sorted({b for _, b in pairs})  # the person's capsules
        self.slot_names = [objects[b].name for b in self._slots]
        self._frames = sorted({objects[a].parentJoint for a, _ in pairs})
        self._kinematics = BatchKinematics(robot_model, self._frames)
        self._frame = np.array([self._frames.index(objects[a].parentJoint) for a, _ in pairs], dtype=int)
        self._slot = np.array([self._slots.index(b) for _, b in pairs], dtype=int)
        self._slot_half = np.array([objects[b].geometry.halfLength for b in self._slots])
        self._person_half = self._slot_half[self._slot]
        self._slot_radius = np.array([objects[b].geometry.radius for b in self._slots])
        self._person_radius = self._slot_radius[self._slot]
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
        self._capsule_of = np.full(len(pairs), -1, dtype=int)  # row -> its index among the capsule rows
        self._capsule_of[self._capsule_rows] = np.arange(self._capsule_rows.size)
        self._others = _coal_model(person_model, [pairs[k] for k in self._other_rows])
        self._copy_of = np.full(len(pairs), -1, dtype=int)  # row -> its pair in the coal model
        self._copy_of[self._other_rows] = np.arange(self._other_rows.size)
        self._row_parts = [a for a, _ in pairs]  # each row's moved part, for the compiled route's rows
        # Each moved part's bounding sphere: centre in its joint's frame (P, 3, 1), radius (P,).
        parts = sorted({a for a, _ in pairs})
        self._part = np.array([parts.index(a) for a, _ in pairs], dtype=int)
        self._sphere_frame = np.array([self._frames.index(objects[a].parentJoint) for a in parts], dtype=int)
        spheres = [bounding_sphere(objects[a]) for a in parts]
        self._sphere_centre = np.array([c for c, _ in spheres]).reshape(-1, 3, 1)
        self._sphere_radius = np.array([r for _, r in spheres])
        # `_kernel_person`'s last answer and the `posed` stamp it was read at (None: not kept).
        self._person_read: tuple[int | None, tuple[np.ndarray, ...]] = (None, ())

    def by_row(self, per_slot: np.ndarray) -> np.ndarray:
        """A value per capsule of the person (`slot_names` order) given to each row of that capsule:
        what depends on the capsule alone is found once a capsule, not once a row (~12 rows each)."""
        return np.asarray(per_slot)[self._slot]

    def at(self, qs: np.ndarray, dqs: np.ndarray, select: Select | None = None) -> StatePairs:
        """Every row at configurations `qs` (N, nq) moving with joint velocities `dqs` (N, nv).

        Without `select` every row is measured. With it, the rows `select.likely` names, then those
        `select.needed` asks for given them; a row left out stays at distance inf, its points and
        velocity NaN: a caller selects every row that could change its answer (rows that cannot,
        computed, and coal's results read from Python, were most of the cost)."""
        frames = self._kinematics(qs, dqs)
        rotation, origin, linear, angular = frames.rotation, frames.origin, frames.linear, frames.angular
        frame = self._frame
        distance = np.full((len(qs), len(self.parts)), np.inf)
        robot_point, person_point, velocity = (np.full((*distance.shape, 3), np.nan) for _ in range(3))
        pairs = StatePairs(self.parts, self.capsules, distance, robot_point, person_point, velocity)
        measured = np.zeros(distance.shape, dtype=bool)
        # Every robot capsule placed at every state at once (a few per state), then gathered.
        placed = rotation[:, self._capsule_frame]
        capsule_centre = (placed @ self._local_centre)[..., 0] + origin[:, self._capsule_frame]
        capsule_axis = (placed @ self._local_axis)[..., 0]
        world = _Placed(rotation, origin, linear, angular, capsule_centre, capsule_axis, *self._person_capsules())

        def measure(mask: np.ndarray) -> None:
            states, rows = np.nonzero(mask & ~measured)
            measured[states, rows] = True
            capsule = self._capsule_of[rows] >= 0
            self._measure_capsules(world, states[capsule], rows[capsule], pairs)
            self._measure_others(qs, states[~capsule], rows[~capsule], pairs)
            at = states, frame[rows]
            velocity[states, rows] = _point_velocity(linear[at], angular[at], origin[at], robot_point[states, rows])

        self._place_person_copies()
        if select is None or not self.parts:
            measure(np.ones(distance.shape, dtype=bool))
            return pairs
        floor, speed = self._bounds(world)
        measure(select.likely(floor, speed))
        # The capsule rows first (numpy, cheap): what they measure narrows what coal must answer.
        measure(select.needed(pairs, floor, speed) & (self._capsule_of >= 0))
        measure(select.needed(pairs, floor, speed))
        return pairs

    @cached_property
    def _kernel_geometry(self) -> tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]]:
        """What the compiled route's kernels read of the robot (`approach_kernels.capsule_rows`'
        `geometry`), made when it first asks (the shape codes live with the kernels, and numba is
        imported only with the kernels on)."""
        objects, n = self.person_model.geometryObjects, len(self.parts)
        # Per row its robot capsule (-1: not a capsule), that capsule's half length and radius.
        capsule, half, radius = np.full(n, -1, dtype=int), np.zeros(n), np.zeros(n)
        at = self._capsule_rows
        capsule[at], half[at], radius[at] = self._robot_capsule, self._robot_half, self._robot_radius
        shapes = _row_shapes([objects[a] for a in self._row_parts])
        robot = (self._capsule_frame, self._local_centre[..., 0], self._local_axis[..., 0])
        spheres = (self._sphere_frame, self._sphere_centre[..., 0], self._sphere_radius)
        rows = (self._part, self._slot, capsule, half, radius, self._frame, *shapes)
        return tuple(np.ascontiguousarray(a) for a in (*robot, *spheres)), tuple(np.ascontiguousarray(a) for a in rows)

    def _kernel_person(self, posed: int | None = None) -> tuple[np.ndarray, ...]:
        """The person's capsules as the kernels read them (`capsule_rows`' `person`), where she
        stands now: read afresh, unless `posed` (a stamp that changes whenever the person is
        placed anew) is the one the last were read at (reading them costs ~60 us)."""
        if posed is None or self._person_read[0] != posed:
            centre, axis = self._person_capsules()
            self._person_read = (posed, (centre, axis, self._slot_half, self._slot_radius))
        return self._person_read[1]

    def folded(
        self, qs: np.ndarray, dqs: np.ndarray, contact: np.ndarray, caps: np.ndarray, iso: np.ndarray
    ) -> np.ndarray:
        """The ISO/TS 15066 monitor's aggregates of each state (N, `approach_kernels.AGGREGATES`)
        over every row that could change them, computed state by state in compiled code
        (`approach_kernels.py`: its rows' contact flags and caps, its numbers `iso`), capsules,
        boxes and cylinders exactly; the rows it leaves (a mesh, a shape touching the person)
        measured by coal and folded in after."""
        from hriplan.safety import approach_kernels as kernels  # numba: imported with the kernels on

        frames = self._kinematics(qs, dqs)
        # Every array C-contiguous, whatever made it: one compiled signature serves every robot.
        rotation, origin, linear, angular = (
            np.ascontiguousarray(a) for a in (frames.rotation, frames.origin, frames.linear, frames.angular)
        )
        agg, left = np.empty((len(qs), kernels.AGGREGATES)), np.zeros((len(qs), len(self.parts)), dtype=bool)
        geometry, person = self._kernel_geometry, self._kernel_person()
        kernels.capsule_rows(rotation, origin, linear, angular, geometry, person, contact, caps, iso, agg, left)
        if left.any():  # a mesh, or a shape touching the person: coal's (np.nonzero alone costs ~30 us)
            states, rows = map(np.ascontiguousarray, np.nonzero(left))
            self._place_person_copies()
            distance, robot, person = self._coal(qs, states, rows)
            points = np.hstack([np.array(robot), np.array(person)])
            kernels.fold_rows(
                states, rows, np.array(distance), points, origin, linear, angular, self._frame, contact, caps, iso, agg
            )
        return agg

    def nearest(self, qs: np.ndarray, ceiling: float = np.inf, posed: int | None = None) -> tuple[float, int, int]:
        """The least distance of every row over the configurations `qs` (N, nq): (distance,
        state, row), of equal ones the first state, then the first row; rows whose bound passes
        `ceiling` (a distance the caller has) or the least found are not measured, so (inf, -1,
        -1) when none comes within it. Compiled (`approach_kernels.nearest_rows`): capsules, boxes
        and cylinders exactly, the rows it leaves (a mesh, a shape touching the person) by coal.
        `posed`: as `_kernel_person`'s."""
        from hriplan.safety import approach_kernels as kernels  # numba: imported with the kernels on

        rotation, origin = map(np.ascontiguousarray, self._kinematics.placements(qs))
        best, left = np.empty(3), np.zeros((len(qs), len(self.parts)), dtype=bool)
        geometry, person = self._kernel_geometry, self._kernel_person(posed)
        kernels.nearest_rows(rotation, origin, geometry, person, BOUND_TOLERANCE, ceiling, best, left)
        found = (float(best[0]), int(best[1]), int(best[2]))
        if left.any():
            states, rows = np.nonzero(left)
            self._place_person_copies()
            distance, _, _ = self._coal(qs, states, rows)
            found = min([found, *zip(distance, states.tolist(), rows.tolist())])
        return found

    def _measure_capsules(self, world: _Placed, states: np.ndarray, rows: np.ndarray, pairs: StatePairs) -> None:
        """The capsule rows `rows` at `states` (flat, paired), in one numpy pass, into `pairs`."""
        if not rows.size:
            return
        k = self._capsule_of[rows]
        robot = self._robot_capsule[k]
        found = capsule_distances(
            world.capsule_centre[states, robot],
            world.capsule_axis[states, robot],
            self._robot_half[k],
            self._robot_radius[k],
            world.person_centre[self._slot[rows]],
            world.person_axis[self._slot[rows]],
            self._person_half[rows],
            self._person_radius[rows],
        )
        pairs.distance[states, rows], pairs.robot_point[states, rows], pairs.person_point[states, rows] = found

    def _measure_others(self, qs: np.ndarray, states: np.ndarray, rows: np.ndarray, pairs: StatePairs) -> None:
        """The non-capsule rows `rows` at `states` (flat, paired, by state), by coal, into `pairs`."""
        if rows.size:
            pairs.distance[states, rows], pairs.robot_point[states, rows], pairs.person_point[states, rows] = (
                self._coal(qs, states, rows)
            )

    def _coal(self, qs: np.ndarray, states: np.ndarray, rows: np.ndarray) -> tuple[list, list, list]:
        """coal's distance and witness points (robot, person) of the non-capsule rows `rows` at
        `states` (flat, paired, by state): each result read once, the lists made at the end."""
        (others, other_data, _), model, data = self._others, self.robot_model, self.robot_data
        found, copy_of = [], self._copy_of[rows].tolist()
        last = -1
        for n, m in zip(states.tolist(), copy_of):
            if n != last:
                pin.updateGeometryPlacements(model, data, others, other_data, qs[n])
                last = n
            r = pin.computeDistance(others, other_data, m)
            found.append((r.min_distance, r.getNearestPoint1(), r.getNearestPoint2()))
        return [d for d, _, _ in found], [p for _, p, _ in found], [p for _, _, p in found]

    def _place_person_copies(self) -> None:
        """The person's capsules in the coal model of the other shapes placed where the person
        model has them (~4 us each: once a batch, not once a round of measuring)."""
        (others, _, copies), person = self._others, self.person_model.geometryObjects
        if self._other_rows.size:
            for original, copy in copies.items():
                others.geometryObjects[copy].placement = person[original].placement

    def _bounds(self, world: _Placed) -> tuple[np.ndarray, np.ndarray]:
        """Per state and row (N, k): a lower bound on its distance (its part's bounding sphere
        against the capsule's axis, less coal's tolerance) and an upper bound on the speed of any
        point of the part (the sphere centre's speed plus spin times radius). Every sphere meets
        every capsule axis in products of (N, parts, 3) by (3, capsules), not per row: the
        squared gaps lose ~1e-15 m^2 to rounding, ~3e-8 m at contact, well inside the tolerance."""
        frame = self._sphere_frame
        centre = (world.rotation[:, frame] @ self._sphere_centre)[..., 0] + world.origin[:, frame]
        spin = world.angular[:, frame]
        speed = np.linalg.norm(_point_velocity(world.linear[:, frame], spin, world.origin[:, frame], centre), axis=2)
        speed += np.linalg.norm(spin, axis=2) * self._sphere_radius
        gap = axis_gaps(centre, world.person_centre, world.person_axis, self._slot_half)[:, self._part, self._slot]
        floor = gap - self._sphere_radius[self._part] - self._person_radius - BOUND_TOLERANCE
        return floor, speed[:, self._part] * (1.0 + ROUNDING) + ROUNDING

    def _person_capsules(self) -> tuple[np.ndarray, np.ndarray]:
        """World centres and axes of the person's capsules (S, 3), read afresh from the model:
        the person may have been re-posed."""
        person = [self.person_model.geometryObjects[b].placement for b in self._slots]
        return np.array([m.translation for m in person]), np.array([m.rotation[:, 2] for m in person])


@dataclass(frozen=True)
class _Placed:
    """One batch's world placements: the carrying joints' rotations (N, F, 3, 3), origins,
    linear and angular velocities (N, F, 3), the robot's capsules' centres and axes (N, C, 3) and
    the person's capsules' (S, 3)."""

    rotation: np.ndarray
    origin: np.ndarray
    linear: np.ndarray
    angular: np.ndarray
    capsule_centre: np.ndarray
    capsule_axis: np.ndarray
    person_centre: np.ndarray
    person_axis: np.ndarray


def _point_velocity(linear: np.ndarray, angular: np.ndarray, origin: np.ndarray, point: np.ndarray) -> np.ndarray:
    """The world velocity of `point` on a body whose `origin` moves at `linear` and turns at
    `angular` (all (..., 3), world)."""
    return linear + cross(angular, point - origin)


def nearest_moving(
    robot_model: pin.Model,
    model: pin.GeometryModel,
    joints: Collection[int],
    qs: np.ndarray,
    ceiling: float,
    posed: int | None = None,
) -> tuple[float, int, int]:
    """`CollisionChecker.closest_human`'s moving pairs in compiled code: of `model`'s pairs whose
    robot part rides on one of `joints`, the least distance over `qs` (N, nq) as (distance,
    state, pair index in the model), of equal ones the first state, then the first pair; (inf,
    -1, -1) if none comes within `ceiling` (`PersonDistances.nearest`; `posed` as there)."""
    distances = PersonDistances.of(robot_model, model, joints)
    distance, state, row = distances.nearest(qs, ceiling, posed)
    return distance, state, int(distances.pair_index[row]) if row >= 0 else -1


def _row_shapes(parts: list[pin.GeometryObject]) -> tuple[np.ndarray, ...]:
    """Per row (its robot part `parts[k]`) for the compiled route: its shape's kind
    (`approach_kernels.CAPSULE`, BOX, CYLINDER or BY_COAL), its placement in its joint's frame
    (rotation (K, 3, 3), origin (K, 3)) and its sizes (K, 3: a box's half sides, a cylinder's
    radius and half length)."""
    from hriplan.safety.approach_kernels import BOX, BY_COAL, CAPSULE, CYLINDER

    k = len(parts)
    kind, rotation, origin, dims = (
        np.full(k, BY_COAL, dtype=int),
        np.zeros((k, 3, 3)),
        np.zeros((k, 3)),
        np.zeros((k, 3)),
    )
    for row, part in enumerate(parts):
        shape = part.geometry
        rotation[row], origin[row] = part.placement.rotation, part.placement.translation
        if isinstance(shape, coal.Capsule):
            kind[row] = CAPSULE
        elif isinstance(shape, coal.Box):
            kind[row], dims[row] = BOX, shape.halfSide
        elif isinstance(shape, coal.Cylinder):
            kind[row], dims[row, :2] = CYLINDER, (shape.radius, shape.halfLength)
    return kind, rotation, origin, dims


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
    return model, person_distance_data(model), {g: k for g, k in index.items() if g in people}
