"""robots/contact_witness.py: a contact proven from kept triangle pairs is one coal finds.

Triangles whose edge passes through another near its edges, near its plane and clear through:
`crossing` says they intersect only where coal's meshes of them collide. And MADAR's tabled
forearm and wrist 2 meshes, walked through contact: the checker's answers with the witnesses are
coal's, and most contacts are proven without it.
"""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin
import pytest

pytest.importorskip("numba")

from hriplan.robots import kernel_switch
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.contact_witness import crossing
from hriplan.robots.model import load_robot

pytestmark = pytest.mark.usefixtures("module_robot_registry")


def _mesh(corners: np.ndarray) -> coal.BVHModelOBBRSS:
    mesh = coal.BVHModelOBBRSS()
    mesh.beginModel(1, 3)
    mesh.addTriangle(*corners)
    mesh.endModel()
    return mesh


def _coal_collides(a: np.ndarray, b: np.ndarray) -> bool:
    result = coal.CollisionResult()
    where = coal.Transform3s()
    return coal.collide(_mesh(a), where, _mesh(b), where, coal.CollisionRequest(), result) > 0


def _near_pairs(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Triangle pairs (n, 3, 3) each: an edge of the first crossing the second's plane at a point
    up to 0.1 mm either side of one of its edges, its ends 0 to 0.1 mm either side of the plane
    at most, or farther: near every boundary of a proof."""
    second = rng.uniform(-0.05, 0.05, (n, 3, 3))
    first = np.empty_like(second)
    for k, t in enumerate(second):
        normal = np.cross(t[1] - t[0], t[2] - t[0])
        normal /= np.linalg.norm(normal)
        c = rng.integers(3)
        o, d = t[c], t[(c + 1) % 3]
        inward = np.cross(normal, d - o)
        inward /= np.linalg.norm(inward)
        x = o + rng.uniform(0.1, 0.9) * (d - o) + inward * rng.choice([-1, 1]) * 10 ** rng.uniform(-7, -3.5)
        ends = [rng.choice([-1, 1]) * 10 ** rng.uniform(-7, -2) for _ in range(2)]
        first[k, 0] = x + normal * ends[0]
        first[k, 1] = x - normal * ends[1]
        first[k, 2] = first[k, 0] + rng.normal(scale=0.03, size=3)
    return first, second


def test_a_proven_crossing_is_a_collision_for_coal():
    first, second = _near_pairs(np.random.default_rng(1), 6000)
    eye, proven = np.eye(4), 0
    for a, b in zip(first, second):
        for one, other in ((a, b), (b, a)):
            if crossing(one[None], eye, other[None], eye, np.zeros((1, 2), dtype=np.int64)):
                assert _coal_collides(one, other)
                proven += 1
    assert proven > 0.1 * len(first)


def test_a_crossing_is_found_through_either_placement_and_not_beyond_the_meshes():
    """The corners are placed by each mesh's own transform, and a witness of a triangle that is
    not in a mesh proves nothing."""
    rng = np.random.default_rng(2)
    first, second = _near_pairs(rng, 2000)
    pairs = np.zeros((1, 2), dtype=np.int64)
    found = [crossing(a[None], np.eye(4), b[None], np.eye(4), pairs) for a, b in zip(first, second)]
    assert 0.1 < np.mean(found) < 0.9
    for a, b, was in zip(first[:300], second[:300], found):
        rotation, shift = pin.Quaternion(*rng.normal(size=4)).normalized().matrix(), rng.normal(size=3)
        moved = np.eye(4)
        moved[:3, :3], moved[:3, 3] = rotation, shift
        local_a, local_b = (a - shift) @ rotation, (b - shift) @ rotation  # R^T (p - t), row by row
        assert crossing(local_a[None], moved, local_b[None], moved, pairs) == was
    assert not crossing(first[:1], np.eye(4), second[:1], np.eye(4), np.array([[1, 0], [0, -1]], dtype=np.int64))


def test_mesh_contacts_walked_through_are_coals_and_mostly_proven(monkeypatch):
    """MADAR's right forearm and wrist 2 meshes (a clearance table's pair), at states along
    segments through their contact (wrists 1 and 2 turning, the table's joints, as a planner's
    walk steps): the checker with the kernels on (witnesses kept) answers as coal alone, and
    proves most contacts from the kept triangles."""
    robot = load_robot("madar")
    checker = CollisionChecker(robot)
    model, gm, data = robot.model, checker.geom_model, checker.geom_data
    names = [(gm.geometryObjects[p.first].name, gm.geometryObjects[p.second].name) for p in gm.collisionPairs]
    pair = names.index(("right_fore_arm_link (mesh)", "right_wrist_2_link (mesh)"))
    wrists = [model.idx_qs[model.getJointId(f"right_wrist_{k}_joint")] for k in (1, 2)]
    rng = np.random.default_rng(3)
    states: list[np.ndarray] = []
    while len(states) < 40 * 60:
        q = rng.uniform(model.lowerPositionLimit, model.upperPositionLimit)
        pin.updateGeometryPlacements(model, robot.data, gm, data, q)
        if not pin.computeCollision(gm, data, pair):
            continue
        step = np.zeros(model.nq)
        step[wrists] = rng.normal(size=2)
        step *= 0.01 / np.linalg.norm(step)
        states += [q + k * step for k in range(-30, 30)]
    truth = []
    for q in states:
        pin.updateGeometryPlacements(model, robot.data, gm, data, q)
        truth.append(pin.computeCollision(gm, data, pair))
    proofs = []
    kernel_switch.use_kernels(True)
    try:
        for q, touches in zip(states, truth):
            pin.updateGeometryPlacements(model, robot.data, gm, data, q)
            proofs.append(checker._witnesses is not None and checker._witnesses.proven(gm, data, pair))
            assert checker._meshes_touch([pair]) == touches
    finally:
        kernel_switch.use_kernels(False)
    truth, proofs = np.array(truth), np.array(proofs)
    assert not (proofs & ~truth).any()
    assert 0.2 < truth.mean() < 0.9 and proofs.sum() > 0.5 * truth.sum()
