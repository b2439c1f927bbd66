"""How fast the robot approaches each person along a path, against the ISO/TS 15066 limit.

For every robot part moved by the planned group (and every carried object) and every capsule of
a person: the separation between them and the speed of the part's closest point towards the
person's closest point (the robot speed v_r of ISO/TS 15066), per unit of the joint velocity
given (its whole speed near a contact region, see separation.py). The allowed speed comes from
`separation.kept_speeds` (ISO/TS 15066's limit with the policy's margin); the ratio of the two
bounds the path speed. A moved part inside a person's minimum separation and its padding (allowed
speed 0) may only move away from them (ISO/TS 15066 permits motion away at any separation: a
leave phase, planner/leave.py); moving towards them there is an error: the robot would have to
stand still.

All points of one call are measured in one batch (safety/person_distance.py): timing asks for
the whole path at once, and one coal query per point and pair was most of a re-plan's time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hriplan import HriplanError
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.kernel_switch import kernels_on
from hriplan.robots.model import Robot
from hriplan.robots.part_spheres import BOUND_TOLERANCE
from hriplan.safety.person_distance import ROUNDING, PersonDistances, Select, StatePairs
from hriplan.safety.separation import (
    PersonSeparation,
    SeparationPolicy,
    capped_speeds,
    contact_caps,
    kept_capped_speeds,
    kept_separation,
    kept_speed_terms,
    minimum_separation,
)

# Below this separation (m) the direction to the person is undefined: the part's whole speed counts.
_TOUCHING = 1e-6
# Speeds towards a person below this (m/s per unit joint velocity) are not closing: a part moving
# away inside S_0 along a smooth path may round off to a hair above 0.
CLOSING = 1e-9


@dataclass(frozen=True)
class PersonSample:
    """One person at one configuration: the binding part-capsule pair and its numbers."""

    separation: float  # the closest moved part to the person (m)
    body_separation: float  # the same, outside the person's contact regions (what S_0 applies to)
    allowed: float  # allowed speed towards the person of the binding pair, with the policy's margin (m/s)
    iso_allowed: float  # ISO/TS 15066's own limit for that pair (no margin) (m/s)
    approach: float  # speed of the binding pair towards the person for the given joint velocity (m/s)
    scale: float  # largest factor on the joint velocity keeping every pair within its limit (inf: none)
    part: str
    capsule: str


@dataclass(frozen=True)
class _Rows:
    """Per row of a person's pair geometry: does its capsule meet a contact region, and the
    speed cap there (0: SSM alone; `separation.contact_caps`)."""

    contact: np.ndarray
    caps: np.ndarray


class ApproachMonitor:
    """A robot group's approach to the people of a policy, at configurations of that group.

    Serves one scene: each state's numbers are memoised (the report re-reads the timing's final
    check), its samples made only when asked, while the pair geometry is rebuilt whenever the
    checker rebuilds a person's model."""

    def __init__(
        self, robot: Robot, checker: CollisionChecker, policy: SeparationPolicy, group: str, base: np.ndarray
    ) -> None:
        self.robot, self.checker, self.policy, self.group = robot, checker, policy, group
        self.base = np.asarray(base, dtype=float)
        missing = [name for name in checker.humans if policy.person(name) is None]
        if missing:
            raise HriplanError(f"the separation policy has no parameters for {', '.join(missing)}")
        self.people: list[PersonSeparation] = [p for p in policy.people if p.name in checker.humans]
        model = robot.model
        self._iq = robot.group_indices(group)
        self._iv = np.array([model.joints[model.getJointId(j)].idx_v for j in robot.group_joints(group)])
        self._moved = robot.moved_joints(group)
        self._memo: dict[bytes, tuple[_Batch, int]] = {}
        self._distances: dict[str, tuple[PersonDistances, _Rows]] = {}

    def full(self, x: np.ndarray) -> np.ndarray:
        q = self.base.copy()
        q[self._iq] = x
        return q

    def samples(self, x: np.ndarray, dx: np.ndarray) -> list[PersonSample]:
        """Per person (policy order), at group values `x` moving with group velocity `dx`."""
        return self.samples_along(np.asarray(x, dtype=float)[None], np.asarray(dx, dtype=float)[None])[0]

    def samples_along(self, xs: np.ndarray, dxs: np.ndarray) -> list[list[PersonSample]]:
        """`samples` at every row of `xs` (k x group) moving with `dxs`, in one batch."""
        found = self._rows(np.asarray(xs, dtype=float), np.asarray(dxs, dtype=float))
        return [batch.samples()[n] for batch, n in found]

    def speed_scale(self, xs: np.ndarray, dxs: np.ndarray) -> np.ndarray:
        """Per row: the largest factor on `dxs` that keeps every person's limit (inf: unbounded)."""
        found = self._rows(np.asarray(xs, dtype=float), np.asarray(dxs, dtype=float))
        return np.array([batch.scale[n] for batch, n in found], dtype=float)

    def _rows(self, xs: np.ndarray, dxs: np.ndarray) -> list[tuple[_Batch, int]]:
        """Every row's batch and its state there, the ones not memoised computed in one batch; a
        moved part inside S_0 raises at the first such row (first person there), as row-by-row
        evaluation would. A row's key is its bytes (one view of the batch, not a copy a row)."""
        rows = np.concatenate([xs, dxs], axis=1)
        keys = rows.view(np.dtype((np.void, rows.shape[1] * rows.itemsize))).ravel().tolist()
        first: dict[bytes, int] = {}
        for i, key in enumerate(keys):
            first.setdefault(key, i)
        new = [i for key, i in first.items() if key not in self._memo]
        if new:
            qs = np.repeat(self.base[None], len(new), axis=0)
            qs[:, self._iq] = xs[new]
            dqs = np.zeros((len(new), self.robot.model.nv))
            dqs[:, self._iv] = dxs[new]
            per_person = [self._person(person, qs, dqs) for person in self.people]
            stops = [stop for _, stop in per_person if stop is not None]
            if stops:
                raise HriplanError(min(stops, key=lambda stop: stop[0])[1])
            batch = _Batch(self.policy, [found for found, _ in per_person if found is not None], len(new))
            self._memo.update({keys[i]: (batch, n) for n, i in enumerate(new)})
        return [self._memo[k] for k in keys]

    def _pairs(self, person: PersonSeparation) -> tuple[PersonDistances, _Rows]:
        """The person's pair geometry and which rows meet a contact region and at what speed cap
        (once per person model)."""
        model = self.checker.person_model(person.name)
        cached = self._distances.get(person.name)
        if cached is None or cached[0].person_model is not model:
            distances = PersonDistances.of(self.robot.model, model, self._moved)
            names = distances.slot_names
            contact = distances.by_row(np.array([person.contact_region(c) is not None for c in names], dtype=bool))
            cached = distances, _Rows(contact, distances.by_row(contact_caps(self.policy.robot, person, names)))
            self._distances[person.name] = cached
        return cached

    def _deciding(self, person: PersonSeparation, kind: _Rows, speeds: _Speeds) -> Select:
        """Which rows could change a sample: those whose distance bound does not put them beyond
        the closest row measured (overall, or outside the contact regions), or whose bounds on
        allowed speed and approach could make them bind, lower the scale or stop the robot.
        kept_speeds grows with the separation and the approach is at most the part's speed, so
        every other row provably changes nothing; ties are measured. Measured first, at each
        state, the rows whose bounds make them likeliest to be the closest (overall and outside
        the contact regions), to bind and to set the scale: they make the second answer small."""

        at_floor: list = [None, None]  # the last floor asked about, and the allowed speeds there

        def allowed_at(floor: np.ndarray) -> np.ndarray:
            """kept_capped_speeds at the distance bounds: a batch asks with one `floor`, thrice."""
            if at_floor[0] is not floor:
                at_floor[:] = floor, kept_capped_speeds(self.policy, person, floor, kind.caps)
            return at_floor[1]

        def likely(floor: np.ndarray, speed: np.ndarray) -> np.ndarray:
            lowest = allowed_at(floor)
            closing = speed > CLOSING
            ratio = np.where(closing, lowest / np.where(closing, speed, 1.0), np.inf)
            chosen = np.zeros(floor.shape, dtype=bool)
            at = np.arange(len(floor))
            for rank in (floor, np.where(kind.contact, np.inf, floor), lowest - speed, ratio):
                chosen[at, rank.argmin(axis=1)] = True
            return chosen

        def needed(pairs: StatePairs, floor: np.ndarray, speed: np.ndarray) -> np.ndarray:
            allowed, approach = speeds.of(pairs)
            nearest = pairs.distance.min(axis=1, initial=np.inf)[:, None]
            body = _body(kind.contact, pairs.distance)[:, None]
            margin = (allowed - approach).min(axis=1, initial=np.inf)[:, None]
            scale = _scales(allowed, approach).min(axis=1, initial=np.inf)
            lowest = allowed_at(floor)
            moving = speed > CLOSING
            return (
                (floor <= nearest)
                | (~kind.contact & (floor <= body))
                | (lowest - speed <= margin)
                | (moving & ((lowest <= 0.0) | (lowest <= scale[:, None] * speed)))
            )

        return Select(likely, needed)

    def _person(
        self, person: PersonSeparation, qs: np.ndarray, dqs: np.ndarray
    ) -> tuple[_Found | None, tuple[int, str] | None]:
        """One person's numbers at each state, or the first state with a moved part inside S_0 and why."""
        distances, kind = self._pairs(person)
        if not distances.parts:
            return _Found(person, distances, kind, None), None
        columns = (self._compiled if kernels_on() else self._measured)(person, distances, kind, qs, dqs)
        if columns.stop is not None:
            n, k, distance = columns.stop
            return None, (
                n,
                f"{distances.parts[k]} passes {distance:.3f} m from {person.name}/{distances.capsules[k]}, inside the "
                f"minimum protective separation {minimum_separation(self.policy.robot, person):.3f} m of ISO/TS 15066 "
                f"and the padding {self.policy.margin.padding:g} m ({kept_separation(self.policy, person):.3f} m; the "
                f"robot would have to stand still there)",
            )
        return _Found(person, distances, kind, columns), None

    def _measured(
        self, person: PersonSeparation, distances: PersonDistances, kind: _Rows, qs: np.ndarray, dqs: np.ndarray
    ) -> _Columns:
        """The samples' numbers from the rows `_deciding` selects, measured in numpy batches."""
        speeds = _Speeds(self.policy, person, kind, (len(qs), len(distances.parts)))
        pairs = distances.at(qs, dqs, self._deciding(person, kind, speeds))
        distance = pairs.distance
        allowed, approach = speeds.of(pairs)
        stopped = (allowed <= 0.0) & (approach > CLOSING)
        stop = None
        if stopped.any():
            n = int(np.flatnonzero(stopped.any(axis=1))[0])
            k = int(np.flatnonzero(stopped[n])[np.argmin(distance[n, stopped[n]])])
            stop = n, k, float(distance[n, k])
        binding = np.argmin(allowed - approach, axis=1)
        at = np.arange(len(qs))
        return _Columns(
            nearest=distance.min(axis=1),
            body=_body(kind.contact, distance),
            binding=binding,
            allowed=allowed[at, binding],
            approach=approach[at, binding],
            distance=distance[at, binding],
            scale=_scales(allowed, approach).min(axis=1),
            stop=stop,
        )

    def _compiled(
        self, person: PersonSeparation, distances: PersonDistances, kind: _Rows, qs: np.ndarray, dqs: np.ndarray
    ) -> _Columns:
        """The same numbers from the compiled route (`approach_kernels.py`), state by state."""
        from hriplan.safety import approach_kernels as k  # numba: imported with the kernels on

        iso = np.array([*kept_speed_terms(self.policy, person), BOUND_TOLERANCE, CLOSING, _TOUCHING, ROUNDING])
        agg = distances.folded(qs, dqs, kind.contact, kind.caps, iso)
        stopping = np.flatnonzero(agg[:, k.STOP] >= 0)
        stop = None
        if stopping.size:
            n = int(stopping[0])
            stop = n, int(agg[n, k.STOP]), float(agg[n, k.STOP_DISTANCE])
        return _Columns(
            nearest=agg[:, k.NEAREST],
            body=agg[:, k.BODY],
            binding=agg[:, k.BINDING].astype(int),
            allowed=agg[:, k.ALLOWED],
            approach=agg[:, k.APPROACH],
            distance=agg[:, k.DISTANCE],
            scale=agg[:, k.SCALE],
            stop=stop,
        )


@dataclass(frozen=True)
class _Columns:
    """One person's numbers at each state (N,): the nearest row's distance, the nearest outside
    the contact regions, the binding row (least allowed less approach) with its allowed speed,
    approach and distance, the least scale; and the first state with a part closing in where
    no speed is allowed: (state, row, distance), else None."""

    nearest: np.ndarray
    body: np.ndarray
    binding: np.ndarray
    allowed: np.ndarray
    approach: np.ndarray
    distance: np.ndarray
    scale: np.ndarray
    stop: tuple[int, int, float] | None


@dataclass(frozen=True)
class _Found:
    """One person's numbers at a batch's states (None: no moved part meets them) and what a
    sample reads besides: the pair geometry's names and caps."""

    person: PersonSeparation
    distances: PersonDistances
    kind: _Rows
    columns: _Columns | None


class _Batch:
    """One batch's states: per state the least scale over the people, and the samples, made
    when first asked (`samples`, the report): `speed_scale` reads the scales alone, and making a
    PersonSample per state and person was a fifth of its time."""

    def __init__(self, policy: SeparationPolicy, people: list[_Found], count: int) -> None:
        self.policy, self.people, self.count = policy, people, count
        least = np.full(count, np.inf)
        for n, found in enumerate(people):  # min over the people in order: the first of equal ones
            scale = np.full(count, np.inf) if found.columns is None else found.columns.scale
            least = scale if n == 0 else np.where(scale < least, scale, least)
        self.scale: list[float] = least.tolist()
        self._samples: list[list[PersonSample]] | None = None

    def samples(self) -> list[list[PersonSample]]:
        """Per state, per person (policy order): the person's sample, made once."""
        if self._samples is None:
            per_person = [self._person_samples(found) for found in self.people]
            self._samples = [[samples[n] for samples in per_person] for n in range(self.count)]
        return self._samples

    def _person_samples(self, found: _Found) -> list[PersonSample]:
        """One person's sample at every state of the batch."""
        columns = found.columns
        if columns is None:
            return [PersonSample(np.inf, np.inf, np.inf, np.inf, 0.0, np.inf, "", "") for _ in range(self.count)]
        binding = columns.binding
        iso = capped_speeds(self.policy.robot, found.person, columns.distance, found.kind.caps[binding])
        numbers = (columns.nearest, columns.body, columns.allowed, iso, columns.approach, columns.scale, binding)
        parts, capsules = found.distances.parts, found.distances.capsules
        return [
            PersonSample(d, b, a, i, r, s, parts[k], capsules[k])
            for d, b, a, i, r, s, k in zip(*(np.asarray(column).tolist() for column in numbers))
        ]


class _Speeds:
    """One batch's rows (N, k): the speed allowed towards the person (with the policy's margin)
    and the robot point's speed towards them (its whole speed at a contact region or touching).
    A row not measured (distance inf) is allowed inf and approaches at 0. Rows are computed once,
    when first seen measured: a batch is asked after each round of measuring."""

    def __init__(self, policy: SeparationPolicy, person: PersonSeparation, kind: _Rows, shape: tuple[int, int]):
        self.policy, self.person, self.kind = policy, person, kind
        self.allowed, self.approach = np.full(shape, np.inf), np.zeros(shape)
        self._seen = np.zeros(shape, dtype=bool)

    def of(self, pairs: StatePairs) -> tuple[np.ndarray, np.ndarray]:
        """(allowed, approach) with every row `pairs` has measured so far."""
        states, rows = np.nonzero(np.isfinite(pairs.distance) & ~self._seen)
        self._seen[states, rows] = True
        distance, v = pairs.distance[states, rows], pairs.robot_velocity[states, rows]
        whole = self.kind.contact[rows] | (distance <= _TOUCHING)
        gap = pairs.person_point[states, rows] - pairs.robot_point[states, rows]
        towards = np.einsum("ij,ij->i", v, gap) / np.maximum(distance, _TOUCHING)
        self.allowed[states, rows] = kept_capped_speeds(self.policy, self.person, distance, self.kind.caps[rows])
        self.approach[states, rows] = np.where(whole, np.sqrt(np.einsum("ij,ij->i", v, v)), towards)
        return self.allowed, self.approach


def _scales(allowed: np.ndarray, approach: np.ndarray) -> np.ndarray:
    """Per row: the factor on the joint velocity that brings the approach to the allowed speed
    (inf where the row does not close in)."""
    closing = approach > CLOSING
    return np.where(closing, allowed / np.where(closing, approach, 1.0), np.inf)


def _body(contact: np.ndarray, distance: np.ndarray) -> np.ndarray:
    """Per state: the closest row outside the person's contact regions (what S_0 applies to)."""
    return np.where(contact, np.inf, distance).min(axis=1, initial=np.inf)
