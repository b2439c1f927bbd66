"""The compiled certifier (robots/free_certifier.py, certifier_kernels.py, kernel_fk.py) against
pinocchio and coal.

Its forward kinematics is pinocchio's to 1e-9; its bounds are never above coal's distances; a
state it certifies is free for coal (10 000 random states per robot, in scenes with boxes, a
cylinder, a mesh and people close by); and the checker answers the same with and without it.
"""

from __future__ import annotations

import copy
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
import pytest

pytest.importorskip("numba")

from hriplan.robots import free_certifier, kernel_switch
from hriplan.robots.certifier_kernels import (
    APART,
    EXACT,
    EXACT_BOX,
    EXACT_CAPSULE,
    PAIR,
    REACH,
    ROW,
    TOUCHING,
    capsule_beyond_face,
    capsule_box_floor,
    capsule_clears_box,
    capsule_in_box,
    exact_verdict,
    place_joints,
    same_joints,
    segment_floor,
    verdict_of,
    verdict_one,
    verdict_views,
)
from hriplan.robots.certifier_kernels import verdicts as verdict_codes
from hriplan.robots.collision import CollisionChecker, SeparationZones
from hriplan.robots.descriptions.registry import load_robot_file
from hriplan.robots.free_certifier import (
    _LEAF,
    ASKED_OF_COAL,
    FreeCertifier,
    _geometry_row,
    _mesh_pieces,
    _spheres_about,
    _static_rows,
)
from hriplan.robots.human import HumanSpec
from hriplan.robots.kernel_fk import joint_tables
from hriplan.robots.mesh_clearance import FINE
from hriplan.robots.model import load_robot
from hriplan.robots.scene import Box, Cone, Cylinder, Obstacle, Scene, Sphere
from hriplan.robots.spatial import Pose

BAXTER = Path(__file__).parents[1] / "data" / "robots" / "baxter.yaml"
STATES = 10_000

pytestmark = pytest.mark.usefixtures("module_robot_registry")


@pytest.fixture(scope="module")
def robots():
    return {"ur5": load_robot("ur5"), "madar": load_robot("madar"), "baxter": load_robot(load_robot_file(BAXTER).name)}


def _random_states(robot, n: int, seed: int) -> np.ndarray:
    model = robot.model
    return np.random.default_rng(seed).uniform(model.lowerPositionLimit, model.upperPositionLimit, (n, model.nq))


def _worst_fk_error(model: pin.Model, states) -> float:
    """The largest difference between the kernel's joint frames and pinocchio's over `states`."""
    data = model.createData()
    rows, ints = joint_tables(model)
    rotation, origin = np.empty((model.njoints, 3, 3)), np.empty((model.njoints, 3))
    worst = 0.0
    for q in states:
        pin.forwardKinematics(model, data, q)
        place_joints(q, rows, ints, rotation, origin)
        for j in range(model.njoints):
            worst = max(worst, np.abs(data.oMi[j].rotation - rotation[j]).max())
            worst = max(worst, np.abs(data.oMi[j].translation - origin[j]).max())
    return worst


@pytest.mark.parametrize("name", ["ur5", "madar", "baxter"])
def test_forward_kinematics_is_pinocchios(robots, name):
    assert _worst_fk_error(robots[name].model, _random_states(robots[name], 500, 1)) < 1e-9


# A tree of every joint kind the kernel walks, on tilted axes and turned placements (TIAGo's torso
# lift slides, a Kinova's wrist turns without end): the built-in robots have revolute joints only.
EVERY_KIND = """<robot name="kinds"><link name="w"/><link name="a"/><link name="b"/><link name="c"/><link name="d"/>
<joint name="slide" type="prismatic"><parent link="w"/><child link="a"/><origin xyz="0.1 -0.2 0.3" rpy="0.3 -0.2 0.7"/>
  <axis xyz="0.6 0 0.8"/><limit lower="-0.5" upper="0.5" effort="1" velocity="1"/></joint>
<joint name="spin" type="continuous"><parent link="a"/><child link="b"/><origin xyz="0 0.4 0" rpy="1.2 0 -0.4"/>
  <axis xyz="0 1 0"/></joint>
<joint name="turn" type="revolute"><parent link="b"/><child link="c"/><origin xyz="0.2 0 0.1" rpy="0 0.9 0"/>
  <axis xyz="0.36 0.48 0.8"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
<joint name="branch" type="prismatic"><parent link="a"/><child link="d"/><origin xyz="0 0 -0.3"/>
  <axis xyz="0 0 1"/><limit lower="0" upper="0.2" effort="1" velocity="1"/></joint></robot>"""


def test_joint_tables_of_a_model_changed_in_place_are_its_own(robots):
    """Tables are kept per model, found again only for a model equal to the one they were made
    of, and handed out as the caller's own arrays."""
    model = pin.Model(robots["ur5"].model)
    before = joint_tables(model)
    model.jointPlacements[2] = pin.SE3(np.eye(3), np.array([0.0, 0.3, 0.1])) * model.jointPlacements[2]
    after, fresh = joint_tables(model), joint_tables(pin.Model(model))
    assert not np.array_equal(before[0], after[0]) and np.array_equal(after[0], fresh[0])
    after[0][:], after[1][:] = 0.0, 0
    again = joint_tables(model)
    assert np.array_equal(again[0], fresh[0]) and np.array_equal(again[1], fresh[1])


def test_forward_kinematics_of_every_joint_kind_is_pinocchios():
    model = pin.buildModelFromXML(EVERY_KIND)
    rng, k = np.random.default_rng(3), model.idx_qs[model.getJointId("spin")]
    states = []
    for _ in range(300):
        q = pin.randomConfiguration(model, np.full(model.nq, -1.0), np.full(model.nq, 1.0))
        q[k : k + 2] = [np.cos(a := rng.uniform(-np.pi, np.pi)), np.sin(a)]  # the continuous joint's (cos, sin)
        states.append(q)
    assert _worst_fk_error(model, states) < 1e-9


def _capsule_rows(rng, n: int, kind: str = "any") -> np.ndarray:
    """Rows (n, 23) of random capsules (ends, radius) within a metre: in pairs (2k, 2k + 1) at
    any angle, nearly parallel, or nearly parallel and crossing near their middles (where the
    least distance is inside both and the ends' distances are above it)."""
    rows = np.zeros((n, 23))
    start = rng.uniform(-0.5, 0.5, (n, 3))
    direction = rng.normal(size=(n, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    length = rng.uniform(0.0, 0.6, (n, 1)) * (rng.uniform(size=(n, 1)) > 0.1)
    if kind != "any":
        tilt = rng.normal(scale=10.0 ** rng.uniform(-7, -4, (n // 2, 1)), size=(n // 2, 3))
        direction[1::2] = direction[::2] + tilt
        direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    if kind == "crossing":
        length[1::2] = length[::2] = np.maximum(length[::2], 0.3)
        middle = start[::2] + direction[::2] * length[::2] / 2 + rng.normal(scale=1e-5, size=(n // 2, 3))
        start[1::2] = middle - direction[1::2] * length[1::2] / 2
    rows[:, 0:3], rows[:, 3:6] = start, start + direction * length
    rows[:, 6] = rng.uniform(0.01, 0.15, n)
    return rows


def _coal_capsule(row: np.ndarray) -> tuple[coal.Capsule, coal.Transform3s]:
    axis = row[3:6] - row[0:3]
    length = float(np.linalg.norm(axis))
    z = axis / length if length > 0 else np.array([0.0, 0.0, 1.0])
    rotation = pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), z).matrix()
    return coal.Capsule(row[6], length), coal.Transform3s(rotation, (row[0:3] + row[3:6]) / 2.0)


@pytest.mark.parametrize("kind", ["any", "parallel", "crossing"])
def test_segment_bound_is_never_above_coals_capsule_distance(kind):
    rng = np.random.default_rng(3)
    rows = _capsule_rows(rng, 4000, kind)
    rows[:, 6] = rows[:, 6] * (kind == "any")  # bare segments: coal's distance is theirs
    tight, apart = 0, 0
    for k in range(0, len(rows), 2):
        a, b = _coal_capsule(rows[k]), _coal_capsule(rows[k + 1])
        result = coal.DistanceResult()
        distance = coal.distance(a[0], a[1], b[0], b[1], coal.DistanceRequest(), result)
        bound = segment_floor(rows, k, k + 1) - rows[k, 6] - rows[k + 1, 6]
        assert bound <= distance + 1e-9
        apart += distance > 0.0
        tight += distance > 0.0 and distance - bound < 1e-6
    # And it is the distance, not merely below it (nearly parallel ones: the lines' distance).
    assert apart > 0 and tight >= {"any": 0.99, "parallel": 0.1, "crossing": 0.0}[kind] * apart


def _inside(points: np.ndarray, capsules: np.ndarray) -> np.ndarray:
    """Per point (k, 3) and capsule (m, 7: ends, radius): does the capsule hold the point?"""
    start, span = capsules[None, :, 0:3], capsules[None, :, 3:6] - capsules[None, :, 0:3]
    length = np.maximum((span**2).sum(axis=-1), 1e-300)
    t = np.clip(((points[:, None, :] - start) * span).sum(axis=-1) / length, 0.0, 1.0)
    gaps = np.linalg.norm(points[:, None, :] - start - t[..., None] * span, axis=-1)
    return gaps <= capsules[None, :, 6]


def test_mesh_pieces_hold_every_triangle(robots):
    """Each triangle of a mesh lies in the capsules of every node on a path from the root to a
    leaf (its three corners do): the kernel, finding a node clear, passes only triangles that
    node holds, and tests the leaves of the nodes it does not pass."""
    checker = CollisionChecker(robots["madar"])
    meshes = [g for g in checker.geom_model.geometryObjects if isinstance(g.geometry, coal.BVHModelBase)][:6]
    assert meshes
    for mesh in meshes:
        pieces, ends = _mesh_pieces(mesh)
        shape = mesh.geometry
        corners = np.asarray(shape.vertices())
        triangles = np.array([[t[0], t[1], t[2]] for t in (shape.tri_indices(i) for i in range(shape.num_tris))])
        placed = corners @ mesh.placement.rotation.T + mesh.placement.translation
        held = _inside(placed[triangles].reshape(-1, 3), pieces).reshape(len(triangles), 3, -1).all(axis=1)
        assert ends[0] == len(pieces) and (ends > np.arange(len(pieces))).all()
        reached = np.zeros_like(held)  # held by the node and every node above it
        reached[:, 0] = held[:, 0]
        for node in np.flatnonzero(ends > np.arange(1, len(pieces) + 1)):
            first, second = node + 1, ends[node + 1]  # its children: the next node, and the one after its subtree
            assert ends[second] == ends[node]
            for child in (first, second):
                reached[:, child] = reached[:, node] & held[:, child]
        leaves = np.flatnonzero(ends == np.arange(1, len(pieces) + 1))
        assert reached[:, leaves].any(axis=1).all()
        assert len(leaves) >= len(triangles) / _LEAF


def _mesh_pairs(checker) -> list[int]:
    """The broad phase's active pairs (ids) of which a geometry is a mesh."""
    objects, active = checker.geom_model.geometryObjects, checker.geom_data.activeCollisionPairs
    return [
        k
        for k, p in enumerate(checker.geom_model.collisionPairs)
        if active[k] and any(isinstance(objects[g].geometry, coal.BVHModelBase) for g in (p.first, p.second))
    ]


def _pair_touches(checker, q: np.ndarray, ids: list[int]) -> np.ndarray:
    """Per pair of `ids`: does coal find it collide at `q` (placed as the broad phase places it)?"""
    pin.updateGeometryPlacements(checker.robot.model, checker.robot.data, checker.geom_model, checker.geom_data, q)
    return np.array([pin.computeCollision(checker.geom_model, checker.geom_data, int(k)) for k in ids])


def _near_contact(checker, ids: list[int], seed: int, count: int) -> tuple[np.ndarray, np.ndarray]:
    """States (n, nq) where a mesh pair is at the edge of contact, and which pair: a random
    state where it touches and one where it does not, bisected along the segment between them to
    2^-22 of it, then the states at the edge and 1e-4 to 1e-2 of the segment either side."""
    rng = np.random.default_rng(seed)
    states = _random_states(checker.robot, 3000, seed)
    touches = np.array([_pair_touches(checker, q, ids) for q in states])
    out, which = [], []
    for k in np.flatnonzero(touches.any(axis=0) & ~touches.all(axis=0)):
        inside, outside = np.flatnonzero(touches[:, k]), np.flatnonzero(~touches[:, k])
        for _ in range(count):
            a, b = states[rng.choice(inside)], states[rng.choice(outside)]
            low, high = 0.0, 1.0  # touching at low, apart at high
            for _ in range(22):
                middle = (low + high) / 2.0
                inside_now = _pair_touches(checker, a + middle * (b - a), [ids[k]])[0]
                low, high = (middle, high) if inside_now else (low, middle)
            for step in (0.0, 1e-4, -1e-4, 1e-3, -1e-3, 1e-2, -1e-2):
                out.append(a + (high + step) * (b - a))
                which.append(ids[k])
    return np.array(out), np.array(which)


@pytest.mark.parametrize("name", ["ur5", "madar"])
def test_mesh_pairs_cleared_near_contact_are_apart_for_coal(robots, name, kernels):
    """At states where a mesh pair is at the edge of contact, on either side of it and up to a
    few centimetres away, a pair the certifier does not leave to coal is one coal finds apart;
    both sides occur, and the pieces' tree clears such pairs under 2 cm apart."""
    robot = robots[name]
    checker = CollisionChecker(robot)
    checker.in_collision(_random_states(robot, 1, 12)[0])
    ids = _mesh_pairs(checker)
    states, which = _near_contact(checker, ids, 12, 40)
    certifier = checker._free_certifier()
    touching, near_cleared = 0, 0
    for q, k in zip(states, which):
        touches = _pair_touches(checker, q, [k])[0]
        touching += touches
        verdict = certifier.verdict(q)
        if verdict is None or k in verdict[1]:
            continue  # left to coal (or too many pairs left: the broad phase decides)
        assert not touches
        near_cleared += pin.computeDistance(checker.geom_model, checker.geom_data, int(k)).min_distance < 0.02
    assert touching > 0.2 * len(states) and near_cleared >= 10


def test_ur5_links_near_a_box_are_left_to_coal_only_within_the_tolerance(robots, kernels):
    """The UR5 around a block on a table (benchmarks' scenario a): at states where a link's
    capsule is at the edge of contact with a box, on either side of it and up to centimetres
    away, the verdict proves the pair touching only where coal finds it collide, clears it only
    where coal finds it apart, and leaves it to coal only within the tolerance of contact."""
    robot = robots["ur5"]
    scene = Scene(
        obstacles=[
            Obstacle(name="table", shape=Box(size=(0.6, 1.2, 0.04)), pose=Pose(xyz=(0.5, 0.0, -0.07))),
            Obstacle(name="block", shape=Box(size=(0.3, 0.08, 0.35)), pose=Pose(xyz=(0.45, 0.0, 0.125))),
        ]
    )
    checker = CollisionChecker(robot, scene)
    checker.in_collision(_random_states(robot, 1, 14)[0])
    objects, active = checker.geom_model.geometryObjects, checker.geom_data.activeCollisionPairs
    ids = [
        k
        for k, p in enumerate(checker.geom_model.collisionPairs)
        if active[k] and {type(objects[p.first].geometry), type(objects[p.second].geometry)} == {coal.Capsule, coal.Box}
    ]
    states, which = _near_contact(checker, ids, 14, 30)
    certifier = checker._free_certifier()
    outcomes = {"touching": 0, "apart": 0, "left": 0}
    for q, k in zip(states, which):
        touches = _pair_touches(checker, q, [k])[0]
        distance = pin.computeDistance(checker.geom_model, checker.geom_data, int(k)).min_distance
        verdict = certifier.verdict(q)
        if verdict_one(q, *certifier.packed) == TOUCHING:
            kernel_switch.use_kernels(False)
            assert checker.in_collision(q)
            kernel_switch.use_kernels(True)
            outcomes["touching"] += touches
        elif verdict is not None and k not in verdict[1]:
            assert not touches
            outcomes["apart"] += 1
        elif verdict is not None:
            assert abs(distance) < 1e-4 + 1e-7
            outcomes["left"] += 1
    assert min(outcomes.values()) > 50  # most states touch elsewhere too (proven there, or many pairs left)


def test_a_mesh_against_larger_and_smaller_shapes_is_cleared_only_where_coal_keeps_them_apart(robots, kernels):
    """MADAR's forearm and wrist 3 meshes each paired with a box, a capsule and a ball standing
    about them, larger and smaller than the mesh (the kernel walks the larger one's tree first):
    on states about the one they were placed at, a pair the certifier clears is one coal finds
    apart, and both answers occur."""
    robot = robots["madar"]
    objects = CollisionChecker(robot).geom_model.geometryObjects
    meshes = [o for o in objects if o.name in ("right_fore_arm_link (mesh)", "right_wrist_3_link (mesh)")]
    assert len(meshes) == 2
    rng = np.random.default_rng(14)
    model, data = robot.model, robot.data
    q0 = _random_states(robot, 1, 14)[0]
    pin.forwardKinematics(model, data, q0)
    where = [data.oMi[mesh.parentJoint] * mesh.placement for mesh in meshes]  # the meshes at q0
    shapes = [coal.Box(0.5, 0.4, 0.6), coal.Capsule(0.03, 0.7), coal.Sphere(0.02), coal.Box(0.02, 0.03, 0.04)]
    geom_model = pin.GeometryModel()
    for k, shape in enumerate(shapes * 3):  # the meshes between the shapes: pairs come in both orders
        near = where[k % 2].translation + rng.uniform(-0.15, 0.15, 3)
        turned = pin.SE3(pin.Quaternion(*rng.normal(size=4)).normalized().matrix(), near)
        geom_model.addGeometryObject(pin.GeometryObject(f"shape {k}", 0, turned, shape))
        if k in (3, 7):
            geom_model.addGeometryObject(meshes[k // 4].copy())
    is_mesh = np.array([o.name.endswith("(mesh)") for o in geom_model.geometryObjects])
    pairs = np.array([(m, s) for m in np.flatnonzero(is_mesh) for s in np.flatnonzero(~is_mesh)])
    for m, s in pairs:
        geom_model.addCollisionPair(pin.CollisionPair(int(m), int(s)))
    geom_data = pin.GeometryData(geom_model)
    certifier = FreeCertifier.of(model, geom_model, pairs, [])
    states = q0 + rng.normal(scale=0.3, size=(1500, model.nq))
    cleared, touched = 0, 0
    for q in states:
        verdict = certifier.verdict(q)
        pin.updateGeometryPlacements(model, data, geom_model, geom_data, q)
        for k in range(len(pairs)):
            touches = pin.computeCollision(geom_model, geom_data, k)
            touched += touches
            if verdict is not None and k not in verdict[1]:
                assert not touches
                cleared += 1
    assert cleared > 0.2 * len(states) * len(pairs) and touched > 0.02 * len(states) * len(pairs)


def test_pieces_are_found_again_only_for_their_own_mesh_and_placement(robots, monkeypatch):
    """Pieces are kept by the mesh and its placement themselves: with every digest alike (hash
    made constant), each mesh, and one mesh placed elsewhere, still gets the pieces made for it."""
    monkeypatch.setattr(free_certifier, "_PIECES", {})
    monkeypatch.setattr(free_certifier, "hash", lambda _: 0, raising=False)
    checker = CollisionChecker(robots["ur5"])
    meshes = [g for g in checker.geom_model.geometryObjects if isinstance(g.geometry, coal.BVHModelBase)][:3]
    moved = pin.GeometryObject(meshes[0])
    moved.placement = pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.5])) * meshes[0].placement
    assert len(meshes) == 3
    for _ in range(2):  # made, then found again
        for mesh in [*meshes, moved]:
            found, made = free_certifier._pieces_of(mesh), _mesh_pieces(mesh)  # (capsules, subtree ends)
            assert all(np.array_equal(a, b) for a, b in zip(found, made, strict=True))


def _capsule_and_box(rng, row: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
    """Rows (2, 23): the capsule `row` and a random box turned anywhere near it; coal's distance
    between them; the box's rotation, centre and half sides (3 + 3 + 3, 3)."""
    half = rng.uniform(0.02, 0.4, 3)
    rotation = pin.Quaternion(*rng.normal(size=4)).normalized().matrix()
    centre = rng.uniform(-0.3, 0.3, 3)
    placed = np.zeros((2, 23))
    placed[0] = row
    placed[1, 7:16], placed[1, 16:19], placed[1, 19:22] = rotation.reshape(9), centre, half
    shape, where = _coal_capsule(row)
    result = coal.DistanceResult()
    distance = coal.distance(
        shape, where, coal.Box(*(2 * half)), coal.Transform3s(rotation, centre), coal.DistanceRequest(), result
    )
    return placed, distance, np.vstack([rotation, centre, half])


def test_capsule_clear_of_a_box_only_where_coal_keeps_them_apart():
    rng = np.random.default_rng(4)
    capsules = _capsule_rows(rng, 3000)
    cleared = 0
    for row in capsules:
        placed, distance, _ = _capsule_and_box(rng, row)
        clear = capsule_clears_box(placed, 0, 1, 1e-4)
        assert not clear or distance > 1e-4
        cleared += clear
        if distance > 0.05:  # far enough for the finest pieces (1/64 of the segment) to see it
            assert clear
    assert cleared > 0.3 * len(capsules)


def test_a_capsule_is_proven_in_a_box_exactly_where_coal_finds_it_deeper_than_the_depth():
    """Proven where coal's signed distance is below -depth, not where it is above (1e-7 of
    rounding and search apart): each proof is a contact coal finds, and a capsule reaching into a
    box is proven wherever it reaches deeper than the depth."""
    rng = np.random.default_rng(11)
    proven = 0
    for row in _capsule_rows(rng, 4000):
        placed, distance, _ = _capsule_and_box(rng, row)
        touches = capsule_in_box(placed, 0, 1, 1e-4)
        if abs(distance + 1e-4) > 1e-7:
            assert touches == (distance < -1e-4), distance
        proven += touches
    assert 0.1 < proven / 4000 < 0.9


def test_only_a_capsule_or_sphere_and_a_box_are_decided_exactly():
    """A cylinder is held by its row's capsule and a mesh or cone by its row's box, so neither
    is decided there; a capsule and a sphere are, against a box, whichever row comes first:
    touching where they reach more than the tolerance into it, apart where more than it away."""
    rows = {
        kind: _geometry_row(pin.GeometryObject(kind, 0, pin.SE3.Identity(), shape))
        for kind, shape in {
            "box": coal.Box(0.2, 0.2, 0.2),
            "capsule": coal.Capsule(0.05, 0.2),
            "sphere": coal.Sphere(0.05),
            "cylinder": coal.Cylinder(0.05, 0.2),
            "cone": coal.Cone(0.05, 0.2),
        }.items()
    }

    def decided(kind: str, z: float, other: str = "box") -> int:
        """`kind` along z, its centre at z, against `other` at the origin (both ways round)."""
        placed = np.array([rows[kind], rows[other]])
        placed[0, [2, 5, 18]] += z
        answers = {exact_verdict(placed, placed, 0, 1, 1e-4), exact_verdict(placed[::-1], placed[::-1], 1, 0, 1e-4)}
        assert len(answers) == 1
        return answers.pop()

    # The capsule's end cap reaches 0.1 + 0.05 from its centre, the box's top is at 0.1.
    assert [decided("capsule", 0.25 + d) for d in (-2e-4, -0.5e-4, 0.5e-4, 2e-4)] == [TOUCHING, 0, 0, APART]
    assert [decided("sphere", 0.15 + d) for d in (-2e-4, -0.5e-4, 0.5e-4, 2e-4)] == [TOUCHING, 0, 0, APART]
    # The cylinder's flat end is at 0.1 from its centre: its capsule reaches 0.05 beyond it.
    assert decided("cylinder", 0.22) == decided("cone", 0.15) == decided("cylinder", 0.5) == 0
    assert decided("capsule", 0.0, "capsule") == decided("box", 0.0) == 0


def _coal_shapes(rows: np.ndarray) -> tuple[coal.Capsule, coal.Transform3s, coal.Box, coal.Transform3s]:
    """Row 0's capsule and row 1's box as coal's shapes, where they stand."""
    box = coal.Box(*(2 * rows[1, 19:22]))
    return *_coal_capsule(rows[0]), box, coal.Transform3s(rows[1, 7:16].reshape(3, 3), rows[1, 16:19])


def _near_capsule_and_box(rng, row: np.ndarray) -> tuple[np.ndarray, float]:
    """Rows (2, ROW): the capsule `row` (exact) and a random exact box, the capsule moved along
    coal's normal to a distance of +-1e-7 to 3e-2 m (a quarter of them inside); and coal's
    distance then."""
    near = np.zeros((2, ROW))
    near[:, :23] = _capsule_and_box(rng, row)[0]
    near[0, EXACT], near[1, EXACT] = EXACT_CAPSULE, EXACT_BOX
    result = coal.DistanceResult()
    distance = coal.distance(*_coal_shapes(near), coal.DistanceRequest(), result)
    target = 10.0 ** rng.uniform(-7, -1.5) * (1.0 if rng.uniform() < 0.75 else -1.0)
    near[0, 0:6] -= np.tile((target - distance) * np.asarray(result.normal), 2)  # the normal: capsule to box
    return near, coal.distance(*_coal_shapes(near), coal.DistanceRequest(), coal.DistanceResult())


def _wrong_decisions(floor) -> tuple[int, int, int]:
    """Over 4000 random capsules near random boxes (`_near_capsule_and_box`): how many `floor`
    (rows, a, b: `capsule_box_floor` or a broken one) bounds above coal's distance (0 for those
    that meet), how many of
    those it would call apart coal finds colliding (as the checker asks it: with its contact),
    and how many more than 1e-4 apart it does not call apart."""
    rng = np.random.default_rng(13)
    above, wrongly_apart, undecided = 0, 0, 0
    request = coal.CollisionRequest()
    request.enable_contact = True
    for row in _capsule_rows(rng, 4000):
        near, distance = _near_capsule_and_box(rng, row)
        bound = floor(near, 0, 1)
        above += bound > max(distance, 0.0) + 1e-9
        if bound > 1e-4:
            wrongly_apart += coal.collide(*_coal_shapes(near), request, coal.CollisionResult()) > 0
        undecided += distance > 1e-4 + 1e-9 and bound <= 1e-4
    return above, wrongly_apart, undecided


def test_a_capsule_is_called_apart_from_a_box_only_where_coal_keeps_them_apart():
    """Near contact (from 1e-7 m to 3 cm, either side), the capsule-box bound is never above
    coal's distance and is it, to rounding: every pair more than the tolerance apart is called
    apart, none coal finds colliding; and its verdict is the bound's and the proof's. A sign
    error in the bound (the radius added) calls colliding pairs apart."""
    assert _wrong_decisions(capsule_box_floor) == (0, 0, 0)
    rng = np.random.default_rng(17)
    verdicts = []
    for row in _capsule_rows(rng, 2000):
        near, distance = _near_capsule_and_box(rng, row)
        verdict = exact_verdict(near, near, 0, 1, 1e-4)
        assert verdict != APART or distance > 1e-4
        assert verdict != TOUCHING or distance < -1e-4
        if abs(abs(distance) - 1e-4) > 1e-9:
            assert (verdict == APART) == (distance > 1e-4) and (verdict == TOUCHING) == (distance < -1e-4)
        verdicts.append(verdict)
    assert {APART, TOUCHING, 0} == set(verdicts)

    def radius_added(rows: np.ndarray, a: int, b: int) -> float:
        flipped = rows.copy()
        flipped[a, 6] = -flipped[a, 6]
        return capsule_box_floor(flipped, a, b)

    above, wrongly_apart, _ = _wrong_decisions(radius_added)
    assert above > 1000 and wrongly_apart > 100


def test_capsule_beyond_a_face_only_where_a_plane_and_coal_keep_them_apart():
    """Clear exactly where both ends of the segment lie past one face's plane by more than the
    radius (here in the box's frame, by numpy), and coal finds them apart there."""
    rng = np.random.default_rng(7)
    beyond = 0
    for row in _capsule_rows(rng, 3000):
        placed, distance, box = _capsule_and_box(rng, row)
        ends = (np.array([row[0:3], row[3:6]]) - box[3]) @ box[:3]  # (2, 3) in the box's frame
        reach = box[4] + row[6] + 1e-4
        expected = bool(((ends > reach).all(axis=0) | (ends < -reach).all(axis=0)).any())
        assert capsule_beyond_face(placed, 0, 1, 1e-4) == expected
        assert not expected or distance > 1e-4
        beyond += expected
    assert 0.2 < beyond / 3000 < 0.9


def test_tables_are_asked_as_clearance_table_asks_them(robots):
    """The kernel's cell arithmetic is `ClearanceTable.certified`'s: at random states and on
    every grid's lower and upper limits exactly, beyond them and whole turns away."""
    robot = robots["madar"]
    checker = CollisionChecker(robot)
    tables = [table for table, _ in checker._tabled] if checker.geom_model else []
    assert len(tables) >= 2
    certifier = FreeCertifier.of(robot.model, checker.geom_model, np.zeros((0, 2), dtype=int), tables)
    qs = _random_states(robot, 4000, 2)
    for k, table in enumerate(tables):
        for a, (i, lower, step, n) in enumerate(zip(table.q_index, table.lower, table.step, table.cells)):
            edges = [lower, lower + step * n, lower - 1e-9, lower + step * n + 1e-9, lower + 2 * np.pi, lower + step]
            rows = slice(100 * (2 * k + a), 100 * (2 * k + a) + 100)
            qs[rows, i] = np.resize(edges, 100)
    # Sub-cells' edges, exactly and a hair either side, in cells not certified whole.
    rng = np.random.default_rng(3)
    for k, table in enumerate(tables):
        cells = np.argwhere(~table.free.reshape(table.cells))
        for n, row in enumerate(range(1200 + 400 * k, 1600 + 400 * k)):
            cell, sub = cells[rng.integers(len(cells))], rng.integers(0, FINE, len(table.cells))
            for a, (i, lower, step) in enumerate(zip(table.q_index, table.lower, table.step)):
                qs[row, i] = lower + (cell[a] + (sub[a] + rng.uniform(0.05, 0.95)) / FINE) * step
            i, lower, step = table.q_index[n % 2], table.lower[n % 2], table.step[n % 2]
            qs[row, i] = lower + (cell[n % 2] + sub[n % 2] / FINE) * step + (-1e-12, 0.0, 1e-12)[n % 3]
    expected = [sum((not table.certified(q.tolist())) << k for k, table in enumerate(tables)) for q in qs]
    assert [tables for tables, _ in certifier.verdicts(qs)] == expected  # no pairs: never None
    assert 0.1 < np.mean(np.array(expected) == 0) < 0.9
    # Sub-cells certify states in cells not certified whole, and not all of them.
    for k, table in enumerate(tables):
        rows = qs[1200 + 400 * k : 1600 + 400 * k]
        index = np.floor((rows[:, table.q_index] - table.lower) / table.step).astype(int) % np.array(table.cells)
        flat = np.ravel_multi_index(tuple(index.T), table.cells)
        certified = table.certified_many(rows)[~table.free[flat]]  # a hair below a cell's edge: the cell before
        assert len(certified) > 300 and 0.05 < certified.mean() < 0.95


def _in_scene(robot, name: str, first: np.ndarray) -> tuple[CollisionChecker, FreeCertifier]:
    """A checker of `robot` in the test scene `_scene` and its certifier, made by asking about
    the state `first`."""
    checker = CollisionChecker(robot, _scene(robot, name))
    checker.in_collision(first)
    return checker, checker._free_certifier()


def _scene(robot, name: str) -> Scene:
    """Boxes, a cylinder, a cone, a ball and two people about the robot's reach."""
    near = {"ur5": (0.45, 0.0), "madar": (0.0, 1.0), "baxter": (0.8, 0.0)}[name]
    x, y = near
    return Scene(
        obstacles=[
            Obstacle(name="table", shape=Box(size=(0.6, 0.8, 0.05)), pose=Pose(xyz=(x, y, 0.35))),
            Obstacle(name="crate", shape=Box(size=(0.2, 0.3, 0.25)), pose=Pose(xyz=(-x, -y, 0.6), rpy=(0, 0, 0.6))),
            Obstacle(name="post", shape=Cylinder(radius=0.05, height=0.6), pose=Pose(xyz=(y, x, 0.9))),
            Obstacle(name="funnel", shape=Cone(radius=0.08, height=0.2), pose=Pose(xyz=(-y, x, 1.1))),
            Obstacle(name="ball", shape=Sphere(radius=0.07), pose=Pose(xyz=(x * 0.7, y * 0.7 + 0.3, 1.0))),
        ],
        humans=[
            HumanSpec(name="bob", position=(x * 1.6, y * 1.6), yaw=np.pi),
            HumanSpec(name="kim", position=(-y * 1.5 - 0.2, x * 1.5), yaw=0.0, margin=0.05),
        ],
    )


# The share of random states certified at least: Baxter's torso mesh lies within a centimetre of
# its shoulders' meshes in every state, which spheres about its triangles cannot tell apart.
@pytest.mark.parametrize(("name", "share"), [("ur5", 0.05), ("madar", 0.03), ("baxter", 0.0)])
def test_certified_states_are_free_for_coal_and_answers_are_the_same(robots, name, share, kernels):
    robot = robots[name]
    states = _random_states(robot, STATES, 5)
    checker, certifier = _in_scene(robot, name, states[0])
    certified = certifier.free_many(states)
    kernel_switch.use_kernels(False)
    collides = np.array([checker.in_collision(q) for q in states])
    first = checker.first_collision(states[~certified][:50])
    kernel_switch.use_kernels(True)
    assert not (certified & collides).any()
    assert certified.mean() >= share and collides.mean() > 0.05  # both sides are exercised
    verdicts = certifier.verdicts(states)
    # Some pairs or a table's meshes left to coal one by one (the rest clear): both answers occur.
    tabled = np.array([k for k, v in enumerate(verdicts) if v is not None and v != (0, ())][:1000], dtype=int)
    if name != "baxter":
        assert collides[tabled].any() and not collides[tabled].all()
    asked = np.concatenate([np.arange(2000), tabled])
    assert [checker.in_collision(q) for q in states[asked]] == collides[asked].tolist()
    assert [certifier.verdict(q) for q in states[:500]] == certifier.verdicts(states[:500])
    assert checker.first_collision(states[~certified][:50]) == first
    # A state where a pair is proven to touch collides for coal; the robots' capsules reach
    # into the boxes in some (Baxter's links are meshes: none is proven).
    codes = verdict_codes(states, *certifier.packed, np.empty((len(states), ASKED_OF_COAL + 1), dtype=np.int64))
    proven = codes == TOUCHING
    assert collides[proven].all()
    assert proven.mean() > (0.0 if name == "baxter" else 0.01)


def test_moved_people_and_obstacles_are_where_the_certifier_looks(robots, kernels):
    """A person re-posed onto the arm, then an obstacle moved onto it: no longer certified."""
    robot = robots["ur5"]
    checker = CollisionChecker(robot, _scene(robot, "ur5"))
    states = _random_states(robot, 200, 6)
    checker.in_collision(states[0])
    q = states[np.argmax(checker._free_certifier().free_many(states))]
    assert not checker.in_collision(q) and checker._free_certifier().verdict(q) == (0, ())
    pin.framesForwardKinematics(robot.model, robot.data, q)
    tool = robot.data.oMf[robot.frame_id(robot.tool_frame(next(iter(robot.arms))))].translation
    checker.pose_human(HumanSpec(name="bob", position=(tool[0], tool[1]), yaw=np.pi))
    assert checker.in_collision(q) and not checker._free_certifier().verdict(q) == (0, ())
    checker.pose_human(HumanSpec(name="bob", position=(3.0, 3.0), yaw=np.pi))
    assert not checker.in_collision(q)
    checker.move_obstacle("ball", Pose(xyz=tuple(tool)))
    assert checker.in_collision(q) and not checker._free_certifier().verdict(q) == (0, ())


def test_a_certifier_placed_anew_answers_as_one_made_there(robots, kernels):
    """A person re-posed and an obstacle moved: the certifier placed anew holds what packing
    it afresh would (its int array was not packed again), and answers as a certifier made in
    the moved scene does."""
    robot = robots["ur5"]
    states = _random_states(robot, 500, 7)
    checker, certifier = _in_scene(robot, "ur5", states[0])
    before = certifier.verdicts(states)
    checker.pose_human(HumanSpec(name="bob", position=(0.5, 0.2), yaw=np.pi))
    checker.move_obstacle("ball", Pose(xyz=(0.3, 0.1, 0.5)))
    assert checker._free_certifier() is certifier
    floats, ints = copy.deepcopy(certifier)._packed()
    scratch = certifier.kernel_written  # the mesh pairs' witnesses and the ids of the pairs left
    assert np.array_equal(certifier._floats, floats, equal_nan=True)
    assert np.array_equal(certifier._ints[:-scratch], ints[:-scratch])
    made = CollisionChecker(robot, checker.scene)
    made.in_collision(states[0])
    after = certifier.verdicts(states)
    assert after == made._free_certifier().verdicts(states) and after != before


def test_every_move_leaves_the_certifier_as_one_made_where_things_stand(robots, kernels):
    """However the checker moves what is on no joint (a person re-posed, with separation zones
    grown from their capsules; an obstacle moved; a new scene; a remembered build used again,
    placed anew), the placements it keeps for its certifier are its collision model's, and the
    certifier holds, to the bit, the rows of one made in that scene, and answers as it does."""
    robot = robots["ur5"]
    scene = _scene(robot, "ur5")
    zones = SeparationZones(
        {"bob": {"right_hand": 0.2, "middle_thorax": 0.1}}, frozenset(range(1, robot.model.njoints))
    )
    checker, states = CollisionChecker(robot), _random_states(robot, 300, 13)
    bob = scene.humans[0]
    at = lambda x, y: bob.model_copy(update={"position": (x, y)})  # noqa: E731
    keep_out = Obstacle(name="keep-out:bob", shape=Cylinder(radius=0.3, height=1.8), pose=Pose(xyz=(0.5, 0.3, 0.9)))
    moves = [
        lambda: checker.set_world(scene, zones),
        lambda: checker.pose_human(at(0.5, 0.2)),
        lambda: checker.move_obstacle("ball", Pose(xyz=(0.3, 0.1, 0.5))),
        lambda: checker.set_world(scene.model_copy(update={"obstacles": [*scene.obstacles, keep_out]}), zones),
        lambda: checker.set_world(scene.model_copy(update={"humans": [at(0.4, -0.3), scene.humans[1]]}), zones),
        lambda: checker.set_scene(scene.model_copy(update={"humans": [at(0.6, 0.1), scene.humans[1]]})),
        lambda: checker.set_world(scene.model_copy(update={"humans": [at(0.45, 0.3), scene.humans[1]]}), zones),
    ]
    for move in moves:
        move()
        checker.in_collision(states[0])
        certifier, objects = checker._free_certifier(), checker.geom_model.geometryObjects
        statics = [k for k, g in enumerate(objects) if g.parentJoint == 0]
        assert np.array_equal(checker._where[statics], np.array([objects[k].placement.homogeneous for k in statics]))
        made = CollisionChecker(robot)
        made.set_world(checker.scene, checker.zones)
        made.in_collision(states[0])
        assert np.array_equal(certifier._rows, made._free_certifier()._rows)
        assert certifier.verdicts(states) == made._free_certifier().verdicts(states)


def _off_centre_mesh() -> coal.BVHModelOBBRSS:
    """A mesh whose box is off its frame's origin along every axis (its points' every coordinate counts)."""
    mesh = coal.BVHModelOBBRSS()
    corners = np.array([[x, y, z] for x in (0.1, 0.3) for y in (-0.2, 0.05) for z in (0.4, 0.45)])
    mesh.beginModel(4, 8)
    for a, b, c in ((0, 1, 2), (1, 2, 3), (4, 5, 6), (5, 6, 7)):
        mesh.addTriangle(corners[a], corners[b], corners[c])
    mesh.endModel()
    return mesh


def test_static_rows_are_geometry_rows_to_the_bit():
    """Rows of geometries on no joint made in one pass (`_static_rows`, from a row made anywhere)
    are `_geometry_row`'s where they stand, to the bit, for every kind of shape and placement."""
    rng = np.random.default_rng(3)
    shapes = [coal.Capsule(0.1, 0.4), coal.Cylinder(0.1, 0.4), coal.Sphere(0.1), coal.Box(0.1, 0.2, 0.3)]
    shapes += [coal.Cone(0.1, 0.3), _off_centre_mesh()]
    for shape in shapes:
        anywhere = _geometry_row(pin.GeometryObject("g", 0, pin.SE3.Random(), shape))
        points = _geometry_row(pin.GeometryObject("g", 0, pin.SE3.Identity(), shape))[[0, 1, 2, 3, 4, 5, 16, 17, 18]]
        placements = [pin.SE3(pin.rpy.rpyToMatrix(*rng.uniform(-4, 4, 3)), rng.normal(0, 2, 3)) for _ in range(200)]
        placements += [pin.SE3.Identity(), pin.SE3(np.eye(3), np.array([0.0, -0.0, 1.0]))]
        where = np.array([p.homogeneous for p in placements])
        made = _static_rows(
            np.tile(anywhere, (len(where), 1)), np.tile(points.reshape(3, 3), (len(where), 1, 1)), where
        )
        expected = np.array([_geometry_row(pin.GeometryObject("g", 0, p, shape)) for p in placements])
        assert np.array_equal(made.view(np.uint64), expected.view(np.uint64))


def test_a_group_sphere_holds_its_members_and_no_other_row_moves_it():
    """`_spheres_about`: each sphere holds every member's sphere (the middle of its capsule, its
    reach), and is the sphere of its members alone, to the bit: the other rows, wherever they
    are, change nothing; a member moved far is held where it is."""
    rng = np.random.default_rng(4)
    for _ in range(50):
        rows = rng.normal(0.0, 0.3, (int(rng.integers(1, 20)), REACH + 1))
        rows[:, REACH] = rng.uniform(0.01, 0.2, len(rows))
        members = rng.uniform(size=(5, len(rows))) < 0.5
        members[:, rng.integers(len(rows))] = True
        for moved in (rows, rows + np.where(np.arange(REACH + 1) < 6, 2.0, 0.0) * (np.arange(len(rows)) == 0)[:, None]):
            spheres = _spheres_about(moved, members)
            middles = (moved[:, 0:3] + moved[:, 3:6]) / 2.0
            for sphere, flags in zip(spheres, members):
                held = np.linalg.norm(middles[flags] - sphere[0:3], axis=1) + moved[flags, REACH]
                assert np.all(held <= sphere[REACH] + 1e-12)
                alone = _spheres_about(moved[flags], np.ones((1, flags.sum()), dtype=bool))[0]
                assert np.array_equal(sphere, alone)


def _centres(certifier: FreeCertifier, model: pin.Model, q: np.ndarray) -> np.ndarray:
    """Each row's sphere centre (its capsule's middle) in the world at `q`, placed by pinocchio."""
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    middles = (certifier._rows[:, 0:3] + certifier._rows[:, 3:6]) / 2.0
    return np.array([data.oMi[int(j)].act(m) for j, m in zip(certifier._carrier, middles)])


@pytest.mark.parametrize("name", ["ur5", "madar"])
def test_node_spheres_hold_their_members_where_the_kernel_places_them(robots, name, kernels):
    """Each link's sphere (placed at every state), person's and part of a person's holds its
    members' spheres (placed here by pinocchio)."""
    robot = robots[name]
    states = _random_states(robot, 300, 8)
    checker, certifier = _in_scene(robot, name, states[0])
    rows = certifier._link_rows + certifier._group_rows + certifier._part_rows
    nodes = list(zip(rows, certifier._links + certifier._groups + certifier._parts))
    assert len(certifier._links) >= 5 and len(certifier._groups) == 2 and len(certifier._parts) == 8
    worst, reach = -np.inf, certifier._rows[:, REACH]
    for q in states:
        certifier.verdict(q)
        scratch = len(certifier._joint_rows) * 15  # the joints' frames, state and moves first
        placed = certifier._work[scratch : scratch + certifier._rows.size].reshape(certifier._rows.shape)
        centres = _centres(certifier, robot.model, q)
        for node, members in nodes:
            held = np.linalg.norm(centres[members] - placed[node, 0:3], axis=1) + reach[members]
            worst = max(worst, float(np.max(held - placed[node, REACH])))
    assert -0.01 < worst < 1e-12  # held, and not by far


def _flat(certifier: FreeCertifier) -> FreeCertifier:
    """The same certifier testing every pair alone (no node's sphere skips a run)."""
    flat = copy.copy(certifier)
    flat._pairs = certifier._pairs.copy()
    flat._pairs[:, 5:PAIR:3] = 0  # every level's run ends
    flat._floats, flat._ints = flat._packed()
    return flat


def _partly_kept_states(robot, seed: int) -> np.ndarray:
    """1000 random states, each keeping none, some, most or all of the last one's coordinates."""
    qs, rng = _random_states(robot, 1000, seed), np.random.default_rng(seed)
    for k in range(1, len(qs)):
        keep = rng.uniform(size=qs.shape[1]) < rng.choice([0.0, 0.5, 0.9, 1.0])
        qs[k, keep] = qs[k - 1, keep]
    return qs


def test_frames_kept_from_the_last_state_are_those_placed_anew(robots, kernels):
    """A joint whose coordinate and ancestors' are those of the last state keeps its frame and
    its rows: the same verdicts, frames and placed rows, to the bit, as placing all anew, over
    states that keep none, some, most or all of the last one's coordinates."""
    robot = robots["madar"]
    qs = _partly_kept_states(robot, 12)
    checker, certifier = _in_scene(robot, "madar", qs[0])
    anew = copy.copy(certifier)
    anew._floats, anew._ints = anew._packed()
    nj = len(certifier._joint_rows)
    frames = slice(0, nj * 12)
    placed = slice(nj * 15, nj * 15 + certifier._rows.size)  # between them: the state and which moved
    for q in qs:
        anew._work[nj * 12 : nj * 14] = np.nan  # no state placed: every joint placed anew
        assert certifier.verdict(q) == anew.verdict(q)
        assert np.array_equal(certifier._work[frames], anew._work[frames])
        assert np.array_equal(certifier._work[placed], anew._work[placed])
    assert certifier._work[nj * 12 + 1] == qs[-1, 1]  # the last state is kept


def test_a_verdict_asked_again_of_its_state_is_the_one_kept(robots, kernels):
    """`verdict_one` asked about the state the scratch was last placed at (CBiRRT's walk stops at
    a state it cannot clear, then the checker asks it) gives the verdict kept there, pairs left
    and all, reading no row (rows spoilt after it do not change it), whoever placed it: another
    `verdict_one`, or a batch (`verdicts`) that ended there. The verdicts are those of a
    certifier that keeps none."""
    robot = robots["madar"]
    qs = _random_states(robot, 300, 14)
    checker, certifier = _in_scene(robot, "madar", qs[0])
    floats, ints = certifier.packed
    anew = copy.copy(certifier)
    anew._floats, anew._ints = anew._packed()
    nj, rows = len(certifier._joint_rows), certifier._rows.size
    last, placed = certifier._work[nj * 12 : nj * 14], certifier._work[nj * 15 : nj * 15 + rows].reshape(-1, ROW)
    on_joints = certifier._carrier != 0
    told_apart = kept_free = pairs_left = 0
    for a, b in zip(qs, qs[1:]):
        anew._work[nj * 12 : nj * 14] = np.nan  # none kept: every verdict made anew
        expected = anew.verdict(b)
        assert certifier.verdict(a) == anew.verdict(a)
        assert certifier.verdict(b) == expected
        if expected == (0, ()):  # the rows on joints spoilt: placed anew, no state would be free
            placed[: len(on_joints)][on_joints] = np.nan
            assert certifier.verdict(b) == expected
            last[:] = np.nan  # every row placed anew at the next state
            kept_free += 1
        certifier.verdict(a)
        verdict_codes(b[None], floats, ints, np.empty((1, 9), dtype=np.int64))
        certifier._left[:] = -1  # the pairs left come from what the batch kept
        assert certifier.verdict(b) == expected
        told_apart += min(verdict_one(a, *anew.packed), 1) != min(verdict_one(b, *anew.packed), 1)
        pairs_left += expected is not None and len(expected[1]) > 0
    assert told_apart > 20 and kept_free > 20 and pairs_left > 20  # each way a kept verdict differs


def test_frames_placed_by_the_caller_are_taken_as_placed_here(robots, kernels):
    """`verdict_of` given frames (CBiRRT's walk: its joints placed for the margins) gives the verdict,
    frames, placed rows and kept state of `verdict_one` to the bit, over states that keep none,
    some, most or all of the last one's coordinates; tables not the certifier's are told apart."""
    robot = robots["madar"]
    checker = CollisionChecker(robot, _scene(robot, "madar"))
    qs = _partly_kept_states(robot, 13)
    checker.in_collision(qs[0])
    floats, ints = checker._free_certifier().packed
    given = floats.copy(), ints.copy()  # a scratch of its own
    rows, joint_ints = joint_tables(robot.model)
    assert same_joints(*given, rows, joint_ints)
    other = rows.copy()
    other[3, 9] += 1e-12
    assert not same_joints(*given, other, joint_ints) and not same_joints(*given, rows[:-1], joint_ints[:-1])
    rotation, origin = np.empty((len(rows), 3, 3)), np.empty((len(rows), 3))
    scratch = slice(ints[11], None)
    views = verdict_views(*given)  # views of `given`: the verdict writes its scratch there
    codes = set()
    for q in qs:
        place_joints(q, rows, joint_ints, rotation, origin)
        code = verdict_one(q, floats, ints)
        assert verdict_of(q, *given, *views, (rotation, origin)) == code
        assert floats[scratch].tobytes() == given[0][scratch].tobytes()
        codes.add(min(code, 1))
    assert {0, 1, TOUCHING} <= codes  # free, pairs left, a pair proven to touch: all taken


@pytest.mark.parametrize("name", ["ur5", "madar"])
def test_node_spheres_skip_only_pairs_clear_alone(robots, name, kernels):
    """Runs of pairs passed by their nodes' spheres leave to coal exactly the pairs that testing
    each pair alone leaves, and skip most pairs of the states near the robot."""
    robot = robots[name]
    states = _random_states(robot, STATES, 9)
    checker, certifier = _in_scene(robot, name, states[0])
    assert ((certifier._pairs[:, 5:PAIR:3] > 0).sum(axis=0) >= 5).all()  # runs at every level
    left = [None if v is None else (v[0], sorted(v[1])) for v in certifier.verdicts(states)]
    alone = [None if v is None else (v[0], sorted(v[1])) for v in _flat(certifier).verdicts(states)]
    assert left == alone
    assert 0.1 < np.mean([v is not None and v[1] != [] for v in left]) < 0.9  # pairs left to coal, or not


@pytest.mark.parametrize("name", ["ur5", "madar"])
def test_every_pair_of_a_run_lies_in_the_rows_that_pass_it(robots, name, kernels):
    """The spheres that pass a run hold its pairs: at each level, a (or a's node) and b's node or
    part hold the pair's geometries, over the whole run; and each person's parts split it."""
    robot = robots[name]
    checker = CollisionChecker(robot, _scene(robot, name))
    checker.in_collision(_random_states(robot, 1, 10)[0])
    certifier = checker._free_certifier()
    rows = certifier._link_rows + certifier._group_rows + certifier._part_rows
    members = dict(zip(rows, certifier._links + certifier._groups + certifier._parts))
    for group in certifier._groups:
        parts = [part for part in certifier._parts if set(part) <= set(group)]
        assert sorted(g for part in parts for g in part) == sorted(group) and len(parts) == 4
    pairs, runs = certifier._pairs, 0
    for k in range(len(pairs)):
        for column in range(3, PAIR, 3):
            x, y, end = pairs[k, column : column + 3]
            for a, b in pairs[k:end, :2]:
                assert a in members.get(x, [x]) and b in members.get(y, [y])
                runs += 1
    assert runs > len(pairs)


def test_a_checker_stops_asking_its_certifier_when_the_kernels_are_turned_off(robots, kernels, monkeypatch):
    """`use_kernels(False)`: the certifier a checker made is no longer asked (coal answers)."""
    checker = CollisionChecker(robots["ur5"])
    q = _random_states(robots["ur5"], 1, 11)[0]
    expected = checker.in_collision(q)
    asked, certifier = [], checker._free_certifier()
    verdict = certifier.verdict
    monkeypatch.setattr(certifier, "verdict", lambda q: asked.append(q) or verdict(q))
    kernel_switch.use_kernels(False)
    assert checker.in_collision(q) == expected and not asked
    kernel_switch.use_kernels(True)
    checker.in_collision(q)
    assert len(asked) == 1
