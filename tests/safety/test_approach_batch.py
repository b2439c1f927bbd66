"""The batched approach monitor gives the per-point numbers, and its capsule geometry is coal's.

References that do not share the code under test: coal.distance per capsule pair; for the
monitor, the per-point computation it replaced (kept here): coal's closest points through
`CollisionChecker.person_pairs`, point velocities from pinocchio's joint Jacobians, and the
ISO/TS 15066 limits by the formulas written in tests/independent.py (SSM and PFL, not `hriplan.safety.separation`). The
checker's robot-person models run coal's GJK to 1e-12 (`collision.PERSON_GJK_TOLERANCE`), so
the palm's, adapter's and can's distances are exact to ~1e-11 m, as the compiled route's
(`approach_kernels._shape_capsule`, held here to coal); their witness points on a cylinder
stay ~1e-6 m apart, where a test lets approach speeds differ by 1e-6.
"""

from __future__ import annotations

import math
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
import pytest

from hriplan import HriplanError
from hriplan.planner.session import PlanningSession
from hriplan.planner.validate import densify
from hriplan.robots.descriptions.registry import posture
from hriplan.robots.human import HumanSpec
from hriplan.robots.part_spheres import BOUND_TOLERANCE
from hriplan.robots.scene import Scene
from hriplan.safety import person_distance
from hriplan.safety.approach import CLOSING, ApproachMonitor, _Rows, _Speeds
from hriplan.safety.capsule_distance import capsule_distances
from hriplan.safety.person_distance import ROUNDING, PersonDistances, Select, StatePairs
from hriplan.safety.policy import default_policy
from hriplan.safety.separation import SafetyMargin, SeparationPolicy, allowed_speed, kept_speed_terms
from hriplan.tasks.load import load_task
from hriplan.tasks.pipeline import TaskRunner
from independent import iso_allowed as _allowed
from independent import iso_minimum_separation as _s0
from independent import iso_ssm as _ssm

EXAMPLES = Path(__file__).parents[2] / "examples"
FIELDS = ("separation", "body_separation", "allowed", "approach", "scale")


# -- capsule pairs against coal ----------------------------------------------------------------
def _frame(axis: np.ndarray) -> np.ndarray:
    """A rotation whose z column is `axis` (coal's capsule axis)."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(axis, helper)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(axis, x), axis])


def _random_capsules(n: int) -> dict[str, np.ndarray]:
    """Random pairs, a quarter of each kind: general, parallel (same or opposite axis), one of
    them a sphere (first or second), both spheres; many overlap. Plus pairs whose axes cross exactly."""
    rng = np.random.default_rng(7)
    unit = lambda v: v / np.linalg.norm(v, axis=-1, keepdims=True)  # noqa: E731
    c1, c2 = rng.uniform(-0.5, 0.5, (n, 3)), rng.uniform(-0.5, 0.5, (n, 3))
    a1, a2 = unit(rng.normal(size=(n, 3))), unit(rng.normal(size=(n, 3)))
    h1, h2 = rng.uniform(0.0, 0.3, n), rng.uniform(0.0, 0.3, n)
    r1, r2 = rng.uniform(0.01, 0.15, n), rng.uniform(0.01, 0.15, n)
    kind = np.arange(n) % 4
    a2[kind == 1] = a1[kind == 1] * np.where(np.arange(n)[kind == 1] % 8 == 1, 1.0, -1.0)[:, None]
    h1[(kind == 2) & (np.arange(n) % 8 == 2)] = 0.0  # the first a sphere, or
    h2[(kind == 2) & (np.arange(n) % 8 == 6)] = 0.0  # the second
    h1[kind == 3], h2[kind == 3] = 0.0, 0.0
    crossing = np.arange(n) % 50 == 0  # axes meeting at the midpoint of the second
    c1[crossing] = c2[crossing] + (rng.uniform(-0.1, 0.1, crossing.sum()))[:, None] * a1[crossing]
    h1[crossing] = 0.2
    return {
        "c1": c1,
        "a1": a1,
        "h1": h1,
        "r1": r1,
        "c2": c2,
        "a2": a2,
        "h2": h2,
        "r2": r2,
        "kind": kind,
        "crossing": crossing,
    }


def _segment_distance(point: np.ndarray, centre: np.ndarray, axis: np.ndarray, half: float) -> float:
    t = np.clip(np.dot(point - centre, axis), -half, half)
    return float(np.linalg.norm(point - (centre + t * axis)))


def test_capsule_distances_equal_coal_on_random_pairs_in_one_batch():
    pairs = _random_capsules(2000)
    d, p1, p2 = capsule_distances(*(pairs[k] for k in ("c1", "a1", "h1", "r1", "c2", "a2", "h2", "r2")))
    request, overlapping = coal.DistanceRequest(), 0
    for i in range(len(d)):
        result = coal.DistanceResult()
        coal.distance(
            coal.Capsule(pairs["r1"][i], 2 * pairs["h1"][i]),
            coal.Transform3s(_frame(pairs["a1"][i]), pairs["c1"][i]),
            coal.Capsule(pairs["r2"][i], 2 * pairs["h2"][i]),
            coal.Transform3s(_frame(pairs["a2"][i]), pairs["c2"][i]),
            request,
            result,
        )
        assert d[i] == pytest.approx(result.min_distance, abs=1e-6), i
        overlapping += d[i] < 0.0
        # Witness points: on each capsule's surface and |d| apart (parallel axes have many such pairs).
        assert _segment_distance(p1[i], pairs["c1"][i], pairs["a1"][i], pairs["h1"][i]) == pytest.approx(
            pairs["r1"][i], abs=1e-9
        )
        assert _segment_distance(p2[i], pairs["c2"][i], pairs["a2"][i], pairs["h2"][i]) == pytest.approx(
            pairs["r2"][i], abs=1e-9
        )
        assert np.linalg.norm(p2[i] - p1[i]) == pytest.approx(abs(d[i]), abs=1e-9)
        if pairs["kind"][i] != 1 and not pairs["crossing"][i]:  # unique closest points: coal's
            np.testing.assert_allclose(p1[i], result.getNearestPoint1(), atol=1e-6)
            np.testing.assert_allclose(p2[i], result.getNearestPoint2(), atol=1e-6)
    assert overlapping > 100 and pairs["crossing"].sum() == 40
    np.testing.assert_allclose(d[pairs["crossing"]], -(pairs["r1"] + pairs["r2"])[pairs["crossing"]], atol=1e-12)


def test_the_compiled_pair_gives_the_batchs_numbers_on_random_pairs():
    """The monitor's compiled route measures a capsule pair alone (`approach_kernels._capsules`):
    the numbers of `capsule_distances` (held to coal above) on the same random pairs, parallel,
    point-like, crossing and coaxial ones included."""
    kernels = pytest.importorskip("hriplan.safety.approach_kernels")
    pairs = _random_capsules(2000)
    # Coaxial pairs too (the axes cross and are parallel: a normal from a helper axis), some along x.
    coaxial = np.arange(2000) % 100 == 5  # kind 1: capsules with length
    pairs["a1"][coaxial & (np.arange(2000) % 200 == 5)] = [0.96, 0.28, 0.0]
    pairs["a2"][coaxial] = pairs["a1"][coaxial]
    pairs["c2"][coaxial] = pairs["c1"][coaxial] + 0.05 * pairs["a1"][coaxial]
    d, p1, p2 = capsule_distances(*(pairs[k] for k in ("c1", "a1", "h1", "r1", "c2", "a2", "h2", "r2")))
    points = np.empty(6)
    for i in range(len(d)):
        one = (pairs[k][i] for k in ("c1", "a1", "h1", "r1", "c2", "a2", "h2", "r2"))
        assert kernels._capsules(*one, points) == pytest.approx(d[i], abs=1e-12), i
        np.testing.assert_allclose(points, np.concatenate([p1[i], p2[i]]), atol=1e-12)


def _random_rotation(rng: np.random.Generator) -> np.ndarray:
    return pin.Quaternion(rng.normal(size=4)).normalized().matrix()


def _tight_coal(shape: coal.CollisionGeometry, at: coal.Transform3s, capsule: coal.Capsule, where: coal.Transform3s):
    """coal's distance with GJK run to 1e-12: its default 1e-6 leaves a cylinder's points ~0.6 mm
    off; at 1e-12 it agrees with a dense search along the segment to ~1e-11 m (at 1e-13 it stalls
    on some pairs, 7e-7 m short)."""
    request, result = coal.DistanceRequest(), coal.DistanceResult()
    request.gjk_tolerance = 1e-12
    coal.distance(shape, at, capsule, where, request, result)
    return result.min_distance, np.array(result.getNearestPoint1()), np.array(result.getNearestPoint2())


@pytest.mark.parametrize("kind", ["box", "cylinder"])
def test_the_compiled_shape_capsule_pair_is_coals_to_1e9(kind):
    """`approach_kernels._shape_capsule` (a palm box, an adapter or a can against a capsule of a
    person) against coal run to convergence, on 3000 random pairs placed through a joint's frame
    and the shape's own placement in it: distances within 1e-9 m, witness points within 1e-6
    (unique: random poses); a pair touching or overlapping is NaN (left to coal's depth)."""
    kernels = pytest.importorskip("hriplan.safety.approach_kernels")
    rng = np.random.default_rng(5)
    out, scratch, separate, touching = np.empty(6), np.empty(15), 0, 0
    for _ in range(3000):
        joint, local = (
            (_random_rotation(rng), rng.uniform(-0.2, 0.2, 3)),
            (_random_rotation(rng), rng.uniform(-0.1, 0.1, 3)),
        )
        if kind == "box":
            dims = np.array([*rng.uniform(0.005, 0.1, 3)])
            shape, code = coal.Box(*(2.0 * dims)), kernels.BOX
        else:
            dims = np.array([rng.uniform(0.01, 0.08), rng.uniform(0.005, 0.1), 0.0])
            shape, code = coal.Cylinder(dims[0], 2.0 * dims[1]), kernels.CYLINDER
        centre, axis = rng.uniform(-0.4, 0.4, 3), _random_rotation(rng)[:, 2]
        half, radius = rng.uniform(0.0, 0.3), rng.uniform(0.01, 0.1)
        rotation, origin = joint[0][None, None], joint[1][None, None]
        got = kernels._shape_capsule(
            rotation, origin, 0, 0, local[0], local[1], code, dims, centre, axis, half, radius, scratch, out
        )
        world = pin.SE3(*joint) * pin.SE3(*local)
        frame = np.eye(3)
        frame[:, 2] = axis
        frame[:, 0] = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
        frame[:, 0] /= np.linalg.norm(frame[:, 0])
        frame[:, 1] = np.cross(frame[:, 2], frame[:, 0])
        distance, on_shape, on_capsule = _tight_coal(
            shape, coal.Transform3s(world.rotation, world.translation), coal.Capsule(radius, 2.0 * half),
            coal.Transform3s(frame, centre),
        )  # fmt: skip
        if distance <= 1e-9:
            touching += 1
            assert math.isnan(got), distance
            continue
        separate += 1
        assert got == pytest.approx(distance, abs=1e-9)
        np.testing.assert_allclose(out[:3], on_shape, atol=1e-6)
        np.testing.assert_allclose(out[3:], on_capsule, atol=1e-6)
    assert separate > 1000 and touching > 100


def test_a_shape_touching_the_person_is_measured_by_coal_and_the_samples_are_the_per_point_ones(
    either_route, monkeypatch
):
    """MADAR's open right hand held by a person (her right hand at its tool frame: the palm and
    adapter touch her) while the arm moves at random velocities: every sample or S_0 message is
    the per-point one, and on the compiled route coal is asked only at states where a shape
    touches her (`left` rows), each of them a touching pair."""
    session = PlanningSession("madar", Scene(), hands={"right": "open"})
    q0 = session.robot.configuration(posture("madar", "ready"))
    tool = session.robot.frame_pose(session.robot.tool_frame("right"), q0)[:3, 3]
    person = HumanSpec(
        name="visitor", position=(tool[0] + 0.55, tool[1]), yaw=1.25 * math.pi, reach={"right": tuple(tool)}
    )
    session.set_scene(Scene(humans=[person]))
    policy = default_policy("madar", [person], roles={"visitor": "Receiver"})
    rng = np.random.default_rng(3)
    x0 = session.robot.group_values(q0, "right_arm")
    xs = x0 + np.linspace(0.0, 1.0, 12)[:, None] * rng.uniform(-0.3, 0.3, 6)
    asked = []
    measure = pin.computeDistance
    monkeypatch.setattr(pin, "computeDistance", lambda *a: asked.append(measure(*a)) or asked[-1])
    monitor = ApproachMonitor(session.robot, session.checker, policy, "right_arm", q0)
    for x in xs:
        dx = rng.normal(0.0, 0.3, 6)
        reference = _reference(session, policy, "right_arm", q0, x, dx)  # coal's computeDistances, not patched
        if isinstance(reference, str):
            with pytest.raises(HriplanError) as error:
                monitor.samples(x, dx)
            assert str(error.value) == reference
        else:
            _assert_same(monitor, reference, x, dx)
    if either_route:
        assert asked and all(r.min_distance <= 0.0 for r in asked)
    else:  # the numpy route asks coal for every box and cylinder it cannot rule out
        assert any(r.min_distance > 0.0 for r in asked)


def test_capsule_distances_broadcast_one_capsule_against_many():
    pairs = _random_capsules(40)
    one = capsule_distances(
        pairs["c1"][:1],
        pairs["a1"][:1],
        pairs["h1"][0],
        pairs["r1"][0],
        pairs["c2"],
        pairs["a2"],
        pairs["h2"],
        pairs["r2"],
    )
    for i in range(40):
        single = capsule_distances(
            pairs["c1"][0],
            pairs["a1"][0],
            pairs["h1"][0],
            pairs["r1"][0],
            pairs["c2"][i],
            pairs["a2"][i],
            pairs["h2"][i],
            pairs["r2"][i],
        )
        for batch, alone in zip(one, single):
            np.testing.assert_allclose(batch[i], alone, atol=1e-15)


# -- ISO/TS 15066 limits, written from the standard in tests/independent.py ---------------------


def test_the_policy_limits_are_the_standards_formulas(handover):
    """The project's allowed speed against the formulas above, for the handover's policy, at
    separations from inside S_0 to 2 m, on a body capsule and on the receiving hand; the stopping
    term matters here (without it the limit is over 1.5x as lenient), so dropping it is caught."""
    policy = handover[1]
    robot = policy.robot
    person = next(p for p in policy.people if p.contact)
    hand = person.contact[0].capsules[0]
    assert robot.stopping_time > 0.0
    for separation in np.linspace(0.0, 2.0, 41):
        for capsule in ("torso", hand):
            assert allowed_speed(robot, person, separation, capsule) == pytest.approx(
                _allowed(robot, person, separation, capsule), rel=1e-12, abs=1e-12
            ), (separation, capsule)
    far = _s0(robot, person) + 0.5
    lenient = (far - _s0(robot, person)) / robot.reaction_time
    assert lenient > 1.5 * _ssm(robot, person, far)


# -- the monitor against the per-point computation it replaced ---------------------------------
def _reference(
    session: PlanningSession, policy: SeparationPolicy, group: str, q0: np.ndarray, x: np.ndarray, dx: np.ndarray
) -> list[tuple] | str:
    """Per person (separation, body separation, allowed, approach, scale, part, capsule) at one
    point, or the S_0 error message: coal closest points, Jacobian velocities."""
    robot, checker = session.robot, session.checker
    model, model_data = robot.model, robot.model.createData()
    names = robot.group_joints(group)
    q = q0.copy()
    q[robot.group_indices(group)] = x
    velocity = np.zeros(model.nv)
    velocity[[model.joints[model.getJointId(j)].idx_v for j in names]] = dx
    pin.computeJointJacobians(model, model_data, q)
    moved = robot.moved_joints(group)  # which parts move is not what is compared here
    rows = []
    for person in (p for p in policy.people if p.name in checker.humans):
        pairs = checker.person_pairs(q, person.name)
        picked = [k for k, j in enumerate(pairs.joints) if j in moved]
        if not picked:
            rows.append((math.inf, math.inf, math.inf, 0.0, math.inf, "", ""))
            continue
        values = []
        for k in picked:
            joint, d = int(pairs.joints[k]), float(pairs.distance[k])
            twist = pin.getJointJacobian(model, model_data, joint, pin.LOCAL_WORLD_ALIGNED) @ velocity
            v = twist[:3] + np.cross(twist[3:], pairs.robot_point[k] - model_data.oMi[joint].translation)
            contact = person.contact_region(pairs.capsules[k]) is not None
            if contact or d <= 1e-6:
                approach = float(np.linalg.norm(v))
            else:
                approach = float(v @ (pairs.person_point[k] - pairs.robot_point[k]) / d)
            margin = policy.margin  # the padding taken off the separation, the factor below the cap
            allowed = margin.speed_factor * _allowed(policy.robot, person, d - margin.padding, pairs.capsules[k])
            values.append((d, approach, allowed, contact, k))
        stopped = [row for row in values if row[2] <= 0.0 and row[1] > 1e-9]  # closing inside S_0
        if stopped:
            d, _, _, _, k = min(stopped, key=lambda row: row[0])
            return (
                f"{pairs.parts[k]} passes {d:.3f} m from {person.name}/{pairs.capsules[k]}, inside the minimum "
                f"protective separation {_s0(policy.robot, person):.3f} m of ISO/TS 15066 and the padding "
                f"{policy.margin.padding:g} m ({_s0(policy.robot, person) + policy.margin.padding:.3f} m; the robot "
                f"would have to stand still there)"
            )
        binding = min(values, key=lambda row: row[2] - row[1])
        scale = min((row[2] / row[1] for row in values if row[1] > 1e-9), default=math.inf)
        body = min((row[0] for row in values if not row[3]), default=math.inf)
        rows.append(
            (
                min(row[0] for row in values),
                body,
                binding[2],
                binding[1],
                scale,
                pairs.parts[binding[4]],
                pairs.capsules[binding[4]],
            )
        )
    return rows


def _assert_same(
    monitor: ApproachMonitor, reference: list[tuple], x: np.ndarray, dx: np.ndarray, rel: float = 1e-9
) -> None:
    got = monitor.samples(x, dx)
    assert len(got) == len(reference)
    for sample, expected in zip(got, reference):
        for field, value in zip(FIELDS, expected):
            assert getattr(sample, field) == pytest.approx(value, rel=rel, abs=1e-12), field
        assert (sample.part, sample.capsule) == expected[5:]


@pytest.fixture(scope="module")
def handover():
    """The re-plan benchmark's handover: the right arm carries the can (a cylinder) to the receiver."""
    outcome = TaskRunner(load_task(EXAMPLES / "handover_full_can_receiver.yaml"), EXAMPLES).run()
    step = next(s for s in outcome.steps if s.trajectory is not None and s.trajectory.scene.attached)
    traj = step.trajectory
    session = PlanningSession(traj.robot, traj.scene, hands=traj.hands)
    group = next(g for g in session.robot.groups if session.robot.group_joints(g) == traj.joint_names)
    q0 = session.robot.configuration(traj.start)
    xs = np.array(densify([np.array(p.positions) for p in traj.points], 0.05))
    dxs = np.gradient(xs, axis=0) * 4.0  # a joint velocity per point, not all zero, varying in direction
    return session, step.derivation.separation, group, q0, xs, dxs


def test_the_batched_monitor_gives_the_per_point_numbers_on_the_handover(handover, either_route):
    session, policy, group, q0, xs, dxs = handover
    monitor = ApproachMonitor(session.robot, session.checker, policy, group, q0)
    scales = monitor.speed_scale(xs, dxs)
    references = [_reference(session, policy, group, q0, x, dx) for x, dx in zip(xs, dxs)]
    assert len(xs) > 50 and np.isfinite(scales).sum() > 10  # the receiver limits part of the path
    np.testing.assert_allclose(scales, [min(r[4] for r in ref) for ref in references], rtol=1e-9)
    for x, dx, reference in zip(xs, dxs, references):
        _assert_same(monitor, reference, x, dx)
    # The batch reached every kind of pair: the can and the palm (coal), capsules, a contact region.
    bound = {(s.part, s.capsule) for x, dx in zip(xs, dxs) for s in monitor.samples(x, dx)}
    assert len(bound) > 1
    # The separation report re-reads the timing's samples: the same objects, not a recomputation.
    assert monitor.samples(xs[3], dxs[3]) is monitor.samples(xs[3].copy(), dxs[3].copy())


def test_the_monitor_leaves_out_only_pairs_that_cannot_change_a_sample(handover, monkeypatch, either_route):
    """Every pair, capsule (numpy) or not (coal: palm, adapter, can), is measured only where its
    bounds do not rule it out: on the handover's points with random joint velocities (any part
    may bind, set the scale or close in on S_0), every sample or S_0 message is still the
    per-point one, with few of the pairs measured."""
    session, policy, group, q0, xs, _ = handover
    rng = np.random.default_rng(11)
    asked, computed = [], []
    measure, capsules = pin.computeDistance, person_distance.capsule_distances
    monkeypatch.setattr(pin, "computeDistance", lambda *a: asked.append(a[2]) or measure(*a))
    monkeypatch.setattr(person_distance, "capsule_distances", lambda *a: computed.append(len(a[0])) or capsules(*a))
    monitor = ApproachMonitor(session.robot, session.checker, policy, group, q0)
    points = xs[::2]
    velocities = rng.normal(0.0, 0.5, points.shape) * rng.uniform(0.0, 1.0, (len(points), 1))
    for x, dx in zip(points, velocities):
        reference = _reference(session, policy, group, q0, x, dx)
        if isinstance(reference, str):
            with pytest.raises(HriplanError) as error:
                monitor.samples(x, dx)
            assert str(error.value) == reference
        else:  # coal's points on a cylinder (can, adapter), GJK run to 1e-12, are ~1e-6 m from the exact ones
            _assert_same(monitor, reference, x, dx, rel=1e-6)
    model = session.checker.person_model(policy.people[0].name)
    others = [p for p in model.collisionPairs if not isinstance(model.geometryObjects[p.first].geometry, coal.Capsule)]
    if either_route:  # the compiled route measures boxes and cylinders itself; nothing here touches her
        assert asked == []
    else:
        assert 0 < len(asked) < 0.2 * len(others) * len(points)
    rows = monitor._pairs(policy.people[0])[0]._capsule_rows.size  # the moved parts' capsule pairs
    if not either_route:  # the compiled route measures its capsule pairs in its own loop
        assert 0 < sum(computed) < 0.25 * rows * len(points)
    shapes = {g.name: type(g.geometry) for g in model.geometryObjects}
    bound = [s.part for x, dx in zip(points, velocities) for s in monitor.samples(x, dx)]
    assert any(shapes[part] is not coal.Capsule for part in bound)  # a coal pair binds somewhere


def test_a_pair_that_could_bind_is_measured_though_it_is_neither_closest_nor_slowest(handover):
    """Per unit of joint velocity a path may approach faster than allowed (scale < 1). A (a
    capsule pair, the closest) allows 1.0 m/s and approaches at 3.0: margin -2.0, scale 0.33. B
    (a coal pair, farther) may allow as little as ~1.05 and move at up to 3.1: margin down to
    -2.05, scale at least 0.34. B may bind without lowering the scale: it is measured."""
    session, policy, group, q0, _, _ = handover
    monitor = ApproachMonitor(session.robot, session.checker, policy, group, q0)
    person = monitor.people[0]
    body = next(c for c in ("middle_thorax", "pelvis", "head") if person.contact_region(c) is None)
    separations = np.linspace(0.0, 3.0, 301)
    factor, padding = policy.margin.speed_factor, policy.margin.padding
    allowed = [factor * _allowed(policy.robot, person, d - padding, body) for d in separations]
    a = float(np.interp(1.0, allowed, separations))  # where A is allowed 1.0 m/s (linear past S_0)
    pairs = StatePairs(
        ["a", "b"],
        [body, body],
        np.array([[a, np.inf]]),
        np.zeros((1, 2, 3)),
        np.array([[[a, 0.0, 0.0], [0.0, 0.0, 0.0]]]),
        np.array([[[3.0, 0.0, 0.0], [0.0, 0.0, 0.0]]]),
    )
    kind = _Rows(np.array([False, False]), np.zeros(2))
    select = monitor._deciding(person, kind, _Speeds(policy, person, kind, (1, 2)))
    floor = a + 0.01
    lowest = factor * _allowed(policy.robot, person, floor - padding, body)
    speed = 3.1
    assert lowest - speed < 1.0 - 3.0 and lowest / speed > 1.0 / 3.0  # could bind, cannot slow
    floors = np.array([[a - 0.01, floor]])
    assert select.needed(pairs, floors, np.array([[3.0, speed]])).tolist() == [[True, True]]
    # a B that can neither bind nor slow nor be the closest is left out
    assert select.needed(pairs, floors, np.array([[3.0, 1.0]])).tolist() == [[True, False]]
    # The compiled route asks the same of B, given what A measured (approach_kernels.py).
    kernels = pytest.importorskip("hriplan.safety.approach_kernels")
    measured = (a, a, 1.0 - 3.0, 1.0 / 3.0)  # nearest, body, margin and scale so far
    iso = np.array([*kept_speed_terms(policy, person), BOUND_TOLERANCE, CLOSING, 1e-6, ROUNDING])
    assert kernels._kept(floor, 0.0, iso) == pytest.approx(lowest, rel=1e-12)
    assert kernels._needed(floor, speed, lowest, False, *measured, CLOSING)
    assert not kernels._needed(floor, 1.0, lowest, False, *measured, CLOSING)


def _right_arm_sweep(session: PlanningSession) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """From the ready posture, the right arm sweeps out past the people (30 points, one velocity)."""
    q0 = session.robot.configuration(posture("madar", "ready"))
    x0 = session.robot.group_values(q0, "right_arm")
    xs = np.linspace(x0, x0 + np.array([0.8, -0.4, 0.4, 0.3, -0.2, 0.5]), 30)
    return q0, xs, np.tile([0.3, -0.2, 0.4, 0.5, -0.3, 0.2], (30, 1))


def test_the_batched_monitor_follows_every_person_and_their_moves(either_route):
    people = [
        HumanSpec(name="sam", position=(1.38, 0.65), yaw=math.pi),
        HumanSpec(name="ann", position=(0.9, 1.5), yaw=-1.6, reach={"left": (0.95, 1.1, 1.1)}),
    ]
    session = PlanningSession("madar", Scene(humans=people), hands={"right": "open"})
    policy = default_policy("madar", people, {"sam": "Supervisor", "ann": "Giver"}).model_copy(
        update={"margin": SafetyMargin(padding=0.0, speed_factor=0.9)}  # the sweep passes 0.317 m from sam
    )
    q0, xs, dxs = _right_arm_sweep(session)
    monitor = ApproachMonitor(session.robot, session.checker, policy, "right_arm", q0)
    scales = monitor.speed_scale(xs, dxs)
    references = [_reference(session, policy, "right_arm", q0, x, dx) for x, dx in zip(xs, dxs)]
    # The least scale over both people, and each of them sets it somewhere along the sweep.
    np.testing.assert_allclose(scales, [min(r[4] for r in ref) for ref in references], rtol=1e-9)
    assert {int(np.argmin([r[4] for r in ref])) for ref in references} == {0, 1}
    for x, dx, reference in zip(xs, dxs, references):
        _assert_same(monitor, reference, x, dx)
    # A new scene (the checker rebuilds the person models) is measured afresh by a new monitor's batch.
    session.set_scene(Scene(humans=[people[0].model_copy(update={"position": (1.6, 0.4)}), people[1]]))
    moved = ApproachMonitor(session.robot, session.checker, policy, "right_arm", q0)
    for x, dx in zip(xs[::7], dxs[::7]):
        _assert_same(moved, _reference(session, policy, "right_arm", q0, x, dx), x, dx)


def test_a_part_inside_the_minimum_separation_raises_the_per_point_message(handover, either_route):
    session, policy, group, q0, xs, dxs = handover
    robot = policy.robot.model_copy(update={"position_uncertainty": 0.4})  # S_0 grows by 0.38 m
    strict = policy.model_copy(update={"robot": robot})
    references = [_reference(session, strict, group, q0, x, dx) for x, dx in zip(xs, dxs)]
    stops = [r for r in references if isinstance(r, str)]
    assert 0 < len(stops) < len(references) and not isinstance(
        references[0], str
    )  # the first stop is found, not the first row
    monitor = ApproachMonitor(session.robot, session.checker, strict, group, q0)
    with pytest.raises(HriplanError) as raised:
        monitor.speed_scale(xs, dxs)
    assert str(raised.value) == stops[0]


def test_the_first_point_inside_s0_is_reported_whichever_person_it_is(either_route):
    """Policy order sam, ben; the path reaches ben's S_0 (point 8) before sam's (point 13)."""
    people = [
        HumanSpec(name="sam", position=(1.38, 0.65), yaw=math.pi),
        HumanSpec(name="ben", position=(0.3, 1.5), yaw=-math.pi / 2),
    ]
    session = PlanningSession("madar", Scene(humans=people), hands={"right": "open"})
    policy = default_policy("madar", people, {"sam": "Supervisor", "ben": "Bystander"})
    strict = policy.model_copy(update={"robot": policy.robot.model_copy(update={"position_uncertainty": 0.2})})
    q0, xs, dxs = _right_arm_sweep(session)
    references = [_reference(session, strict, "right_arm", q0, x, dx) for x, dx in zip(xs, dxs)]
    first = next(r for r in references if isinstance(r, str))
    assert "from ben/" in first and "from sam/" in references[-1]
    with pytest.raises(HriplanError) as raised:
        ApproachMonitor(session.robot, session.checker, strict, "right_arm", q0).speed_scale(xs, dxs)
    assert str(raised.value) == first


def test_the_monitor_does_not_query_every_pair_through_coal_point_by_point(handover, monkeypatch):
    """The speed guard: capsule pairs (most of them) are batched; `person_pairs` (all ~500 pairs
    through coal, read from Python: the former route) is not used."""
    session, policy, group, q0, xs, dxs = handover

    def refused(*_):
        raise AssertionError("person_pairs called by the monitor")

    monkeypatch.setattr(session.checker, "person_pairs", refused)
    scales = ApproachMonitor(session.robot, session.checker, policy, group, q0).speed_scale(xs, dxs)
    assert np.isfinite(scales).any()


def test_monitors_share_a_persons_pair_geometry_which_follows_the_person(either_route):
    """Every timing call makes a monitor; the pair geometry of a person model is made once
    (`PersonDistances.of`) and serves the next monitors wherever the person has moved, and a
    new model (another body) gets its own."""
    sam = HumanSpec(name="sam", position=(1.38, 0.65), yaw=math.pi)
    session = PlanningSession("madar", Scene(humans=[sam]), hands={"right": "open"})
    policy = default_policy("madar", [sam], {"sam": "Supervisor"}).model_copy(
        update={"margin": SafetyMargin(padding=0.0, speed_factor=0.9)}
    )
    q0, xs, dxs = _right_arm_sweep(session)
    first = ApproachMonitor(session.robot, session.checker, policy, "right_arm", q0)
    first.speed_scale(xs, dxs)
    closer = sam.model_copy(update={"position": (1.45, 0.6)})
    session.pose_human(closer)  # the same person model, its capsules placed anew
    second = ApproachMonitor(session.robot, session.checker, policy, "right_arm", q0)
    moved = second.speed_scale(xs, dxs)
    shared = first._pairs(policy.people[0])[0]
    assert second._pairs(policy.people[0])[0] is shared
    for x, dx in zip(xs[::5], dxs[::5]):
        _assert_same(second, _reference(session, policy, "right_arm", q0, x, dx), x, dx)
    assert not np.allclose(moved, first.speed_scale(xs, dxs))  # she moved: other limits
    # Every pair, coal's included (palm, adapter), where she stands now (coal's GJK: to 1e-6).
    qs = np.array([second.full(x) for x in xs[::5]])
    pairs = shared.at(qs, np.zeros((len(qs), session.robot.model.nv)))
    for q, distance in zip(qs, pairs.distance):
        fresh = session.checker.person_pairs(q, "sam")
        expected = {(p, c): d for p, c, d in zip(fresh.parts, fresh.capsules, fresh.distance)}
        np.testing.assert_allclose(distance, [expected[pc] for pc in zip(pairs.parts, pairs.capsules)], atol=1e-5)
    taller = closer.model_copy(update={"height": 1.9})
    session.set_scene(Scene(humans=[taller]))  # another body: another person model
    third = ApproachMonitor(session.robot, session.checker, policy, "right_arm", q0)
    assert third._pairs(policy.people[0])[0] is not shared
    for x, dx in zip(xs[::5], dxs[::5]):
        _assert_same(third, _reference(session, policy, "right_arm", q0, x, dx), x, dx)


def test_every_pairs_bounds_hold_at_random_states(handover):
    """The bounds the monitor prunes with, on random states of the arm with random joint
    velocities: each pair's distance bound is at most coal's distance (`person_pairs`), its speed
    bound at least the speed of the part's closest point (pinocchio's Jacobian)."""
    session, policy, group, q0, _, _ = handover
    robot, checker = session.robot, session.checker
    monitor = ApproachMonitor(robot, checker, policy, group, q0)
    person = monitor.people[0]
    distances = monitor._pairs(person)[0]
    rng = np.random.default_rng(4)
    low, high = robot.limits(group)
    xs, dxs = rng.uniform(low, high, (40, len(low))), rng.normal(0.0, 1.0, (40, len(low)))
    model, data = robot.model, robot.model.createData()
    iv = [model.joints[model.getJointId(j)].idx_v for j in robot.group_joints(group)]
    qs, dqs = np.array([monitor.full(x) for x in xs]), np.zeros((len(xs), model.nv))
    dqs[:, iv] = dxs
    bounds = {}

    def likely(floor: np.ndarray, speed: np.ndarray) -> np.ndarray:
        bounds.update(floor=floor, speed=speed)
        return np.zeros(floor.shape, dtype=bool)

    distances.at(qs, dqs, Select(likely, lambda pairs, floor, speed: np.zeros(floor.shape, dtype=bool)))
    rows = {(p, c): k for k, (p, c) in enumerate(zip(distances.parts, distances.capsules))}
    checked = 0
    for n, (q, dq) in enumerate(zip(qs, dqs)):
        pairs = checker.person_pairs(q, person.name)
        pin.computeJointJacobians(model, data, q)
        for j, part, capsule, d, point in zip(
            pairs.joints, pairs.parts, pairs.capsules, pairs.distance, pairs.robot_point
        ):
            k = rows.get((part, capsule))
            if k is None:  # a part the arm does not move
                continue
            twist = pin.getJointJacobian(model, data, int(j), pin.LOCAL_WORLD_ALIGNED) @ dq
            speed = np.linalg.norm(twist[:3] + np.cross(twist[3:], point - data.oMi[int(j)].translation))
            assert bounds["floor"][n, k] <= d, (part, capsule)
            assert bounds["speed"][n, k] >= speed * (1.0 - 1e-12), (part, capsule)
            checked += 1
    assert checked == len(qs) * len(distances.parts)
    assert (bounds["floor"] > 0.0).mean() > 0.5  # not trivially low
    # The compiled route prunes with the same distance bounds, to rounding (approach_kernels._floor).
    kernels = pytest.importorskip("hriplan.safety.approach_kernels")
    (robot_arrays, row_arrays), placed = distances._kernel_geometry, distances._kernel_person()
    frames = distances._kinematics(qs, dqs)
    rotation, origin = np.ascontiguousarray(frames.rotation), np.ascontiguousarray(frames.origin)
    centre, centre_sq, capsules = (
        np.empty((robot_arrays[5].size, 3)),
        np.empty(robot_arrays[5].size),
        robot_arrays[0].size,
    )
    terms = kernels._person_terms(placed)
    for n in range(len(qs)):
        kernels._place_parts(rotation, origin, n, robot_arrays, centre, centre_sq, *np.empty((2, capsules, 3)))
        compiled = [
            kernels._floor(centre, centre_sq, terms, robot_arrays, row_arrays, placed, k, BOUND_TOLERANCE)
            for k in range(len(distances.parts))
        ]
        np.testing.assert_allclose(compiled, bounds["floor"][n], rtol=0.0, atol=1e-9)


def test_a_person_no_moved_part_faces_gets_an_empty_batch():
    """No row (the joints carry no part): nothing to bound or select, no error."""
    sam = HumanSpec(name="sam", position=(1.38, 0.65), yaw=math.pi)
    session = PlanningSession("madar", Scene(humans=[sam]), hands={"right": "open"})
    distances = PersonDistances(session.robot.model, session.checker.person_model("sam"), [])
    model = session.robot.model
    nothing = Select(lambda floor, speed: np.ones(floor.shape, dtype=bool), lambda *a: np.ones(a[1].shape, dtype=bool))
    pairs = distances.at(np.zeros((3, model.nq)), np.zeros((3, model.nv)), nothing)
    assert pairs.distance.shape == (3, 0) and pairs.robot_velocity.shape == (3, 0, 3)


def test_nearest_is_the_least_of_every_row_measured(handover):
    """`PersonDistances.nearest` (compiled: it bounds rows, and passes a part whole while its
    sphere has not moved enough since its bounds were far) names the row and state of the least
    distance of every row measured by the batch (numpy capsules, coal's other shapes), on a path
    creeping along the handover, jumping about, and held still; with a ceiling above it too."""
    pytest.importorskip("hriplan.safety.approach_kernels")
    session, policy, group, q0, xs, _ = handover
    monitor = ApproachMonitor(session.robot, session.checker, policy, group, q0)
    distances = monitor._pairs(monitor.people[0])[0]
    rng = np.random.default_rng(12)
    creeping = np.repeat(xs, 3, axis=0) + rng.normal(0.0, 1e-3, (3 * len(xs), xs.shape[1]))
    jumping = xs[rng.integers(len(xs), size=60)] + rng.normal(0.0, 0.3, (60, xs.shape[1]))
    for path in (creeping, jumping, np.concatenate([jumping, creeping]), np.repeat(xs[-1:], 5, axis=0)):
        qs = np.array([monitor.full(x) for x in path])
        every = distances.at(qs, np.zeros((len(qs), session.robot.model.nv))).distance
        state, row = np.unravel_index(np.argmin(every), every.shape)  # the first of the least, by state
        least = every[state, row]
        distance, *at = distances.nearest(qs)
        assert at == [state, row] and distance == pytest.approx(least, abs=1e-9)
        assert distances.nearest(qs, least + 1e-3)[1:] == (state, row)
        below = distances.nearest(qs, least - 1e-3)  # none within the ceiling: what it measured, if any
        assert below == (np.inf, -1, -1) or below[0] >= least - 1e-9
