"""Clearance tables of mesh pairs, checked against the URDF meshes loaded independently.

A table may only say "free" where the meshes cannot touch: states drawn inside the certified
cells that border uncertified ones (where an error in the margin or the grid would show) are
checked on the URDF's own meshes, and each slab's reach is checked against how far its points
really move under forward kinematics.
"""

import functools

import coal
import numpy as np
import pinocchio as pin
import pytest

from hriplan.robots.collision import CollisionChecker
from hriplan.robots.mesh_clearance import (
    EPSILON,
    FINE,
    ClearanceTable,
    cells_with_clear_corners,
    clearance_tables,
    full_word,
    joints_between,
    slabs,
)
from hriplan.robots.model import load_robot
from hriplan.robots.robot_geometry import part_collision_shapes
from independent import UrdfMeshes


@pytest.fixture(scope="module")
def ur5():
    robot = load_robot("ur5")
    checker = CollisionChecker(robot)
    return robot, checker, clearance_tables(robot, checker.parts, checker.acm)


@pytest.fixture(scope="module")
def meshes(ur5) -> UrdfMeshes:
    """The URDF's own meshes of the UR5's tabled pairs."""
    robot, _, tables = ur5
    meshes = UrdfMeshes(robot)
    meshes.watch([f"{a}|{b}" for a, b in (t.parts for t in tables)])
    return meshes


def _cell_states(table: ClearanceTable, cells: np.ndarray, robot, rng, per_cell: int) -> np.ndarray:
    """Random states inside the given flat cells, the other joints random too."""
    index = np.array(np.unravel_index(np.repeat(cells, per_cell), table.cells)).T
    q = rng.uniform(robot.model.lowerPositionLimit, robot.model.upperPositionLimit, size=(len(index), robot.model.nq))
    for axis, i in enumerate(table.q_index):
        q[:, i] = table.lower[axis] + (index[:, axis] + rng.uniform(0, 1, len(index))) * table.step[axis]
    return q


def _bordering(table: ClearanceTable) -> np.ndarray:
    """Certified cells next to a cell that is not (wrapping where the joint turns fully)."""
    free = table.free.reshape(table.cells)
    border = np.zeros_like(free)
    for axis in range(free.ndim):
        for shift in (1, -1):
            border |= ~np.roll(free, shift, axis=axis)
    return np.flatnonzero(free & border)


def test_the_ur5_tables_are_its_two_near_mesh_pairs(ur5):
    """The two pairs 1-2 cm apart in most states get tables; the forearm and wrist 3 (three joints
    between) and the pairs mostly far apart do not. Most of each table is certified."""
    _, _, tables = ur5
    assert {t.parts for t in tables} == {("base_link", "upper_arm_link"), ("fore_arm_link", "wrist_2_link")}
    for table in tables:
        assert table.cells == (128, 128) and all(table.periodic)
        assert 0.6 < table.free.mean() < 0.97


def test_a_certified_cell_is_free_of_contact_everywhere_inside(ur5, meshes):
    robot, _, tables = ur5
    rng = np.random.default_rng(4)
    checked = 0
    for table in tables:
        pair = f"{table.parts[0]}|{table.parts[1]}"
        for q in _cell_states(table, _bordering(table), robot, rng, per_cell=8):
            assert table.certified(q)
            assert pair not in meshes.touching(q), f"{pair} touches in a certified cell at {q.round(4).tolist()}"
            checked += 1
    assert checked > 3000


def _sub_cell_states(table: ClearanceTable, rng, per_cell: int, bordering: bool) -> np.ndarray:
    """Random states inside the certified sub-cells of cells that are not certified whole (with
    `bordering`, only sub-cells next to one that is not certified, within the cell or across its
    edge); the other joints random."""
    words = table.words.reshape(table.cells)
    picked = []
    for cell in np.argwhere(~table.free.reshape(table.cells)):
        word = int(words[tuple(cell)])
        for sub in np.ndindex(*(FINE,) * len(table.cells)):
            bit = int(np.ravel_multi_index(sub, (FINE,) * len(table.cells)))
            if not word >> bit & 1:
                continue
            if bordering:
                neighbours = []
                for axis in range(len(sub)):
                    for shift in (1, -1):
                        s, c = list(sub), list(cell)
                        s[axis] += shift
                        c[axis] += s[axis] // FINE
                        s[axis] %= FINE
                        if table.periodic[axis]:
                            c[axis] %= table.cells[axis]
                        elif not 0 <= c[axis] < table.cells[axis]:
                            continue
                        other = int(words[tuple(c)])
                        neighbours.append(other >> int(np.ravel_multi_index(s, (FINE,) * len(sub))) & 1)
                if all(neighbours):
                    continue
            picked.append(np.array(cell) + np.array(sub) / FINE)
    index = np.repeat(np.array(picked).reshape(-1, len(table.cells)), per_cell, axis=0)
    q = rng.uniform(-np.pi, np.pi, size=(len(index), 6))
    for axis, i in enumerate(table.q_index):
        q[:, i] = table.lower[axis] + (index[:, axis] + rng.uniform(0, 1, len(index)) / FINE) * table.step[axis]
    return q


def test_the_cells_not_certified_whole_have_sub_cells_certified(ur5):
    """Each table's cells: a free one is certified in every sub-cell; of the others, near contact
    (the pair's meshes a few mm apart), many have some."""
    _, _, tables = ur5
    for table in tables:
        assert len(table.words) == len(table.free)
        assert (table.words[table.free] == np.uint64(full_word(2))).all()
        assert (table.words[~table.free] != 0).mean() > 0.3
        assert (table.words[~table.free] != np.uint64(full_word(2))).any()


def test_a_certified_sub_cell_is_free_of_contact_everywhere_inside(ur5, meshes):
    """States inside certified sub-cells that border one that is not, checked on the URDF's own
    meshes: where an error in the sub-cells' margin, corners or bits would show."""
    robot, _, tables = ur5
    rng = np.random.default_rng(7)
    checked = 0
    for table in tables:
        pair = f"{table.parts[0]}|{table.parts[1]}"
        states = _sub_cell_states(table, rng, per_cell=3, bordering=True)
        for q in states[rng.permutation(len(states))[:2500]]:
            assert table.certified(q)
            assert pair not in meshes.touching(q), f"{pair} touches in a certified sub-cell at {q.round(4).tolist()}"
            checked += 1
    assert checked > 3500


def _blocks_hold(table: ClearanceTable, cell: tuple[int, ...], distances) -> bool:
    """Is every certified sub-cell of `cell` in an aligned block of 1, 2 or 4 sub-cells a joint, all
    certified, at each of whose corners every slab is farther from the parent (`distances(node)`,
    a node in sub-cells from the cell's lower corner: per slab, its distance and reach) than the
    block's margin: the slab's reach times half the block's steps, plus EPSILON?"""
    word, axes = int(table.words[np.ravel_multi_index(cell, table.cells)]), len(cell)
    fine = np.array(table.step) / FINE

    def certified(origin, size) -> bool:
        bits = [
            np.ravel_multi_index(tuple(o + k for o, k in zip(origin, sub)), (FINE,) * axes)
            for sub in np.ndindex(*(size,) * axes)
        ]
        return all(word >> int(bit) & 1 for bit in bits)

    def clear(origin, size) -> bool:
        for corner in np.ndindex(*(2,) * axes):
            for distance, reach in distances(tuple(o + size * c for o, c in zip(origin, corner))):
                if distance <= float(reach @ fine) * size / 2.0 + EPSILON - 1e-7:
                    return False
        return True

    for sub in np.ndindex(*(FINE,) * axes):
        if not word >> int(np.ravel_multi_index(sub, (FINE,) * axes)) & 1:
            continue
        blocks = [(tuple(s - s % size for s in sub), size) for size in (1, 2, FINE // 2)]
        if not any(certified(origin, size) and clear(origin, size) for origin, size in blocks):
            return False
    return True


def _slab_distances(robot, table: ClearanceTable, parent, child, moving, cell, node) -> list:
    """Per slab of the child, its distance from the parent's shapes (coal's distance) and its
    reach, at a node of `cell`'s sub-cells."""
    model = robot.model
    data = model.createData()
    q = pin.neutral(model)
    for axis, i in enumerate(table.q_index):
        q[i] = table.lower[axis] + table.step[axis] * cell[axis] + table.step[axis] / FINE * node[axis]
    pin.forwardKinematics(model, data, q)
    relative = data.oMi[parent[0].parentJoint].actInv(data.oMi[child[0].parentJoint])
    out = []
    for slab in moving:
        where = relative * slab.placement
        gap = min(
            coal.distance(
                shape.geometry,
                coal.Transform3s(shape.placement.rotation, shape.placement.translation),
                slab.shape,
                coal.Transform3s(where.rotation, where.translation),
                coal.DistanceRequest(),
                coal.DistanceResult(),
            )
            for shape in parent
        )
        out.append((gap, slab.reach))
    return out


def test_each_certified_sub_cell_lies_in_a_block_clear_by_its_margin_at_its_corners(ur5):
    """The sub-cells' certificate re-derived with coal's distances (not its margin checks): in
    cells not certified whole, each certified sub-cell is in a block of 1, 2 or 4 sub-cells a
    joint, all certified, whose corners are clear by the block's margin."""
    robot, checker, tables = ur5
    model = robot.model
    parts = {p.name: p for p in checker.parts}
    rng = np.random.default_rng(8)
    for table in tables:
        parent, child = (part_collision_shapes(robot, parts[name]) for name in table.parts)
        moving = slabs(model, joints_between(model, parent[0].parentJoint, child[0].parentJoint), child)
        partial = (table.words != 0) & (table.words != np.uint64(full_word(2))) & ~table.free
        for flat in rng.choice(np.flatnonzero(partial), 25, replace=False).tolist():
            cell = tuple(int(k) for k in np.unravel_index(flat, table.cells))
            distances = functools.partial(_slab_distances, robot, table, parent, child, moving, cell)
            assert _blocks_hold(table, cell, distances), f"{table.parts} cell {cell}"


def test_in_collision_answers_as_the_meshes_do_where_a_table_cannot_certify(ur5, meshes):
    """States in uncertified cells where the tabled pair's meshes touch: still a collision, and
    `contacts` names the pair."""
    robot, checker, tables = ur5
    rng = np.random.default_rng(5)
    touching = 0
    for table in tables:
        pair = f"{table.parts[0]}|{table.parts[1]}"
        for q in _cell_states(table, np.flatnonzero(~table.free), robot, rng, per_cell=1)[:1500]:
            if pair in meshes.touching(q):
                touching += 1
                assert not table.certified(q)  # nor any of its sub-cells
                assert checker.in_collision(q)
                named = {frozenset((c.a, c.b)) for c in checker.contacts(q)}
                assert frozenset(f"{part} (mesh)" for part in table.parts) in named
    assert touching > 100


def test_a_slab_moves_no_farther_than_its_reach(ur5):
    """Forward kinematics of the child link's points, for small turns of the joints between: the
    displacement relative to the parent never exceeds sum(reach * |turn|)."""
    robot, checker, tables = ur5
    model, data = robot.model, robot.model.createData()
    parts = {p.name: p for p in checker.parts}
    rng = np.random.default_rng(6)
    for table in tables:
        parent, child = (part_collision_shapes(robot, parts[name]) for name in table.parts)
        joints = joints_between(model, parent[0].parentJoint, child[0].parentJoint)
        columns = [model.idx_qs[j] for j in joints]
        for slab in slabs(model, joints, child):
            points = np.asarray(slab.shape.vertices()) @ slab.placement.rotation.T + slab.placement.translation
            worst = 0.0
            for _ in range(150):
                q = rng.uniform(model.lowerPositionLimit, model.upperPositionLimit)
                turn = rng.uniform(-0.05, 0.05, len(joints))
                moved = q.copy()
                moved[columns] += turn
                where = []
                for state in (q, moved):
                    pin.forwardKinematics(model, data, state)
                    relative = data.oMi[parent[0].parentJoint].actInv(data.oMi[child[0].parentJoint])
                    where.append(points @ relative.rotation.T + relative.translation)
                shift = np.linalg.norm(where[1] - where[0], axis=1).max()
                assert shift <= slab.reach @ np.abs(turn) + 1e-12
                worst = max(worst, shift / (slab.reach @ np.abs(turn)))
            assert worst > 0.3  # the bound is not vacuous either


def test_an_arm_mounted_elsewhere_shares_the_ur5_table(ur5):
    """MADAR's arms are UR5s on a torso: their tables are the UR5's, computed once."""
    _, _, tables = ur5
    madar = load_robot("madar")
    checker = CollisionChecker(madar)
    theirs = {t.parts: t for t in clearance_tables(madar, checker.parts, checker.acm)}
    ours = {t.parts: t for t in tables}
    for side in ("left", "right"):
        mine = theirs[(f"{side}_base_link", f"{side}_upper_arm_link")]
        assert np.array_equal(mine.free, ours[("base_link", "upper_arm_link")].free)
        assert mine.q_index != ours[("base_link", "upper_arm_link")].q_index or side == "left"


def test_certified_reads_the_cell_a_joint_value_falls_in():
    """First joint: a full turn in 4 cells (wrapping); second: -1 .. 1 in 4 cells."""

    def table(*free_cells: int) -> ClearanceTable:
        free = np.zeros(16, bool)
        free[list(free_cells)] = True
        return ClearanceTable(("a", "b"), (0, 1), (0.0, -1.0), (np.pi / 2, 0.5), (4, 4), (True, False), free)

    one = table(3 * 4 + 2)  # turn cell 3 (3pi/2 .. 2pi), second joint 0.0 .. 0.5
    assert one.certified(np.array([-0.1, 0.2]))  # -0.1 rad is 2pi - 0.1
    assert one.certified([2 * np.pi - 0.1 + 4 * np.pi, 0.49])
    assert not one.certified([0.1, 0.2])
    assert not one.certified([-0.1, 0.51])
    last = table(3 * 4 + 3)  # the second joint's last cell, up to its upper limit
    assert last.certified([-0.1, 1.0])
    assert not last.certified([-0.1, 1.01])  # beyond the grid: not certified


def test_certified_reads_the_sub_cell_a_joint_value_falls_in():
    """One cell not certified whole (turn cell 1, second joint's cell 2), its sub-cell (3, 5)
    certified, and (FINE - 1, FINE - 1) of the second joint's last cell, up to its upper limit."""
    free = np.zeros(16, bool)
    words = np.zeros(16, np.uint64)
    words[1 * 4 + 2] = np.uint64(1 << (3 * FINE + 5))
    words[1 * 4 + 3] = np.uint64(1 << (FINE * FINE - 1))
    table = ClearanceTable(("a", "b"), (0, 1), (0.0, -1.0), (np.pi / 2, 0.5), (4, 4), (True, False), free, words)
    inside = [np.pi / 2 + (3.5 / FINE) * np.pi / 2, 0.0 + 5.5 / FINE * 0.5]
    assert table.certified(inside)
    assert table.certified([inside[0] + 4 * np.pi, inside[1]])  # whole turns away
    assert not table.certified([inside[0] + np.pi / 2 / FINE, inside[1]])  # the next sub-cell along the first joint
    assert not table.certified([inside[0], inside[1] - 0.5 / FINE])  # and along the second
    assert table.certified([np.pi - 1e-9, 1.0])  # the upper limit itself: the last sub-cell
    assert not table.certified([np.pi - 1e-9, 1.0 + 1e-9])
    qs = np.array([inside, [inside[0] + np.pi / 2 / FINE, inside[1]], [np.pi - 1e-9, 1.0], [0.3, 0.2]])
    assert table.certified_many(qs).tolist() == [True, False, True, False]


def test_a_cell_is_free_only_if_all_its_corners_are_clear():
    clear = np.ones((4, 3), bool)  # first axis wraps (4 nodes, 4 cells), second does not (3 nodes, 2 cells)
    clear[0, 2] = False
    free = cells_with_clear_corners(clear, (True, False))
    assert free.shape == (4, 2)
    # node (0, 2) is a corner of cells (0, 1) and, wrapping, (3, 1)
    assert np.array_equal(np.argwhere(~free), [[0, 1], [3, 1]])
    line = cells_with_clear_corners(np.array([True, True, False, True]), (False,))
    assert line.tolist() == [True, False, False]
