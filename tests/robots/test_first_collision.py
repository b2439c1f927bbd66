"""A path's first colliding state (`CollisionChecker.first_collision`, dense validation's check)
is the first state `in_collision` calls colliding, the clearance tables asked for every state at
once (`ClearanceTable.certified_many`, the same cells as `certified`)."""

import numpy as np
import pytest

from hriplan.robots import kernel_switch
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.human import HumanSpec
from hriplan.robots.mesh_clearance import ClearanceTable
from hriplan.robots.scene import AttachedObject, Cylinder, Scene, table
from madar_states import CLEAR


@pytest.fixture(scope="module")
def checker(madar):
    can = AttachedObject(name="can", shape=Cylinder(radius=0.033, height=0.12), arm="right")
    scene = Scene(
        obstacles=[table(position=(0.5, 0.8), size=(0.5, 0.5, 0.04), top=0.72)],
        humans=[HumanSpec(name="bob", position=(0.0, 1.2), yaw=-np.pi / 2, margin=0.05)],
        attached=[can],
    )
    return CollisionChecker(madar, scene)


def _states(madar, rng, count: int) -> np.ndarray:
    low, high = madar.model.lowerPositionLimit, madar.model.upperPositionLimit
    return rng.uniform(np.maximum(low, -4.0), np.minimum(high, 4.0), (count, madar.model.nq))


def _upper_edge(lower: float, step: float, cells: int) -> float:
    """A joint value whose offset from `lower` is exactly `step * cells` and falls in cell
    `cells` (the grid's upper limit itself, which `certified` puts in the last cell)."""
    q = lower + step * cells
    for _ in range(64):
        if q - lower == step * cells and np.floor((q - lower) / step) == cells:
            return q
        q = np.nextafter(q, np.inf if q - lower < step * cells else -np.inf)
    return lower + step * cells


def test_tables_certify_the_same_cells_at_once(madar, checker, rng):
    """At random states, on the grid's edges (lower limit, upper limit exactly, beyond either,
    whole turns) and on cell boundaries."""
    qs = _states(madar, rng, 3000)
    assert checker.geom_model.ngeoms  # built
    assert checker._tabled
    for clearance, _ in checker._tabled:
        edges = np.repeat(qs[:40], 8, axis=0)
        axes = zip(clearance.q_index, clearance.lower, clearance.step, clearance.cells)
        for k, (i, lower, step, n) in enumerate(axes):
            top = _upper_edge(lower, step, n)
            at = [lower, top, lower - 1e-9, top + 1e-9, lower + 3 * step, lower + 2 * np.pi, lower - 2 * np.pi, top]
            edges[k::8, i] = at[k % 8]
            edges[(k + 1) % 8 :: 8, i] = top
        asked = np.concatenate([qs, edges])
        assert np.array_equal(clearance.certified_many(asked), [clearance.certified(q.tolist()) for q in asked])
        assert 0.0 < clearance.certified_many(qs).mean() < 1.0


@pytest.mark.parametrize("periodic", [(False, False), (True, False), (False, True)])
def test_tables_of_any_kind_certify_the_same_cells_at_once(periodic, rng):
    """A grid of two joints, each wrapping or bounded, random free cells: states inside, on the
    limits exactly, beyond them and whole turns away."""
    lower, step, cells = (-1.3, 0.2), (0.05, 0.1), (52, 26)
    clearance = ClearanceTable(("a", "b"), (1, 3), lower, step, cells, periodic, rng.random(52 * 26) < 0.6)
    qs = rng.uniform(-4.0, 4.0, (4000, 5))
    for k, (low, width, n) in enumerate(zip(lower, step, cells)):
        i = (1, 3)[k]
        qs[k::5, i] = _upper_edge(low, width, n)
        qs[k + 2 :: 9, i] = low
        qs[k + 4 :: 11, i] = low + width * rng.integers(-60, 60, qs[k + 4 :: 11].shape[0])
    found = clearance.certified_many(qs)
    assert np.array_equal(found, [clearance.certified(q.tolist()) for q in qs])
    assert found.any() and not found.all()


def test_first_collision_is_the_first_state_in_collision(madar, checker, rng, either_route):
    """Chunks of random states and of paths of the right arm from CLEAR: the first colliding
    state or None, as state-by-state `in_collision` says with the kernels off (coal alone); some
    collide on a mesh pair alone, and with the kernels, some where the certifier proves a contact."""
    q0 = madar.configuration(CLEAR)
    assert checker.geom_model.ngeoms  # built
    arm = madar.group_indices("right_arm")
    random = _states(madar, rng, 2000)
    walks = np.repeat(q0[None], 2000, axis=0)
    walks[:, arm] += np.cumsum(rng.normal(0.0, 0.05, (2000, arm.size)), axis=0)
    listed = checker.geom_model.collisionPairs
    objects = checker.geom_model.geometryObjects
    tabled = {
        (objects[listed[k].first].name, objects[listed[k].second].name) for _, pairs in checker._tabled for k in pairs
    }
    meshes_only, proven = 0, 0
    for states in (random, walks):
        kernel_switch.use_kernels(False)
        colliding = [checker.in_collision(q) for q in states]
        kernel_switch.use_kernels(either_route)
        if either_route:
            proven += sum(checker._free_certifier().left_over(states)[1])
        for start in range(0, len(states), 40):
            chunk = slice(start, start + 40)
            expected = next((k for k, hit in enumerate(colliding[chunk]) if hit), None)
            assert checker.first_collision(states[chunk]) == expected
        meshes_only += sum(
            hit and {(c.a, c.b) for c in checker.contacts(q)} <= tabled for q, hit in zip(states, colliding)
        )
    assert meshes_only  # states only a table's meshes collide in were among them
    assert proven or not either_route
    assert checker.first_collision(np.zeros((0, madar.model.nq))) is None
    assert checker.first_collision(np.array([q0])) is None
    assert any(colliding) and not all(colliding)
