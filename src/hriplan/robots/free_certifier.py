"""A compiled certifier of "collision-free": lower bounds on every checked pair's distance.

Why: coal's broad phase costs 6-60 us a state from Python, and almost every state a planner asks
about is far from contact. Each geometry is held by a capsule (a segment and a radius) that
contains it, and an obstacle also by its box; a pair's distance is bounded below by the
segments' distance less both radii, or a capsule's distance to the other's box (the capsule cut
into pieces, each in a sphere, refined where near). A state is certified free only when every
pair the broad phase checks is bounded above `BOUND_TOLERANCE` and every clearance table of the
mesh pairs certifies it: then coal would say free too, so skipping coal changes no answer. The
pairs and tables it cannot clear are left to coal, unchanged. Forward kinematics, bounds and
tables run in one call per state (or per batch), compiled by numba and cached on disk.

The compiled code is in `certifier_kernels.py`; this module makes the arrays it reads.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import coal
import numpy as np
import pinocchio as pin

from hriplan.robots.certifier_kernels import (
    EXACT_BOX,
    EXACT_CAPSULE,
    LEVELS,
    MESH_ROW,
    MESH_SIDE,
    MESH_WITNESSES,
    PAIR,
    REACH,
    ROW,
    TOUCHING,
    WITNESSES,
    verdict_one,
    verdicts,
)
from hriplan.robots.kernel_fk import joint_tables
from hriplan.robots.mesh_arrays import made_from_mesh, mesh_arrays
from hriplan.robots.mesh_clearance import FINE, ClearanceTable
from hriplan.robots.mesh_pairs import MARGIN as MESH_MARGIN
from hriplan.robots.mesh_pairs import MeshPair
from hriplan.robots.mesh_tree_kernels import capsule_tree
from hriplan.robots.part_spheres import BOUND_TOLERANCE

TabledMeshes = tuple[MeshPair, int, int]  # a table's mesh pair: its trees, its first and second geometry

_LEAF = 64  # triangles a mesh piece holds at most
_PARTS = 4  # parts of a person, each a node of the capsules near one another
ASKED_OF_COAL = 8  # pairs a state may leave to coal one by one; more: the whole broad phase


def _held_by(geometry: coal.CollisionGeometry) -> tuple[np.ndarray, np.ndarray, float, np.ndarray, np.ndarray]:
    """A capsule (ends, radius) and a box (centre, half sides) holding `geometry`, in its own
    frame. A capsule or sphere is its own capsule (no box); a cylinder lies in the capsule of
    its radius and length; any other shape in its local bounding box, and the box in a capsule
    along its longest side (radius the half diagonal of its cross-section) or in its sphere."""
    if isinstance(geometry, coal.Capsule | coal.Cylinder):
        half = geometry.halfLength
        box = np.array([geometry.radius, geometry.radius, half]) if isinstance(geometry, coal.Cylinder) else None
        ends = np.array([[0.0, 0.0, -half], [0.0, 0.0, half]])
        return ends[0], ends[1], float(geometry.radius), np.zeros(3), box if box is not None else np.full(3, np.inf)
    if isinstance(geometry, coal.Sphere):
        return np.zeros(3), np.zeros(3), float(geometry.radius), np.zeros(3), np.full(3, np.inf)
    if isinstance(geometry, coal.Box):
        centre, half = np.zeros(3), np.asarray(geometry.halfSide, dtype=float)
    else:
        shape = geometry.clone()  # computing the box on the model's own shape would change it
        shape.computeLocalAABB()
        low, high = np.asarray(shape.aabb_local.min_, dtype=float), np.asarray(shape.aabb_local.max_, dtype=float)
        centre, half = (low + high) / 2.0, (high - low) / 2.0
    longest = int(np.argmax(half))
    across = float(np.sqrt(np.sum(np.delete(half, longest) ** 2)))
    along, sphere = half[longest], float(np.linalg.norm(half))
    if math.pi * across**2 * 2.0 * along + 4.0 / 3.0 * math.pi * across**3 < 4.0 / 3.0 * math.pi * sphere**3:
        axis = np.eye(3)[longest] * along
        return centre - axis, centre + axis, across, centre, half
    return centre, centre, sphere, centre, half


def _geometry_row(geometry: pin.GeometryObject) -> np.ndarray:
    """The row (ROW,) of a geometry: its capsule and box in its joint's frame, and which of them
    is the geometry itself (`certifier_kernels.EXACT`)."""
    start, end, radius, centre, half = _held_by(geometry.geometry)
    placement = geometry.placement
    capsule = np.concatenate([placement.act(start), placement.act(end), [radius]])
    box = np.concatenate([placement.rotation.reshape(9), placement.act(centre), half])
    return np.concatenate([capsule, box, [np.linalg.norm(end - start) / 2.0 + radius, _exact(geometry.geometry)]])


def _exact(geometry: coal.CollisionGeometry) -> float:
    """EXACT_CAPSULE for a capsule or sphere (its row's capsule is it), EXACT_BOX for a box, else 0."""
    if isinstance(geometry, coal.Capsule | coal.Sphere):
        return EXACT_CAPSULE
    return EXACT_BOX if isinstance(geometry, coal.Box) else 0.0


def _placed(points: np.ndarray, where: np.ndarray) -> np.ndarray:
    """Points (m, k, 3), each of m sets in its own frame, placed at `where` (m, 4, 4): R p + t
    added up as pinocchio's `SE3.act` adds them (x and y left to right, z right to left), so
    that a row made here is `_geometry_row`'s to the bit."""
    rotation, origin = where[:, None, :3, :3], where[:, None, :3, 3]
    terms = rotation * points[:, :, None, :]  # (m, k, axis, column)
    a, b, c = terms[..., 0], terms[..., 1], terms[..., 2]
    out = np.empty(a.shape)
    out[..., :2] = (a[..., :2] + b[..., :2]) + c[..., :2]
    out[..., 2] = a[..., 2] + (b[..., 2] + c[..., 2])
    return out + origin


def _static_rows(rows: np.ndarray, points: np.ndarray, where: np.ndarray) -> np.ndarray:
    """Rows (m, ROW) of geometries on no joint placed at `where` (m, 4, 4), in one pass: `rows`
    as they were (their radii, half sides and reach stay), their capsule's ends and box centre
    from `points` (m, 3, 3), those in the geometry's own frame. A re-posed person moves ~40
    geometries of every certifier of a re-plan: one call each cost ~7 us."""
    out = rows.copy()
    ends = _placed(points, where)
    out[:, 0:3], out[:, 3:6], out[:, 16:19] = ends[:, 0], ends[:, 1], ends[:, 2]
    out[:, 7:16] = where[:, :3, :3].reshape(-1, 9)
    return out


def _mesh_pieces(geometry: pin.GeometryObject, leaf: int = _LEAF) -> tuple[np.ndarray, np.ndarray]:
    """A tree of capsules holding a mesh's triangles: rows (m, 7: ends in the joint's frame,
    radius) in depth-first order, and per node where its subtree ends (its index plus one for a
    leaf). The root holds every triangle; a node's group of triangles is halved along its
    centres' widest spread into its two children, down to `leaf` triangles, and each node's
    capsule holds its group's corners (compiled: `mesh_tree_kernels.capsule_tree`). coal tests
    a mesh by its triangles, so a node clear of the other geometry means coal finds no contact
    with any of its triangles."""
    local, triangles = mesh_arrays(geometry.geometry)
    placement = geometry.placement
    return capsule_tree(local @ placement.rotation.T + placement.translation, triangles, leaf)


# By mesh and placement (`made_from_mesh`): the key itself, not a digest of it, which two meshes
# could share.
_PIECES: dict[tuple, tuple[coal.CollisionGeometry, tuple[np.ndarray, np.ndarray]]] = {}


def _pieces_of(geometry: pin.GeometryObject) -> tuple[np.ndarray, np.ndarray]:
    """`_mesh_pieces` of a mesh (made once per mesh and placement), none for another shape."""
    if not isinstance(geometry.geometry, coal.BVHModelBase):
        return np.zeros((0, 7)), np.zeros(0, dtype=np.int64)
    return made_from_mesh(
        _PIECES, geometry.geometry, lambda: _mesh_pieces(geometry), geometry.placement.homogeneous.tobytes()
    )


def _capsule_rows(capsules: np.ndarray) -> np.ndarray:
    """Rows (m, ROW) each holding only a capsule (m, 7: ends, radius; no box)."""
    out = np.zeros((len(capsules), ROW))
    out[:, 0:7] = capsules
    out[:, REACH] = np.linalg.norm(capsules[:, 3:6] - capsules[:, 0:3], axis=1) / 2.0 + capsules[:, 6]
    out[:, 7:16] = np.eye(3).reshape(9)
    out[:, 19:22] = np.inf
    return out


def _spheres_about(rows: np.ndarray, members: np.ndarray) -> np.ndarray:
    """Sphere rows (g, ROW), each holding the spheres of its members (`members` (g, len(rows)):
    a flag a row, one at least) about the middle of their centres' box, in one pass: every
    certifier a re-plan places holds the re-posed person's five (~30 us each, one by one)."""
    centres = (rows[:, 0:3] + rows[:, 3:6]) / 2.0
    inside = members[:, :, None]
    low = np.where(inside, centres, np.inf).min(axis=1, initial=np.inf)
    middle = (low + np.where(inside, centres, -np.inf).max(axis=1, initial=-np.inf)) / 2.0
    reach = np.linalg.norm(centres - middle[:, None], axis=-1) + rows[:, REACH]
    radii = np.where(members, reach, -np.inf).max(axis=1, initial=-np.inf)
    return _capsule_rows(np.column_stack([middle, middle, radii]))


class FreeCertifier:
    """Certifies states free of every checked pair of a collision model, or names the pairs and
    tables left to check. Not for threads at once: its scratch arrays are its own (as the
    checker's pinocchio data is)."""

    @classmethod
    def of(
        cls,
        model: pin.Model,
        geom_model: pin.GeometryModel,
        pairs: np.ndarray,
        tables: Sequence[ClearanceTable],
        groups: Sequence[Sequence[int]] = (),
        ids: Sequence[int] | None = None,
        meshes: Sequence[Sequence[TabledMeshes] | None] = (),
    ) -> FreeCertifier | None:
        """The certifier of these pairs (k, 2) and tables (at most 31), or None for a robot whose
        joints the kernel does not walk or with more tables. `groups`: geometries on no joint that stand together (a person's
        capsules), against which a moving geometry is first tested as one sphere. `meshes`: per
        table, its mesh pairs' trees with their geometries (`TabledMeshes`), decided on their
        triangles by the verdict where the table does not certify a state; None (or none given)
        for a table whose pairs are not all two meshes: coal's."""
        joints = joint_tables(model)
        if joints is None or len(tables) > 31:
            return None
        return cls(joints, geom_model, pairs, tables, groups, ids, meshes)

    def __init__(
        self,
        joints: tuple[np.ndarray, np.ndarray],
        geom_model: pin.GeometryModel,
        pairs: np.ndarray,
        tables: Sequence[ClearanceTable],
        groups: Sequence[Sequence[int]] = (),
        ids: Sequence[int] | None = None,
        meshes: Sequence[Sequence[TabledMeshes] | None] = (),
    ) -> None:
        self._joint_rows, self._joint_ints = joints
        objects = geom_model.geometryObjects
        pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
        used = sorted(set(pairs.reshape(-1).tolist()))
        self._used, slot = used, {g: k for k, g in enumerate(used)}
        # Rows: the geometries, one sphere per link of several, the meshes' pieces, one sphere per
        # group (a person) and per part of a group.
        rows = [_geometry_row(objects[i]) for i in used]
        carrier = [objects[i].parentJoint for i in used]
        self._links = _links_of(carrier)
        self._link_rows = list(range(len(rows), len(rows) + len(self._links)))
        rows += list(_spheres_about(np.array(rows).reshape(-1, ROW), _flags(self._links, len(rows))))
        carrier += [carrier[members[0]] for members in self._links]
        self._children = np.zeros((len(used), 2), dtype=np.int64)  # per geometry: first piece, count
        subtrees = [np.zeros(len(rows), dtype=np.int64)]  # per row: where its piece's subtree ends
        for k, g in enumerate(used):
            pieces, ends = _pieces_of(objects[g])
            self._children[k] = (len(rows), len(pieces))
            subtrees.append(ends + len(rows))
            rows += list(_capsule_rows(pieces))
            carrier += [carrier[k]] * len(pieces)
        self._groups = [[slot[g] for g in group if g in slot] for group in groups]
        self._groups = [group for group in self._groups if group]
        self._parts = [part for group in self._groups for part in _parts_of(np.array(rows), group)]
        self._group_rows = list(range(len(rows), len(rows) + len(self._groups)))
        self._part_rows = list(range(len(rows) + len(self._groups), len(rows) + len(self._groups) + len(self._parts)))
        rows += [np.zeros(ROW)] * (len(self._groups) + len(self._parts))
        subtrees.append(np.zeros(len(self._groups) + len(self._parts), dtype=np.int64))
        self._subtrees = np.concatenate(subtrees)
        carrier += [0] * (len(self._groups) + len(self._parts))
        self._rows, self._carrier = np.array(rows).reshape(-1, ROW), np.array(carrier, dtype=np.int64)
        ids = np.arange(len(pairs)) if ids is None else np.asarray(ids, dtype=np.int64)
        slots = np.vectorize(slot.get, otypes=[np.int64])(pairs).reshape(-1, 2)
        self._pairs = self._ordered_pairs(np.column_stack([slots, ids]))
        # The tables: per table its first axis, number of axes, first word and sub-cells a joint;
        # per axis (q index, cells, periodic) and (lower, step); the cells' words (their
        # certified sub-cells, `ClearanceTable.words`) one after another.
        axes = [axis for table in tables for axis in table._axes]
        counts = np.cumsum([0] + [len(table._axes) for table in tables])
        firsts = np.cumsum([0] + [len(table.words) for table in tables])
        self._tables = np.array(
            [(counts[k], len(t._axes), firsts[k], FINE) for k, t in enumerate(tables)], dtype=np.int64
        ).reshape(-1, 4)
        self._axis_ints = np.array([(i, n, wrap) for i, _, _, n, wrap in axes], dtype=np.int64).reshape(-1, 3)
        self._axis_floats = np.array([(lower, step) for _, lower, step, _, _ in axes], dtype=float).reshape(-1, 2)
        words = [np.asarray(t.words, dtype=np.uint64).view(np.int64) for t in tables]
        self._bits = np.concatenate(words or [np.zeros(0, np.int64)])
        # The geometries on no joint: their rows' slots, ids, points in their own frame
        # (`_static_rows`) and where they were placed, as the checker gives it (`place`).
        self._statics = np.array([k for k, g in enumerate(used) if objects[g].parentJoint == 0], dtype=np.int64)
        self._static_ids = np.array(used, dtype=np.int64)[self._statics]
        held = [_held_by(objects[g].geometry) for g in self._static_ids.tolist()]
        self._static_points = np.array([(start, end, centre) for start, end, _, centre, _ in held]).reshape(-1, 3, 3)
        self._where = np.array([objects[g].placement.homogeneous for g in self._static_ids.tolist()]).reshape(-1, 4, 4)
        # Per group, then part (`_group_rows + _part_rows`): which of the rows in a group
        # (`_grouped`) are its members.
        members = _flags(self._groups + self._parts, len(self._rows))
        self._grouped = np.flatnonzero(members.any(axis=0))
        self._members = members[:, self._grouped]
        self._static_grouped = members.any(axis=0)[self._statics]  # per geometry on no joint: in a group?
        self._place_groups()
        self._meshes = [
            list(meshes[k]) if k < len(meshes) and meshes[k] is not None else [] for k in range(len(tables))
        ]
        self._geometries = objects
        self._floats, self._ints = self._packed()

    def _ordered_pairs(self, pairs: np.ndarray) -> np.ndarray:
        """Pairs (a, b, id, then per level, coarse to fine, the rows tested and where their run
        ends or 0: `certifier_kernels.PAIR`) from rows (a, b, id). A geometry's node is its
        link's sphere or its person's, else itself; a person's capsule is also in a part of the
        person. The pairs between two nodes follow one another, a's pairs with b's node within
        them (b the larger node), and a's with each part of b's node within those; the first of
        a run holds where it ends, so that one test passes it: the nodes' spheres, then a against
        b's node, then a against the part."""
        top = dict(zip(self._group_rows + self._link_rows, self._groups + self._links))
        size = {row: len(members) for row, members in top.items()}
        node = {g: row for row, members in top.items() for g in members}
        part = {g: row for row, members in zip(self._part_rows, self._parts) for g in members}

        def oriented(a: int, b: int, i: int) -> tuple[int, int, int, int, int, int]:
            na, nb = node.get(a, a), node.get(b, b)
            if (size.get(na, 1), na) > (size.get(nb, 1), nb):
                a, b, na, nb = b, a, nb, na
            return a, b, i, na, nb, part.get(b, nb)

        rows = sorted((oriented(*p) for p in pairs.tolist()), key=lambda r: (r[3], r[4], r[0], r[5]))
        levels = [[_level(level, *r[:2], *r[3:]) for r in rows] for level in range(LEVELS)]
        out = []
        for k, (a, b, i, *_) in enumerate(rows):
            tests = [(*(keys[k] or (0, 0)), _run_end(keys, k)) for keys in levels]
            out.append((a, b, i, *(x for test in tests for x in test)))
        return np.array(out, dtype=np.int64).reshape(-1, PAIR)

    def _place_groups(self) -> None:
        """Each group's and part's sphere, where its members stand now."""
        if len(self._members):
            self._rows[self._group_rows + self._part_rows] = _spheres_about(self._rows[self._grouped], self._members)

    def place(self, where: np.ndarray) -> None:
        """Where the geometries on no joint stand now (an obstacle moved, a person re-posed):
        `where` (ngeoms, 4, 4) holds every geometry's placement in the collision model (those on
        a joint are not read). Only the rows of those that moved are made again, with the
        spheres of the groups they are in, and nothing if none moved (planning sets scenes
        around every call, most of them where they were). The checker keeps `where` as it
        places them: reading each placement through pinocchio cost ~3 us."""
        now = where[self._static_ids]
        moved = (now.reshape(-1, 16).view(np.uint64) != self._where.reshape(-1, 16).view(np.uint64)).any(axis=1)
        if not moved.any():
            return
        slots = self._statics[moved]
        self._rows[slots] = _static_rows(self._rows[slots], self._static_points[moved], now[moved])
        self._where[moved] = now[moved]
        if (moved & self._static_grouped).any():
            self._place_groups()
        # Only the float array's rows and its scratch change (not the int array, nor the tabled
        # meshes' trees, most of the floats): written in place, not packed again (a MADAR place
        # cost ~0.09 ms with the trees copied, five a re-plan).
        rows = self._rows.reshape(-1)
        self._floats[self._ints[9] : self._ints[9] + rows.size] = rows
        self._work[:] = self._scratch()

    def _float_parts(self) -> list[np.ndarray]:
        """The float array's parts. The kernel's scratch ends it (`_scratch`)."""
        parts = [np.array([BOUND_TOLERANCE]), self._joint_rows, self._rows, self._axis_floats, self._mesh_floats]
        return [*parts, self._scratch()]

    def _scratch(self) -> np.ndarray:
        """The kernel's scratch as packed: the joints' frames, the state they were placed at
        (none yet) and which moved, the rows in the world (those on no joint placed now, for
        good; the kernel places the others), then the verdict at that state (its code and its
        pairs left, none yet: `certifier_kernels.verdict_of`)."""
        nj = len(self._joint_rows)
        made = [np.zeros(nj * 12), np.full(nj * 2, np.nan), np.zeros(nj), self._rows.reshape(-1)]
        return np.concatenate([*made, np.full(ASKED_OF_COAL + 1, np.nan)])

    @property
    def _work(self) -> np.ndarray:
        """The kernel's scratch: the last of `_float_parts`, a view of the float array."""
        return self._floats[-(len(self._joint_rows) * 15 + self._rows.size + ASKED_OF_COAL + 1) :]

    def _packed(self) -> tuple[np.ndarray, np.ndarray]:
        """All of it in one float and one int array (a numba call costs ~0.05 us an array): the
        int array starts with the sizes and where each part begins (`_unpack`), and ends with the
        ids of the pairs left (the kernel's); the float array is `_float_parts`."""
        sizes = [
            len(self._joint_rows),
            len(self._rows),
            len(self._pairs),
            len(self._tables),
            len(self._axis_ints),
            len(self._children),
            len(self._children) + len(self._links),  # rows placed at each state (those on a joint)
        ]
        # The header: the sizes, where each float part starts, then each int part, in the
        # kernel's order (`_unpack`), then the tabled meshes' parts (`_decided_tables`). The
        # words run to the meshes' witnesses; the witnesses and the pairs left, which the kernel
        # writes, end the int array.
        header = len(sizes) + 5 + 9 + 4
        before = (self._joint_ints, self._carrier, self._pairs, self._tables, self._axis_ints, self._children)
        self._mesh_floats, mesh_ints = self._mesh_parts(
            1 + self._joint_rows.size + self._rows.size + self._axis_floats.size,
            header + sum(a.size for a in before) + self._subtrees.size,
            self._bits.size,
        )
        floats = self._float_parts()
        left = np.zeros(ASKED_OF_COAL + 1)
        ints = [self._joint_ints, self._carrier, self._pairs, self._tables, self._axis_ints, self._children]
        ints += [self._subtrees, *mesh_ints[:3], self._bits, mesh_ints[3], left]
        float_starts = np.cumsum([0] + [a.size for a in floats])[:-1]
        int_starts = header + np.cumsum([0] + [a.size for a in ints])[:-1]
        kernel_order = [*float_starts[:4], float_starts[5], *int_starts[:7], int_starts[10], int_starts[12]]
        meshes = [float_starts[4], int_starts[7], int_starts[8], int_starts[11]]
        head = np.array([*sizes, *kernel_order, *meshes], dtype=np.int64)
        packed = np.concatenate([head, *(a.reshape(-1).astype(np.int64) for a in ints)])
        self._left = packed[-left.size :]  # a view the kernel writes
        self.kernel_written = packed.size - int(head[24])  # the witnesses, then the pairs left
        return np.concatenate([a.reshape(-1) for a in floats]), packed

    def _mesh_parts(self, float_start: int, int_start: int, words: int) -> tuple[np.ndarray, list[np.ndarray]]:
        """The tabled meshes packed: their float part starting at `float_start` of the float
        array (the margin, then per pair its two placements in their joints' frames and its two
        trees' boxes and triangles), and their int parts (per table its first pair and count;
        per pair its row, `certifier_kernels.MESH_ROW`; the trees' nodes; then, after the
        tables' `words`, each pair's witnesses, -1 for none: the kernel writes them) starting at
        `int_start` of the int array."""
        pairs = [pair for table in self._meshes for pair in table]
        table_meshes = np.zeros((len(self._meshes), 2), dtype=np.int64)
        table_meshes[:, 1] = [len(table) for table in self._meshes]
        table_meshes[1:, 0] = np.cumsum(table_meshes[:-1, 1])
        rows = np.zeros((len(pairs), MESH_ROW), dtype=np.int64)
        floats: list[np.ndarray] = [np.array([MESH_MARGIN])]
        nodes: list[np.ndarray] = []
        at_float, at_int = float_start + 1, int_start + table_meshes.size + rows.size
        for m, (trees, first, second) in enumerate(pairs):
            for side, tree, g in ((0, trees.first, first), (MESH_SIDE, trees.second, second)):
                placement = self._geometries[g].placement
                boxes, triangles = tree.boxes.reshape(-1), tree.triangles.reshape(-1)
                rows[m, side : side + MESH_SIDE] = (
                    self._geometries[g].parentJoint,
                    at_float,
                    at_float + 12,
                    at_int,
                    at_float + 12 + boxes.size,
                    len(tree.nodes),
                    len(tree.triangles),
                )
                floats += [placement.rotation.reshape(-1), placement.translation, boxes, triangles]
                nodes.append(tree.nodes.reshape(-1))
                at_float += 12 + boxes.size + triangles.size
                at_int += tree.nodes.size
        rows[:, MESH_WITNESSES] = at_int + words + 2 * WITNESSES * np.arange(len(pairs))
        witnesses = np.full(2 * WITNESSES * len(pairs), -1, dtype=np.int64)
        return np.concatenate(floats), [table_meshes, rows, np.concatenate([np.zeros(0, np.int64), *nodes]), witnesses]

    @property
    def packed(self) -> tuple[np.ndarray, np.ndarray]:
        """The float and int arrays `verdict_one` takes (compiled callers ask it themselves)."""
        return self._floats, self._ints

    def verdict(self, q: np.ndarray) -> tuple[int, tuple[int, ...]] | None:
        """(tables, pairs) at `q`: bit k of tables says table k (of those given) does not
        certify it; pairs are the ids of the pairs that may touch; only those can. `FREE`
        (the same object) if none; None if more than `ASKED_OF_COAL` pairs may touch."""
        code = verdict_one(q, self._floats, self._ints)
        return FREE if code == 0 else _decoded(code, self._left)

    def verdicts(self, qs: np.ndarray) -> list[tuple[int, tuple[int, ...]] | None]:
        """`verdict` of every state of `qs` (N, nq), in one call."""
        if not len(qs):
            return []
        left = np.empty((len(qs), ASKED_OF_COAL + 1), dtype=np.int64)
        codes = verdicts(np.ascontiguousarray(qs, dtype=float), self._floats, self._ints, left)
        return [_decoded(code, row) for code, row in zip(codes.tolist(), left)]

    def left_over(self, qs: np.ndarray) -> tuple[list[int], list[bool], list[tuple[int, tuple[int, ...]] | None]]:
        """The states of `qs` (N, nq) it does not certify free, in order: their indices, whether
        a pair is proven to touch there (`certifier_kernels.exact_verdict`: coal finds it collide),
        and `verdict` of each (None where proven). A path's dense validation asks coal about
        these only: a verdict each for the hundreds of free states cost ~1 us apiece."""
        left = np.empty((len(qs), ASKED_OF_COAL + 1), dtype=np.int64)
        codes = verdicts(np.ascontiguousarray(qs, dtype=float), self._floats, self._ints, left)
        asked = np.flatnonzero(codes).tolist()
        touching = (codes[asked] == TOUCHING).tolist()
        return asked, touching, [_decoded(int(codes[k]), left[k]) for k in asked]

    def free_many(self, qs: np.ndarray) -> np.ndarray:
        """Per state of `qs`: free (no pair may touch, every table certifies it)."""
        return np.array([verdict is FREE for verdict in self.verdicts(qs)], dtype=bool)


FREE: tuple[int, tuple[int, ...]] = (0, ())


def _decoded(code: int, left: np.ndarray) -> tuple[int, tuple[int, ...]] | None:
    """`verdict`'s answer from the kernel's code and the ids it left."""
    if code == 0:
        return FREE
    if code < 0:
        return None
    return code & 0xFFFFFFFF, tuple(left[1 : (code >> 32) + 1].tolist())


def _flags(members: Sequence[Sequence[int]], count: int) -> np.ndarray:
    """Per list of `members`, a flag each of `count` rows: is it one of them?"""
    flags = np.zeros((len(members), count), dtype=bool)
    for k, listed in enumerate(members):
        flags[k, listed] = True
    return flags


def _links_of(carrier: list[int]) -> list[list[int]]:
    """The geometries (slots) of each joint that carries two or more: a node each, whose sphere
    stays put in the joint's frame."""
    by_joint: dict[int, list[int]] = {}
    for k, joint in enumerate(carrier):
        by_joint.setdefault(joint, []).append(k)
    return [members for joint, members in by_joint.items() if joint != 0 and len(members) > 1]


def _parts_of(rows: np.ndarray, members: list[int], count: int = _PARTS) -> list[list[int]]:
    """`members` (slots of `rows`) in `count` parts of members near one another (none if they do
    not split): the part whose centres spread widest halved along that spread."""
    centres = (rows[:, 0:3] + rows[:, 3:6]) / 2.0
    parts = [sorted(members)]
    while len(parts) < count and max(map(len, parts)) > 1:
        widest = max((p for p in parts if len(p) > 1), key=lambda p: np.ptp(centres[p], axis=0).max())
        parts.remove(widest)
        axis = int(np.argmax(np.ptp(centres[widest], axis=0)))
        order = sorted(widest, key=lambda g: centres[g, axis])
        parts += [order[: len(order) // 2], order[len(order) // 2 :]]
    return parts if len(parts) > 1 else []


def _level(level: int, a: int, b: int, na: int, nb: int, pb: int) -> tuple[int, int] | None:
    """The rows that test a pair's run at `level` (its nodes na, nb; pb: b's part, else nb), or
    None where that is no test (a geometry alone, its own node, or a coarser level's rows)."""
    if level == 0:
        return (na, nb) if na not in (a, nb) else None
    if level == 1:
        return (a, nb) if nb not in (b, na) else None
    return (a, pb) if pb not in (b, nb) else None


def _run_end(keys: list[tuple[int, int] | None], k: int) -> int:
    """Where the run of pairs with key k's ends, if k is its first and it holds two or more;
    else 0 (one pair is tested alone)."""
    if keys[k] is None or (k > 0 and keys[k - 1] == keys[k]):
        return 0
    end = next((j for j in range(k, len(keys)) if keys[j] != keys[k]), len(keys))
    return end if end - k > 1 else 0
