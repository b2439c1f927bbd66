"""The leave phase: moving away from a person is always allowed.

A start inside a keep-out volume (every link stays outside it: keep-out cylinders and spheres,
exclusion boxes) or inside a person's minimum separation S_0 (safety/zones.py) makes every
motion fail "start is in collision". ISO/TS 15066 permits motion away from a person at any
separation, so such a start first gets its own motion out: steps of at most STEP rad of the
planned group, each along the least joint motion (a small quadratic programme) that moves every
part inside a zone or keep-out away from it at rate 1 (t per rad once scaled to the step) while

- no moved part comes closer to any person: its least distance to each person and its distance
  to every capsule within S_0 + GUARD grow at a rate of at least GROWTH (so the speed towards
  any person is never positive, and the timing may move it inside S_0, safety/approach.py),
- parts near a keep-out do not go deeper into it, the constraints the start keeps stay kept, the
  joints stay within their limits.

Where no step leaves with every part (deep in a keep-out box each would leave by another face),
only the deepest part in each keep-out must leave and the others may go deeper for a while; the
people's distances are kept all the same. Each step is then checked exactly (not to first
order): those distances did not shrink and the state is collision free (the keep-outs and zones
being left aside; where a step collides, the leave backs off to where that pair was BACK_OFF
apart and goes on keeping it apart). The leave ends where the start is valid for planning:
outside every keep-out and every zone with its whole slack. Where no direction moves away (t <=
0), or every step away collides, there is no way out: one line naming the person or volume and
how close. Timed and validated like any motion (session.py).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import coal
import numpy as np
import pinocchio as pin

from hriplan.planner.constraints.binding import BoundConstraint
from hriplan.planner.constraints.evaluator import ConstraintEvaluator
from hriplan.planner.constraints.keep_out import KEEP_OUT_PREFIX, keep_out_obstacles
from hriplan.planner.motion import PLANNING_MARGIN, with_keep_out
from hriplan.planner.start_zones import start_zones
from hriplan.planner.validate import VALIDATION_TOLERANCE
from hriplan.robots.collision import ZONE_NAMING, CollisionChecker
from hriplan.robots.model import Robot
from hriplan.safety.person_distance import PersonDistances
from hriplan.safety.separation import SeparationPolicy, kept_separation
from hriplan.safety.zones import ZONE_SLACK, separation_zones

STEP = 0.01  # rad: the largest joint move of one step (the planner's validation step)
HALVINGS = 4  # a step that fails its exact check is halved this often before the leave gives up
MAX_STEPS = 600  # 6 rad of joint travel at most
GUARD = 0.05  # m beyond S_0 (and near a keep-out) within which nothing may come closer
BAND = 0.02  # m: a part's pairs this close to its least distance to a person are kept from shrinking
GROWTH = 0.05  # guarded distances grow at least this fraction of the rate the trouble leaves at
TOLERANCE = 1e-6  # m: a distance that shrinks by less has not come closer (rounding, second order)
# coal's penetration depth (inside a keep-out) is this precise (m); its rates are differences over SOLID_STEP rad.
SOLID_NOISE, SOLID_STEP = 2e-5, 1e-5
# The timed motion follows a spline through the steps, which may sway this much more (m).
TIMED_TOLERANCE = 1e-5
# A pair a step collided in is kept apart from where it was this far apart (m): the timed
# motion's spline must not graze it.
BACK_OFF = 0.01
HELD_BAND = 0.02  # a kept constraint this close to its boundary (m or rad) may not move towards it
CLEAR = 1e-3  # m beyond a zone's or keep-out's surface where the leave may end


@dataclass
class Leave:
    """A leave phase: the group's waypoints (the start first), or None and why not; the ids of
    the constraints not kept while leaving: the keep-outs the start lies in, those it breaks."""

    path: list[np.ndarray] | None
    left: list[str] = field(default_factory=list)
    message: str = ""
    measured: _Leaving | None = field(default=None, repr=False)

    def receding(self, states: Sequence[np.ndarray], padding: float = 0.0) -> str:
        """Along `states` (group values: the timed motion), what first came closer to a person (a
        part's least distance to them, a pair inside their zone and within ISO/TS 15066's own S_0,
        the zone less the policy's `padding`; "" if nothing), by more than the timing's spline
        through the steps may sway (TIMED_TOLERANCE). Between S_0 and the padding the timing
        bounds the speed towards the person as ISO/TS 15066 does."""
        rows = self.measured.rows(np.asarray(states[0], dtype=float))
        for k, x in enumerate(states[1:], start=1):
            after = self.measured.rows(np.asarray(x, dtype=float))
            inside = rows.distance < rows.limit - padding  # nan limit (not a person row): False
            breach = receding_breach(rows, after, rows.trouble & inside, TIMED_TOLERANCE)
            if breach:
                return f"at point {k}: {breach}"
            rows = after
        return ""


@dataclass
class _Rows:
    """Distances at one state and their rates per unit of each group joint."""

    names: list[str]  # "part - person/capsule", "part in keep-out:ID", "tool in ID"
    distance: np.ndarray
    rate: np.ndarray  # (rows, joints)
    trouble: np.ndarray  # bool: inside a zone or keep-out: to leave
    guard: np.ndarray  # bool: must not shrink
    least: dict[tuple[str, str], float]  # (part, person) -> least distance
    limit: np.ndarray  # a person row's S_0 (nan: other rows)
    in_keep_out: np.ndarray  # bool: a moved part against a keep-out solid


class _Leaving:
    """The geometry one leave measures: people's capsules (bare), keep-out solids, constraints."""

    def __init__(
        self,
        robot: Robot,
        checker: CollisionChecker,
        bound: list[BoundConstraint],
        group: str,
        q_start: np.ndarray,
        safety: SeparationPolicy | None,
    ) -> None:
        self.robot, self.checker, self.group, self.base = robot, checker, group, np.asarray(q_start, dtype=float)
        self.evaluator = ConstraintEvaluator(robot, bound, group, self.base)
        self.iq = robot.group_indices(group)
        model = robot.model
        self.iv = np.array([model.joints[model.getJointId(j)].idx_v for j in robot.group_joints(group)])
        moved = robot.moved_joints(group)
        people = [p for p in (safety.people if safety else []) if p.name in checker.humans]
        self.people = [
            (p, kept_separation(safety, p), PersonDistances(model, checker.person_model(p.name), moved)) for p in people
        ]
        solids = [
            (o.name, o.shape.geometry(), 0, o.pose.se3()) for o in keep_out_obstacles(bound)
        ]  # coal shapes, built once
        moving = [(p.name, p.geometry, p.joint, p.placement) for p in checker.parts if p.joint in moved]
        fixed = [(p.name, p.geometry, p.joint, p.placement) for p in checker.parts if p.joint not in moved]
        # Shape pairs measured by coal: each moved part in each keep-out (to leave), then the pairs
        # a step collided in (`avoid`, kept from closing in); the fixed parts' pairs on their own.
        self.solid_pairs = [(part, solid) for solid in solids for part in moving]
        self.inside_pairs = len(self.solid_pairs)
        self.fixed_pairs = [(part, solid) for solid in solids for part in fixed]
        self.avoid: list[tuple[str, str]] = []
        self.volumes = [
            i for i, c in enumerate(self.evaluator.constraints) if getattr(c.spec, "keep_out_all_links", False)
        ]
        margins = self.evaluator.margins(self.base) if self.evaluator.constraints else np.zeros(0)
        others = [i for i in range(len(margins)) if i not in self.volumes]
        # The constraints the start keeps stay kept; those it breaks cannot be (planner/motion.py
        # projects onto them after, if asked).
        self.held = [i for i in others if margins[i] <= VALIDATION_TOLERANCE]
        self.broken = [self.evaluator.constraints[i].id for i in others if margins[i] > VALIDATION_TOLERANCE]
        self.data = model.createData()

    def full(self, x: np.ndarray) -> np.ndarray:
        q = self.base.copy()
        q[self.iq] = x
        return q

    def rows(self, x: np.ndarray) -> _Rows:
        q, n = self.full(x), len(self.iq)
        names, distance, rate, trouble, guard, least, limit, in_keep_out = [], [], [], [], [], {}, [], []
        for person, s0, pairs in self.people:
            dqs = np.zeros((n, self.robot.model.nv))
            dqs[np.arange(n), self.iv] = 1.0
            at = pairs.at(np.repeat(q[None], n, axis=0), dqs)
            d = at.distance[0]
            away = (at.robot_point[0] - at.person_point[0]) / np.maximum(d, 1e-9)[:, None]
            rates = np.einsum("kc,jkc->kj", away, at.robot_velocity)
            body = np.array([person.contact_region(c) is None for c in at.capsules], dtype=bool)
            for part in set(at.parts):
                mine = np.array([p == part for p in at.parts])
                least[(part, person.name)] = float(d[mine].min())
            part_least = np.array([least[(p, person.name)] for p in at.parts])
            names += [f"{p} - {person.name}/{c}" for p, c in zip(at.parts, at.capsules)]
            distance.append(d)
            limit.append(np.full(len(d), s0))
            in_keep_out.append(np.zeros(len(d), bool))
            rate.append(rates)
            trouble.append(body & (d < s0 + ZONE_SLACK + CLEAR))
            guard.append((d < s0 + ZONE_SLACK + GUARD) | (d <= part_least + BAND))
        if self.solid_pairs:
            k_names, k_distance, k_rate = self._solid_rows(x)
            names += k_names
            distance.append(k_distance)
            limit.append(np.full(len(k_distance), np.nan))
            rate.append(k_rate)
            inside = np.arange(len(k_distance)) < self.inside_pairs
            in_keep_out.append(inside)
            trouble.append((k_distance < CLEAR) & inside)
            guard.append(k_distance < GUARD)
        if self.volumes:
            margins, gradients = self.evaluator.gradients(x)
            names += [f"tool in {self.evaluator.constraints[i].id}" for i in self.volumes]
            m = -margins[self.volumes]
            distance.append(m)
            limit.append(np.full(len(m), np.nan))
            in_keep_out.append(np.zeros(len(m), bool))
            rate.append(-gradients[self.volumes])
            trouble.append(m < 2 * PLANNING_MARGIN)
            guard.append(m < GUARD)
        if not names:
            empty = np.zeros(0, bool)
            return _Rows([], np.zeros(0), np.zeros((0, n)), empty, empty, least, np.zeros(0), empty)
        return _Rows(
            names,
            np.concatenate(distance),
            np.concatenate(rate),
            np.concatenate(trouble),
            np.concatenate(guard),
            least,
            np.concatenate(limit),
            np.concatenate(in_keep_out),
        )

    def _solid_rows(self, x: np.ndarray) -> tuple[list[str], np.ndarray, np.ndarray]:
        """The solid pairs: coal's signed distance (negative inside) and, for those within GUARD,
        its rate per group joint by finite differences (the others are neither left nor guarded)."""
        n = len(self.iq)
        distance = self.solid_distances(self.full(x))
        near = np.flatnonzero(distance < GUARD)
        rate = np.zeros((len(distance), n))
        for j in range(n):
            dx = np.zeros(n)
            dx[j] = SOLID_STEP
            rate[near, j] = (self.solid_distances(self.full(x + dx), near) - distance[near]) / SOLID_STEP
        names = [f"{a[0]} {'in' if k < self.inside_pairs else '-'} {b[0]}" for k, (a, b) in enumerate(self.solid_pairs)]
        return names, distance, rate

    def keep_apart(self, contacts: list[tuple[str, str]]) -> None:
        """Keep the pairs of these collision geometry names from closing in from now on."""
        objects = self.checker.geom_model.geometryObjects
        for pair in contacts:
            a, b = (objects[self.checker.geom_model.getGeometryId(name)] for name in pair)
            self.solid_pairs.append(
                ((a.name, a.geometry, a.parentJoint, a.placement), (b.name, b.geometry, b.parentJoint, b.placement))
            )
            self.avoid.append(pair)

    def solid_distances(
        self, q: np.ndarray, which: Sequence[int] | None = None, pairs: list | None = None
    ) -> np.ndarray:
        """At `q`: coal's signed distance of each solid pair (or of those `which`), or of `pairs`."""
        pin.forwardKinematics(self.robot.model, self.data, q)
        pairs = self.solid_pairs if pairs is None else pairs
        chosen = range(len(pairs)) if which is None else which
        return np.array(
            [
                _distance(a[1], self.data.oMi[a[2]] * a[3], b[1], self.data.oMi[b[2]] * b[3])
                for a, b in (pairs[k] for k in chosen)
            ]
        )

    def fixed_in_keep_out(self) -> str:
        """The deepest part the group does not move that lies in a keep-out, in words ("" if none)."""
        if not self.fixed_pairs:
            return ""
        distance = self.solid_distances(self.base, pairs=self.fixed_pairs)
        k = int(np.argmin(distance))
        part, solid = self.fixed_pairs[k]
        return f"{part[0]} in {solid[0]} by {-distance[k]:.3f} m" if distance[k] < 0.0 else ""

    def breaks(self, x: np.ndarray, y: np.ndarray) -> str:
        """The kept constraint whose margin grew past the planning margin from `x` to `y` ("" if none)."""
        if not self.held:
            return ""
        before, after = (self.evaluator.margins(self.full(v))[self.held] for v in (x, y))
        bad = np.flatnonzero(after > np.maximum(before, -PLANNING_MARGIN))
        return f"breaks {self.evaluator.constraints[self.held[bad[0]]].id}" if bad.size else ""

    def direction(self, x: np.ndarray, rows: _Rows, relaxed: bool = False) -> tuple[np.ndarray, float, np.ndarray]:
        """The unit (max-norm) joint direction of the least joint motion that leaves every trouble
        at rate 1 (guarded rows growing at GROWTH), the rate t it leaves at per rad, and the rows
        it guards; t = 0 if there is none. Least motion: a direction that swings joints to their
        bounds folds the arm. `relaxed`: of the parts in keep-outs only the deepest must leave, the
        others may go deeper for now (deep in a box, each would leave by another face)."""
        n = len(self.iq)
        moving = np.abs(rows.rate).sum(axis=1) > 1e-6  # a distance no joint changes cannot grow
        leaving, guarded = rows.trouble, rows.guard
        if relaxed and (rows.trouble & rows.in_keep_out).any():
            deepest = np.flatnonzero(rows.trouble & rows.in_keep_out)
            deepest = deepest[np.argmin(rows.distance[deepest])]
            leaving = rows.trouble & ~rows.in_keep_out
            leaving[deepest] = True
            guarded = rows.guard & ~rows.in_keep_out
        trouble, guard = rows.rate[leaving], rows.rate[guarded & ~leaving & moving]
        none = np.zeros(n), 0.0, guarded
        if not moving[leaving].all():
            return none
        a = [trouble, guard]
        b = [np.ones(len(trouble)), np.full(len(guard), GROWTH)]
        if self.held:  # near its boundary, a kept constraint's margin must not grow (first order)
            margins, gradients = self.evaluator.gradients(x)
            near = [i for i in self.held if margins[i] > -HELD_BAND]
            a.append(-gradients[near])
            b.append(np.zeros(len(near)))
        lower, upper = self.robot.limits(self.group)
        rows_a, rows_b = np.vstack(a), np.concatenate(b)
        from scipy.optimize import minimize  # here: scipy's import is 0.4 s, and most motions never leave

        found = minimize(
            lambda d: 0.5 * d @ d,
            np.linalg.lstsq(trouble, np.ones(len(trouble)), rcond=None)[0],
            jac=lambda d: d,
            constraints=[{"type": "ineq", "fun": lambda d: rows_a @ d - rows_b, "jac": lambda d: rows_a}],
            method="SLSQP",
        )
        dx = found.x
        if not found.success or (rows_a @ dx - rows_b).min() < -1e-6 or not np.abs(dx).max() > 0.0:
            return none
        scale = np.abs(dx).max()
        direction = dx / scale
        beyond = (x + STEP * direction > upper) | (x + STEP * direction < lower)
        if beyond.any():
            return none
        return direction, 1.0 / scale, guarded


def leave_path(
    robot: Robot,
    checker: CollisionChecker,
    bound: list[BoundConstraint],
    group: str,
    q_start: np.ndarray,
    safety: SeparationPolicy | None,
) -> Leave | None:
    """The leave phase of `group` from `q_start` (checker: the scene without keep-outs or zones),
    or None when the start lies in no keep-out volume and no person's S_0: nothing to leave."""
    with checker.moving(group, q_start):  # every state it asks moves `group` alone from the start
        zones = start_zones(checker, robot, safety, group, q_start)
        with with_keep_out(
            checker, bound, zones
        ):  # the contacts only of a start that collides: plans re-check every start
            contacts = checker.contacts(q_start) if checker.in_collision(q_start) else []
        blocking = [c for c in contacts if _blocking(c.a) or _blocking(c.b)]
        if not blocking or checker.in_collision(q_start):
            return None  # a start valid, or in a plain collision: plan_motion says so
        left = sorted(
            {n[len(KEEP_OUT_PREFIX) :] for c in blocking for n in (c.a, c.b) if n.startswith(KEEP_OUT_PREFIX)}
        )
        leaving = _Leaving(robot, checker, bound, group, q_start, safety)
        left = sorted({*left, *leaving.broken})
        fixed = leaving.fixed_in_keep_out()
        if fixed:
            return Leave(None, left, f"the start is inside a keep-out volume: {fixed}, which {group} does not move")
        full_zones = None if zones is None else separation_zones(checker, robot, safety, group, None)
        x = robot.group_values(q_start, group)
        path, rows = [x], leaving.rows(x)
        for _ in range(MAX_STEPS):
            if not rows.trouble.any():
                with with_keep_out(checker, bound, full_zones):
                    contacts = checker.contacts(leaving.full(x))
                if not contacts:
                    return Leave(path, left, measured=leaving)
                listed = ", ".join(f"{c.a} - {c.b}" for c in contacts[:2])
                return Leave(
                    None, left, f"the start is in a keep-out volume or a person's S_0 ({listed}) no leave measures"
                )
            step, why, new = _advance(leaving, checker, x, rows)
            if step is None and not new and not why:
                return Leave(None, left, f"{_worst(rows)}, and no motion of {group} moves away without coming closer")
            if new:  # keep those apart from now on, from where they were BACK_OFF apart
                leaving.keep_apart(new)
                added = range(len(leaving.solid_pairs) - len(new), len(leaving.solid_pairs))
                while len(path) > 1 and leaving.solid_distances(leaving.full(path[-1]), added).min() < BACK_OFF:
                    path.pop()
                x, rows = path[-1], leaving.rows(path[-1])
                continue
            if step is None:
                return Leave(None, left, f"{_worst(rows)}, and every motion of {group} away {why}")
            x, rows = step
            path.append(x)
        return Leave(None, left, f"{_worst(rows)} after {MAX_STEPS} steps away")


def _advance(
    leaving: _Leaving, checker: CollisionChecker, x: np.ndarray, rows: _Rows
) -> tuple[tuple[np.ndarray, _Rows] | None, str, list[tuple[str, str]]]:
    """One step out (`_step`): every part in trouble leaving, else (relaxed) only the deepest
    part in each keep-out; "" and no pairs for why when neither has a direction that leaves."""
    step, why, new = None, "", []
    for relaxed in (False, True):
        direction, rate, watched = leaving.direction(x, rows, relaxed)
        if rate > 1e-9:
            step, why, new = _step(leaving, checker, x, rows, direction, watched)
            if step is not None or new:
                break
    return step, why, new


def _distance(a: coal.CollisionGeometry, at_a: pin.SE3, b: coal.CollisionGeometry, at_b: pin.SE3) -> float:
    """coal's signed distance of two placed shapes (negative: penetrating)."""
    where = [coal.Transform3s(at.rotation, at.translation) for at in (at_a, at_b)]
    return coal.distance(a, where[0], b, where[1], coal.DistanceRequest(), coal.DistanceResult())


def _blocking(name: str) -> bool:
    return name.startswith(KEEP_OUT_PREFIX) or ZONE_NAMING in name


def _step(
    leaving: _Leaving,
    checker: CollisionChecker,
    x: np.ndarray,
    rows: _Rows,
    direction: np.ndarray,
    watched: np.ndarray,
) -> tuple[tuple[np.ndarray, _Rows] | None, str, list[tuple[str, str]]]:
    """The state one step along `direction` and its rows, halved while its exact check fails
    (a person comes closer, a `watched` row shrinks, a kept constraint breaks);
    or None, what the last try met and the pairs it collided in that the leave did not yet keep
    apart (then the leave backs off and aims again)."""
    h, why = STEP, ""
    for _ in range(HALVINGS + 1):
        y = x + h * direction
        if checker.in_collision(leaving.full(y)):
            contacts = checker.contacts(leaving.full(y))
            why = "collides: " + ", ".join(f"{c.a} - {c.b}" for c in contacts[:2])
            new = [(c.a, c.b) for c in contacts if (c.a, c.b) not in leaving.avoid]
            if new:
                return None, why, new
        else:
            after = leaving.rows(y)
            why = receding_breach(rows, after, watched)
            why = f"comes closer: {why}" if why else leaving.breaks(x, y)
            if not why:
                return (y, after), "", []
        h /= 2.0
    return None, why, []


def receding_breach(before: _Rows, after: _Rows, watched: np.ndarray, tolerance: float = TOLERANCE) -> str:
    """What came closer between two states: a part's least distance to a person, or a `watched`
    row (guarded: within S_0 + GUARD, near a keep-out, near a part's least distance); "" when
    nothing did. A keep-out's depth is as precise as coal's penetration (SOLID_NOISE)."""
    for key, d in before.least.items():
        if after.least[key] < d - tolerance:
            return f"{key[0]} to {key[1]} by {d - after.least[key]:.2g} m"
    noise = np.where(np.isnan(before.limit), max(tolerance, SOLID_NOISE), tolerance)
    shrunk = watched & (after.distance < before.distance - noise)
    if shrunk.any():
        k = int(np.flatnonzero(shrunk)[0])
        return f"{before.names[k]} by {before.distance[k] - after.distance[k]:.2g} m"
    return ""


def _worst(rows: _Rows) -> str:
    """The deepest trouble in words: which part, which person or volume, how close."""
    k = int(np.flatnonzero(rows.trouble)[np.argmin(rows.distance[rows.trouble])])
    name, d = rows.names[k], rows.distance[k]
    if " - " in name:
        return (
            f"the start is inside a person's minimum separation of ISO/TS 15066 ({rows.limit[k]:.3f} m): "
            f"{name} {d:.3f} m apart"
        )
    return f"the start is inside a keep-out volume: {name} by {max(-d, 0.0):.3f} m"
