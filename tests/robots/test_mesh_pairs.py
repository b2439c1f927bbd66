"""Mesh pairs decided on their triangles (`mesh_pairs.py`, `mesh_pair_kernels.py`), checked
against coal: on triangle pairs placed a given gap apart or into each other, and on the tabled
mesh pairs of four arms near contact against the URDF's own meshes (tests/independent.py), and
through `in_collision` with the kernels on and off.

A verdict must be coal's wherever it is given, and hold when a triangle moves by less than the
margin (so that coal's tolerances cannot reach it); and most states near contact must get one.
"""

import coal
import numpy as np
import pinocchio as pin
import pytest

from data_robots import data_robot
from hriplan.robots import kernel_switch
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.descriptions.registry import posture
from hriplan.robots.mesh_clearance import clearance_tables
from hriplan.robots.mesh_pairs import MARGIN, MeshPair
from hriplan.robots.model import load_robot
from hriplan.robots.robot_geometry import part_collision_shapes
from independent import UrdfMeshes

numba = pytest.importorskip("numba")
from hriplan.robots.mesh_pair_kernels import triangles_apart, triangles_touch  # noqa: E402

pytestmark = pytest.mark.usefixtures("module_robot_registry")
_IDENTITY = coal.Transform3s()


def _mesh(triangle: np.ndarray) -> coal.BVHModelOBBRSS:
    mesh = coal.BVHModelOBBRSS()
    mesh.beginModel(1, 3)
    mesh.addTriangle(*triangle.reshape(3, 3))
    mesh.endModel()
    return mesh


def _coal_touch(p: np.ndarray, q: np.ndarray) -> bool:
    request = coal.CollisionRequest()
    request.enable_contact = True
    return coal.collide(_mesh(p), _IDENTITY, _mesh(q), _IDENTITY, request, coal.CollisionResult())


def _coal_distance(p: np.ndarray, q: np.ndarray) -> coal.DistanceResult:
    result = coal.DistanceResult()
    coal.distance(_mesh(p), _IDENTITY, _mesh(q), _IDENTITY, coal.DistanceRequest(), result)
    return result


def _triangle_pairs(count: int, seed: int):
    """Pairs of 1-5 cm triangles, the second moved along the line of their nearest points so that
    their gap is one of +-1e-7..1e-3 m (negative: into each other); a third of them coplanar-ish
    (the second's vertices near the first's plane) or sharing an edge's line."""
    rng = np.random.default_rng(seed)
    for n in range(count):
        p = rng.uniform(-0.02, 0.02, 9)
        q = rng.uniform(-0.02, 0.02, 9)
        if n % 3 == 1:  # nearly parallel planes
            normal = np.cross(p[3:6] - p[:3], p[6:] - p[:3])
            normal /= np.linalg.norm(normal)
            q = q.reshape(3, 3)
            q -= np.outer((q - p[:3]) @ normal, normal) * rng.uniform(0.9, 1.0)
            q = q.ravel()
        result = _coal_distance(p, q)
        target = rng.choice([-1.0, 1.0]) * 10 ** rng.uniform(-7, -3)
        gap = result.min_distance
        if gap <= 0.0:
            continue
        direction = (result.getNearestPoint2() - result.getNearestPoint1()) / gap
        yield p, q + np.tile(direction * (target - gap), 3)


def test_triangle_verdicts_are_coal_s_and_hold_within_the_margin():
    """Every pair called apart is farther apart than the margin by coal's distance; every pair
    called touching still collides in coal moved by 0.99 margin in random directions. Nearly
    every pair farther apart than twice the margin is called apart; many pairs, touching."""
    rng = np.random.default_rng(3)
    apart = touching = asked = far = 0
    for p, q in _triangle_pairs(6000, seed=1):
        asked += 1
        distance = _coal_distance(p, q).min_distance
        far += distance > 2 * MARGIN
        if triangles_apart(p, q, MARGIN):
            apart += 1
            assert distance > MARGIN * (1 - 1e-6), (p.tolist(), q.tolist())
        if triangles_touch(p, q, MARGIN):
            touching += 1
            assert _coal_touch(p, q), (p.tolist(), q.tolist())
            for direction in rng.normal(size=(4, 3)):
                shift = np.tile(direction / np.linalg.norm(direction) * 0.99 * MARGIN, 3)
                assert _coal_touch(p, q + shift), (p.tolist(), q.tolist(), shift[:3].tolist())
    assert apart > 0.95 * far > 0.2 * asked and touching > 0.1 * asked, (apart, far, touching, asked)


def _robots():
    return {
        "ur5": load_robot("ur5"),
        "madar": load_robot("madar"),
        "ur10": data_robot("ur10"),
        "panda": data_robot("panda"),
    }


@pytest.fixture(scope="module")
def robots():
    return _robots()


def _tabled(robot):
    checker = CollisionChecker(robot)
    return checker, clearance_tables(robot, checker.parts, checker.acm)


def _placed(robot, shapes, q: np.ndarray) -> list[pin.SE3]:
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q)
    return [data.oMi[s.parentJoint] * s.placement for s in shapes]


def _near_contact(robot, table, touches, rng, count: int, base=None) -> tuple[np.ndarray, np.ndarray]:
    """States near where the pair starts to touch: from a random state where it touches (none in
    4000 tries: no states), along a random direction in the table's joints, the first state where
    it does not, found by bisection (to 1e-9 rad); then states offset from there by +-1e-7..3e-2
    rad (either side of the boundary); and each one's offset. With `base`, only the table's joints
    are drawn, the others stay there."""
    model, states, offsets = robot.model, [], []
    lower, upper = model.lowerPositionLimit, model.upperPositionLimit
    tries = 0
    while len(states) < count:
        q = rng.uniform(lower, upper)
        if base is not None:
            q = np.where(np.isin(np.arange(model.nq), table.q_index), q, base)
        tries += 1
        if not touches(q):
            if tries > 4000 and not states:
                break
            continue
        direction = np.zeros(model.nq)
        direction[list(table.q_index)] = rng.normal(size=len(table.q_index))
        direction /= np.linalg.norm(direction)
        steps = [
            s for s in np.arange(0.0, 2.0, 0.025) if np.all((q + direction * s >= lower) & (q + direction * s <= upper))
        ]
        out = [s for s in steps if not touches(q + direction * s)]
        if not out:
            continue
        low, high = out[0] - 0.025, out[0]
        while high - low > 1e-9:
            middle = 0.5 * (low + high)
            low, high = (middle, high) if touches(q + direction * middle) else (low, middle)
        for offset in rng.choice([-1.0, 1.0], 8) * 10 ** rng.uniform(-7, np.log10(3e-2), 8):
            states.append(q + direction * (low + offset))
            offsets.append(abs(offset))
    states = np.clip(np.array(states[:count]).reshape(-1, model.nq), lower, upper)
    return states, np.array(offsets[:count])


@pytest.mark.parametrize("name", ["ur5", "ur10", "panda"])
def test_tabled_pairs_near_contact_agree_with_the_urdf_meshes(robots, name):
    """On 1500 states near contact per tabled pair: a verdict wherever coal on the URDF's own
    meshes says the same; one for at least 90 % of those 1e-3 rad or more from contact (a
    link's points move ~1e-4 m there, ten margins), both verdicts in number."""
    robot = robots[name]
    checker, tables = _tabled(robot)
    by_name = {part.name: part for part in checker.parts}
    meshes = UrdfMeshes(robot)
    meshes.watch([f"{a}|{b}" for a, b in (t.parts for t in tables)])
    rng = np.random.default_rng(11)
    tested = 0
    for table in tables:
        first, second = (part_collision_shapes(robot, by_name[part]) for part in table.parts)
        assert len(first) == len(second) == 1
        pair = MeshPair.of(first[0].geometry, second[0].geometry)
        if pair is None:  # a box (the UR10's base): coal's
            continue
        name_of = "|".join(table.parts)

        def coal_touches(q: np.ndarray, name_of: str = name_of) -> bool:
            return name_of in meshes.touching(q)

        counts = {True: 0, False: 0, None: 0}
        states, offsets = _near_contact(robot, table, coal_touches, rng, 1500)
        if not len(states):  # the pair never touches (the UR10's base and upper arm)
            continue
        tested += 1
        for q, offset in zip(states, offsets):
            mine = pair.touches(*_placed(robot, [first[0], second[0]], q))
            counts[mine] += offset >= 1e-3
            if mine is not None:
                assert mine == coal_touches(q), f"{name} {name_of} at {q.tolist()}: {mine}"
        assert counts[None] < 0.1 * sum(counts.values()) and counts[True] > 100 and counts[False] > 100, counts
    assert tested


def test_in_collision_with_the_trees_is_coal_s(robots):
    """MADAR's states near its arms' forearm-wrist 2 contact (the peg-in-hole scenario's): the
    checker with the kernels on (the trees asked first) says what it says with them off. Only
    the wrist joints move, from the ready posture."""
    robot = robots["madar"]
    checker, tables = _tabled(robot)
    by_name = {part.name: part for part in checker.parts}
    rng = np.random.default_rng(5)
    base, states = robot.configuration(posture("madar", "ready")), []
    for table in tables:
        if "fore_arm_link" not in table.parts[0]:
            continue
        first, second = (part_collision_shapes(robot, by_name[part])[0] for part in table.parts)

        def touches(q: np.ndarray, first=first, second=second) -> bool:
            a, b = _placed(robot, [first, second], q)
            request = coal.CollisionRequest()
            request.enable_contact = True
            placed = [coal.Transform3s(x.rotation, x.translation) for x in (a, b)]
            return coal.collide(first.geometry, placed[0], second.geometry, placed[1], request, coal.CollisionResult())

        states += list(_near_contact(robot, table, touches, rng, 600, base)[0])
    kernel_switch.use_kernels(False)
    expected = [checker.in_collision(q) for q in states]
    kernel_switch.use_kernels(True)
    try:
        assert [checker.in_collision(q) for q in states] == expected
        assert checker.first_collision(np.array(states)) == (expected.index(True) if any(expected) else None)
        # The compiled verdict decides them itself (`certifier_kernels._decided_tables`): proven
        # touching only where coal finds a collision, and a table left to coal exactly where the
        # trees asked from Python (`MeshPair.touches`, pinocchio's placements) prove nothing.
        asked, touching, verdicts = checker._free_certifier().left_over(np.array(states))
        assert all(expected[k] for k, proven in zip(asked, touching) if proven) and any(touching)
        assert all(not expected[k] for k in set(range(len(states))) - set(asked))
        left = {k for k, verdict in zip(asked, verdicts) if verdict is not None and verdict[0]}
        assert left == set(np.flatnonzero([_trees_undecided(checker, q) for q in states]).tolist())
    finally:
        kernel_switch.use_kernels(False)
    assert 0.2 < np.mean(expected) < 0.8


def _trees_undecided(checker: CollisionChecker, q: np.ndarray) -> bool:
    """Do the trees of a tabled pair whose table does not certify `q` prove nothing there?"""
    model, data = checker.robot.model, checker.robot.data
    pin.updateGeometryPlacements(model, data, checker._geom_model, checker._geom_data, q)
    placed = checker._geom_data.oMg
    for table, ks in checker._tabled:
        if table.certified(q.tolist()):
            continue
        for k in ks:
            first, second = (int(i) for i in checker._pair_table[k])
            if checker._mesh_pair(first, second).touches(placed[first], placed[second]) is None:
                return True
    return False


@pytest.mark.parametrize("count", [1, 2, 3, 7, 64, 1000])
def test_a_tree_halves_each_node_across_its_widest_spread(count):
    """Every node's triangles are its children's, the left half the smaller, split where their
    centres spread most (ties and equal spreads included); leaves hold one triangle; nodes come
    level by level, a child after its parent."""
    from hriplan.robots.mesh_pair_kernels import COUNT, FIRST
    from hriplan.robots.mesh_tree_kernels import split

    rng = np.random.default_rng(count)
    centres = np.round(rng.normal(size=(count, 3)) * [1.0, 3.0, 0.5], 1)  # rounded: equal values
    order, nodes = split(centres)
    assert sorted(order.tolist()) == list(range(count))
    assert nodes.shape == (2 * count - 1, 4) and nodes[0, FIRST] == 0 and nodes[0, COUNT] == count
    depth = {0: 0}
    for n, (left, right, first, size) in enumerate(nodes.tolist()):
        if size == 1:
            assert left == right == -1
            continue
        assert left > n and right == left + 1
        assert nodes[left, FIRST] == first and nodes[left, COUNT] == size // 2
        assert nodes[right, FIRST] == first + size // 2 and nodes[right, COUNT] == size - size // 2
        depth[left] = depth[right] = depth[n] + 1
        members = centres[order[first : first + size]]
        axis = int(np.argmax(members.max(axis=0) - members.min(axis=0)))
        along = members[:, axis]  # the halves are apart along it (their own order is their children's)
        assert along[: size // 2].max() <= along[size // 2 :].min()
    assert list(depth) == sorted(depth) and np.all(np.diff([depth[n] for n in sorted(depth)]) >= 0)


def test_boxes_are_parted_as_along_their_15_axes():
    """`_boxes_apart` parts two random boxes exactly when one of their 15 axes (each's 3, the 9
    crosses of one's with the other's, unnormalised) parts their projections by more than the
    margin (an unrolled cross with a wrong index, or a point called in both boxes that is not,
    fails here)."""
    from hriplan.robots.mesh_pair_kernels import _boxes_apart

    rng = np.random.default_rng(5)
    margin, parted, asked = 1e-3, 0, 0
    for _ in range(3000):
        a = np.concatenate([rng.uniform(-0.3, 0.3, 3), rng.uniform(0.01, 0.3, 3)])
        b = np.concatenate([rng.uniform(-0.3, 0.3, 3), rng.uniform(0.01, 0.3, 3)])
        rotation = pin.exp3(rng.normal(size=3))
        translation = rng.uniform(-0.3, 0.3, 3)
        pose = np.concatenate([rotation.ravel(), translation])
        t = translation + rotation @ b[:3] - a[:3]
        axes = [np.eye(3)[i] for i in range(3)] + [rotation[:, j] for j in range(3)]
        axes += [np.cross(np.eye(3)[i], rotation[:, j]) for i in range(3) for j in range(3)]
        gaps = [abs(t @ u) - np.abs(u) @ a[3:] - np.abs(rotation.T @ u) @ b[3:] - margin for u in axes]
        if min(abs(g) for g in gaps) < 1e-9:  # too near the margin for rounding to agree
            continue
        expected = max(gaps) > 0.0
        assert _boxes_apart(a, b, pose, np.abs(pose[:9]), margin) == expected
        parted, asked = parted + expected, asked + 1
    assert asked > 2900 and 0.2 * asked < parted < 0.8 * asked
