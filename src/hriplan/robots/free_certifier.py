"""A compiled certifier of "collision-free": lower bounds on every checked pair's distance.

Why: coal's broad phase costs 6-60 us a state from Python, and almost every state a planner asks
about is far from contact. Each geometry is held by a capsule (a segment and a radius) that
contains it, and an obstacle also by its box; a pair's distance is bounded below by the
segments' distance less both radii, or a capsule's distance to the other's box (the capsule cut
into pieces, each in a sphere, refined where near). A state is certified free only when every
pair the broad phase checks is bounded above `BOUND_TOLERANCE` and every clearance table of the
mesh pairs certifies it: then coal would say free too, so skipping coal changes no answer. Any
other state is left to coal, unchanged. Forward kinematics, bounds and tables run in one call
per state (or per batch), compiled by numba and cached on disk.

The bounds are conservative: a capsule (or box) holds its geometry (`_held_by`), and each
distance below is a true lower bound in exact arithmetic; rounding errs by ~1e-15 m on metre
sized scenes, far below the 1e-4 m tolerance.
- Segments: the least distance is reached at an end of one of them (a point-to-segment
  distance) or at points inside both, where it is the distance between their lines; the line
  distance is never above the segments', so the least of the four end distances and the line
  distance (when the lines' nearest points fall within the segments, 1e-3 of margin for
  rounding) is a lower bound. Nearly parallel lines (sine below 1e-4) have an ill-conditioned
  line distance: there the distance of the second segment's ends to the first's line, less the
  second's length times 1e-4, bounds it instead (along a segment at angle t to a line, the
  squared distance is the lines' squared distance plus (s sin t)^2).
- Capsule to box: each piece of the segment lies in a sphere about its middle of radius half
  its length (plus the capsule's), whose distance to the box is exact; a piece too near is
  halved, down to `_DEPTH` levels, then the pair is left to coal.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import coal
import numpy as np
import pinocchio as pin
from numba import njit

from hriplan.robots.kernel_fk import joint_tables, place_joints
from hriplan.robots.mesh_clearance import ClearanceTable
from hriplan.robots.part_spheres import BOUND_TOLERANCE

_DEPTH = 6  # a capsule against a box: pieces of 1/64 of its segment at the finest
_LEAVES = 16  # spheres per mesh
ASKED_OF_COAL = 8  # pairs a state may leave to coal one by one; more: the whole broad phase
_PARALLEL = 1e-4  # sine below which two segments' line distance is not used
_INSIDE = 1e-3  # margin on the lines' nearest points falling within both segments
# A geometry's row: capsule ends in its joint's frame (3 + 3) and radius; box rotation (9),
# centre (3) and half sides (3) in the joint's frame (a box of infinite sides when it has none);
# the radius of the sphere about the capsule's middle that holds it (half its length + radius).
_CAPSULE, _BOX, _REACH = 7, 15, 22
_ROW = _REACH + 1


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
    """The row (23,) of a geometry: its capsule and box in its joint's frame."""
    start, end, radius, centre, half = _held_by(geometry.geometry)
    placement = geometry.placement
    capsule = np.concatenate([placement.act(start), placement.act(end), [radius]])
    box = np.concatenate([placement.rotation.reshape(9), placement.act(centre), half])
    return np.concatenate([capsule, box, [np.linalg.norm(end - start) / 2.0 + radius]])


def _mesh_pieces(geometry: pin.GeometryObject, leaves: int = _LEAVES) -> list[np.ndarray]:
    """Spheres (centre in the joint's frame, radius: 4) holding every triangle of a mesh: the
    widest group of triangles halved along its centres' widest spread until there are `leaves`,
    each group in the sphere about its vertices' box. coal tests a mesh by its triangles, so
    spheres clear of the other geometry mean coal finds no contact."""
    shape = geometry.geometry
    vertices = np.asarray(shape.vertices(), dtype=float)
    triangles = np.array([[t[0], t[1], t[2]] for t in (shape.tri_indices(i) for i in range(shape.num_tris))])

    def sphere(group: np.ndarray) -> tuple[np.ndarray, float]:
        points = vertices[np.unique(group)]
        centre = (points.min(axis=0) + points.max(axis=0)) / 2.0
        return centre, float(np.sqrt(((points - centre) ** 2).sum(axis=1).max()))

    groups = [(triangles, *sphere(triangles))]
    while len(groups) < leaves:
        widest = max(range(len(groups)), key=lambda k: groups[k][2] if len(groups[k][0]) > 1 else -1.0)
        group = groups[widest][0]
        if len(group) < 2:
            break
        groups.pop(widest)
        centres = vertices[group].mean(axis=1)
        order = np.argsort(centres[:, int(np.argmax(np.ptp(centres, axis=0)))], kind="stable")
        halves = group[order[: len(group) // 2]], group[order[len(group) // 2 :]]
        groups += [(half, *sphere(half)) for half in halves]
    return [np.array([*geometry.placement.act(centre), radius]) for _, centre, radius in groups]


_PIECES: dict[int, tuple[coal.CollisionGeometry, list[np.ndarray]]] = {}  # by mesh, kept alive with it


def _pieces_of(geometry: pin.GeometryObject) -> list[np.ndarray]:
    """`_mesh_pieces` of a mesh (made once per mesh and placement: ~10 ms), none for another shape."""
    if not isinstance(geometry.geometry, coal.BVHModelBase):
        return []
    key = hash((id(geometry.geometry), geometry.placement.homogeneous.tobytes()))
    if key not in _PIECES:
        _PIECES[key] = (geometry.geometry, _mesh_pieces(geometry))
    return _PIECES[key][1]


def _sphere_row(centre: np.ndarray, radius: float) -> np.ndarray:
    """A row holding only a sphere (a capsule of no length, no box)."""
    return np.concatenate([centre, centre, [radius], np.eye(3).reshape(9), np.zeros(3), np.full(3, np.inf), [radius]])


class FreeCertifier:
    """Certifies states free of every checked pair of a collision model, or says nothing."""

    @classmethod
    def of(
        cls,
        model: pin.Model,
        geom_model: pin.GeometryModel,
        pairs: np.ndarray,
        tables: Sequence[ClearanceTable],
        groups: Sequence[Sequence[int]] = (),
        ids: Sequence[int] | None = None,
    ) -> FreeCertifier | None:
        """The certifier of these pairs (k, 2) and tables (at most 31), or None for a robot whose
        joints the kernel does not walk or with more tables. `groups`: geometries on no joint that stand together (a person's
        capsules), against which a moving geometry is first tested as one sphere."""
        joints = joint_tables(model)
        if joints is None or len(tables) > 31:
            return None
        return cls(joints, geom_model, pairs, tables, groups, ids)

    def __init__(
        self,
        joints: tuple[np.ndarray, np.ndarray],
        geom_model: pin.GeometryModel,
        pairs: np.ndarray,
        tables: Sequence[ClearanceTable],
        groups: Sequence[Sequence[int]] = (),
        ids: Sequence[int] | None = None,
    ) -> None:
        self._joint_rows, self._joint_ints = joints
        objects = geom_model.geometryObjects
        pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
        used = sorted(set(pairs.reshape(-1).tolist()))
        self._used, slot = used, {g: k for k, g in enumerate(used)}
        # Rows: the geometries, then the meshes' pieces, then one sphere per group.
        rows = [_geometry_row(objects[i]) for i in used]
        carrier = [objects[i].parentJoint for i in used]
        self._children = np.zeros((len(used), 2), dtype=np.int64)  # per geometry: first piece, count
        for k, g in enumerate(used):
            pieces = _pieces_of(objects[g])
            self._children[k] = (len(rows), len(pieces))
            rows += [_sphere_row(p[:3], p[3]) for p in pieces]
            carrier += [carrier[k]] * len(pieces)
        self._groups = [[slot[g] for g in group if g in slot] for group in groups]
        self._groups = [group for group in self._groups if group]
        self._group_rows = list(range(len(rows), len(rows) + len(self._groups)))
        rows += [np.zeros(_ROW)] * len(self._groups)
        carrier += [0] * len(self._groups)
        self._rows, self._carrier = np.array(rows).reshape(-1, _ROW), np.array(carrier, dtype=np.int64)
        ids = np.arange(len(pairs)) if ids is None else np.asarray(ids, dtype=np.int64)
        slots = np.vectorize(slot.get, otypes=[np.int64])(pairs).reshape(-1, 2)
        self._pairs = self._ordered_pairs(np.column_stack([slots, ids]))
        self._left = np.empty(ASKED_OF_COAL + 1, dtype=np.int64)
        # The tables: per table its first axis, number of axes and first bit; per axis (q index,
        # cells, periodic) and (lower, step); the cells' bits one after another.
        axes = [axis for table in tables for axis in table._axes]
        counts = np.cumsum([0] + [len(table._axes) for table in tables])
        bits = np.cumsum([0] + [len(table.free) for table in tables])
        self._tables = np.array([(counts[k], len(t._axes), bits[k]) for k, t in enumerate(tables)], dtype=np.int64)
        self._tables = self._tables.reshape(-1, 3)
        self._axis_ints = np.array([(i, n, wrap) for i, _, _, n, wrap in axes], dtype=np.int64).reshape(-1, 3)
        self._axis_floats = np.array([(lower, step) for _, lower, step, _, _ in axes], dtype=float).reshape(-1, 2)
        self._bits = np.concatenate([np.asarray(t.free, dtype=np.uint8) for t in tables] or [np.zeros(0, np.uint8)])
        self._statics = [k for k, g in enumerate(used) if objects[g].parentJoint == 0]
        self._place_groups()
        self._floats, self._ints = self._packed()

    def _ordered_pairs(self, pairs: np.ndarray) -> np.ndarray:
        """Pairs (a, b, group's row or -1, end of the run or 0, id) from rows (a, b, id): a
        moving geometry's pairs with the members of one group follow one another, the first
        holding where the run ends, so that one test against the group's sphere passes them all."""
        member = {g: k for k, group in enumerate(self._groups) for g in group}
        grouped = sorted(
            ((a, b, i) if b in member else (b, a, i) for a, b, i in pairs.tolist() if (a in member) != (b in member)),
            key=lambda p: (p[0], member[p[1]]),
        )
        alone = [(a, b, -1, 0, i) for a, b, i in pairs.tolist() if (a in member) == (b in member)]
        runs = [(a, member[b]) for a, b, _ in grouped]
        out = list(alone)
        for k, (a, b, i) in enumerate(grouped):
            first = k == 0 or runs[k - 1] != runs[k]
            end = len(alone) + next((j for j in range(k, len(grouped)) if runs[j] != runs[k]), len(grouped))
            out.append((a, b, self._group_rows[member[b]], end if first else 0, i))
        return np.array(out, dtype=np.int64).reshape(-1, 5)

    def _place_groups(self) -> None:
        """Each group's sphere: about the middle of its members' spheres' box, holding them all."""
        for row, group in zip(self._group_rows, self._groups):
            members = self._rows[group]
            centres = (members[:, 0:3] + members[:, 3:6]) / 2.0
            middle = (centres.min(axis=0) + centres.max(axis=0)) / 2.0
            radius = float(np.max(np.linalg.norm(centres - middle, axis=1) + members[:, _REACH]))
            self._rows[row] = _sphere_row(middle, radius)

    def place(self, geom_model: pin.GeometryModel) -> None:
        """Read again where the geometries on no joint stand (an obstacle moved, a person re-posed)."""
        objects = geom_model.geometryObjects
        for k in self._statics:
            self._rows[k] = _geometry_row(objects[self._used[k]])
        self._place_groups()
        self._floats, self._ints = self._packed()

    def _packed(self) -> tuple[np.ndarray, np.ndarray]:
        """All of it in one float and one int array (a numba call costs ~0.1 us an array): the
        int array starts with the sizes and where each part begins (`_unpack`)."""
        floats = [self._joint_rows, self._rows, self._axis_floats]
        ints = [self._joint_ints, self._carrier, self._pairs, self._tables, self._axis_ints, self._children, self._bits]
        sizes = [
            len(self._joint_rows),
            len(self._rows),
            len(self._pairs),
            len(self._tables),
            len(self._axis_ints),
            len(self._children),
        ]
        header = len(sizes) + len(floats) + len(ints)
        float_starts = np.cumsum([0] + [a.size for a in floats])[:-1]
        int_starts = header + np.cumsum([0] + [a.size for a in ints])[:-1]
        head = np.array([*sizes, *float_starts, *int_starts], dtype=np.int64)
        packed = np.concatenate([head, *(a.reshape(-1).astype(np.int64) for a in ints)])
        # The rows in the world: those on no joint placed now, for good; the kernel places the others.
        self._placed = self._rows.copy()
        return np.concatenate([a.reshape(-1) for a in floats]), packed

    def verdict(self, q: np.ndarray) -> tuple[int, tuple[int, ...]] | None:
        """(tables, pairs) at `q`: bit k of tables says table k (of those given) does not
        certify it; pairs are the ids of the pairs that may touch; only those can. `FREE`
        (the same object) if none; None if more than `ASKED_OF_COAL` pairs may touch."""
        return _decoded(_verdict_one(q, self._floats, self._ints, self._placed, self._left), self._left)

    def verdicts(self, qs: np.ndarray) -> list[tuple[int, tuple[int, ...]] | None]:
        """`verdict` of every state of `qs` (N, nq), in one call."""
        if not len(qs):
            return []
        left = np.empty((len(qs), ASKED_OF_COAL + 1), dtype=np.int64)
        codes = _verdicts(np.ascontiguousarray(qs, dtype=float), self._floats, self._ints, self._placed, left)
        return [_decoded(code, row) for code, row in zip(codes.tolist(), left)]

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


@njit(cache=True, nogil=True)
def _uncertified_tables(q, tables, axis_ints, axis_floats, bits) -> int:
    """The tables that do not certify `q`, bit k for table k: `ClearanceTable.certified`'s arithmetic."""
    mask = 0
    for k in range(tables.shape[0]):
        first, count, flat, inside = tables[k, 0], tables[k, 1], 0, True
        for a in range(first, first + count):
            i, n, wrap = axis_ints[a, 0], axis_ints[a, 1], axis_ints[a, 2]
            lower, step = axis_floats[a, 0], axis_floats[a, 1]
            c = math.floor((q[i] - lower) / step)
            if wrap:
                c %= n
            elif c == n and q[i] - lower <= step * n:
                c = n - 1
            elif not 0 <= c < n:
                inside = False
                break
            flat = flat * n + c
        if not inside or bits[tables[k, 2] + flat] != 1:
            mask |= 1 << k
    return mask


@njit(cache=True, nogil=True)
def _point_segment(px, py, pz, ax, ay, az, bx, by, bz) -> float:
    """Distance from a point to the segment a-b."""
    dx, dy, dz = bx - ax, by - ay, bz - az
    length = dx * dx + dy * dy + dz * dz
    t = 0.0
    if length > 0.0:
        t = min(max(((px - ax) * dx + (py - ay) * dy + (pz - az) * dz) / length, 0.0), 1.0)
    ex, ey, ez = px - ax - t * dx, py - ay - t * dy, pz - az - t * dz
    return math.sqrt(ex * ex + ey * ey + ez * ez)


@njit(cache=True, nogil=True)
def _point_line(px, py, pz, ax, ay, az, dx, dy, dz, length) -> float:
    """Distance from a point to the line through a along d (|d|^2 = length > 0)."""
    t = ((px - ax) * dx + (py - ay) * dy + (pz - az) * dz) / length
    ex, ey, ez = px - ax - t * dx, py - ay - t * dy, pz - az - t * dz
    return math.sqrt(ex * ex + ey * ey + ez * ez)


@njit(cache=True, nogil=True)
def segment_floor(rows, a, b) -> float:
    """A lower bound on the distance between the segments of rows a and b (ends at 0:3 and 3:6;
    module docstring: the ends' distances and, where it can hold the least, the lines' distance).
    Rows and indices, not views: making a view costs more than the arithmetic."""
    p0, p1, p2, p3, p4, p5 = rows[a, 0], rows[a, 1], rows[a, 2], rows[a, 3], rows[a, 4], rows[a, 5]
    q0, q1, q2, q3, q4, q5 = rows[b, 0], rows[b, 1], rows[b, 2], rows[b, 3], rows[b, 4], rows[b, 5]
    least = min(
        _point_segment(p0, p1, p2, q0, q1, q2, q3, q4, q5),
        _point_segment(p3, p4, p5, q0, q1, q2, q3, q4, q5),
        _point_segment(q0, q1, q2, p0, p1, p2, p3, p4, p5),
        _point_segment(q3, q4, q5, p0, p1, p2, p3, p4, p5),
    )
    ux, uy, uz = p3 - p0, p4 - p1, p5 - p2
    vx, vy, vz = q3 - q0, q4 - q1, q5 - q2
    a, e = ux * ux + uy * uy + uz * uz, vx * vx + vy * vy + vz * vz
    if a == 0.0 or e == 0.0:  # a point: its distance is one of the ends'
        return least
    nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    normal = nx * nx + ny * ny + nz * nz
    if normal <= _PARALLEL * _PARALLEL * a * e:
        across = min(
            _point_line(q0, q1, q2, p0, p1, p2, ux, uy, uz, a),
            _point_line(q3, q4, q5, p0, p1, p2, ux, uy, uz, a),
        )
        return min(least, across - math.sqrt(e) * _PARALLEL)
    rx, ry, rz = p0 - q0, p1 - q1, p2 - q2
    b, c, f = ux * vx + uy * vy + uz * vz, ux * rx + uy * ry + uz * rz, vx * rx + vy * ry + vz * rz
    denominator = a * e - b * b
    s, t = (b * f - c * e) / denominator, (a * f - b * c) / denominator
    if s < -_INSIDE or s > 1.0 + _INSIDE or t < -_INSIDE or t > 1.0 + _INSIDE:
        return least
    return min(least, abs(rx * nx + ry * ny + rz * nz) / math.sqrt(normal))


@njit(cache=True, nogil=True)
def _box_gap(x, y, z, hx, hy, hz) -> float:
    """Distance from a point in a box's frame to the box (0 inside)."""
    dx, dy, dz = max(abs(x) - hx, 0.0), max(abs(y) - hy, 0.0), max(abs(z) - hz, 0.0)
    return math.sqrt(dx * dx + dy * dy + dz * dz)


@njit(cache=True, nogil=True)
def capsule_clears_box(rows, a, b, tolerance) -> bool:
    """True if row a's capsule (ends, radius: 0:7) is more than `tolerance` from row b's box
    (rotation 7:16, centre 16:19, half sides 19:22): its segment's pieces, halved where near,
    each in a sphere clear of the box. The pieces are the nodes of a binary tree walked depth
    first (piece i of level l spans [i, i + 1] / 2^l), with no stack."""
    ox, oy, oz = rows[a, 0] - rows[b, 16], rows[a, 1] - rows[b, 17], rows[a, 2] - rows[b, 18]
    x0 = rows[b, 7] * ox + rows[b, 10] * oy + rows[b, 13] * oz
    y0 = rows[b, 8] * ox + rows[b, 11] * oy + rows[b, 14] * oz
    z0 = rows[b, 9] * ox + rows[b, 12] * oy + rows[b, 15] * oz
    ox, oy, oz = rows[a, 3] - rows[a, 0], rows[a, 4] - rows[a, 1], rows[a, 5] - rows[a, 2]
    dx = rows[b, 7] * ox + rows[b, 10] * oy + rows[b, 13] * oz
    dy = rows[b, 8] * ox + rows[b, 11] * oy + rows[b, 14] * oz
    dz = rows[b, 9] * ox + rows[b, 12] * oy + rows[b, 15] * oz
    hx, hy, hz, radius = rows[b, 19], rows[b, 20], rows[b, 21], rows[a, 6]
    length = math.sqrt(dx * dx + dy * dy + dz * dz)
    level, i = 0, 0
    while True:
        width = 1.0 / (1 << level)
        middle = (i + 0.5) * width
        gap = _box_gap(x0 + middle * dx, y0 + middle * dy, z0 + middle * dz, hx, hy, hz)
        if gap - radius - width * length / 2.0 > tolerance:
            while i % 2 == 1:  # the last of its siblings: up to the first ancestor with a next one
                level, i = level - 1, i // 2
            if level == 0:
                return True
            i += 1
        elif level == _DEPTH:
            return False
        else:
            level, i = level + 1, 2 * i


@njit(cache=True, nogil=True)
def _place(rows, g, rotation, origin, j, out) -> None:
    """Row g (joint j's frame) in the world, into out[g]: capsule ends and radius, box rotation,
    centre and sides, reach."""
    for e in range(2):
        x, y, z = rows[g, 3 * e], rows[g, 3 * e + 1], rows[g, 3 * e + 2]
        for r in range(3):
            out[g, 3 * e + r] = origin[j, r] + rotation[j, r, 0] * x + rotation[j, r, 1] * y + rotation[j, r, 2] * z
    out[g, 6] = rows[g, 6]
    out[g, 19], out[g, 20], out[g, 21], out[g, _REACH] = rows[g, 19], rows[g, 20], rows[g, 21], rows[g, _REACH]
    if rows[g, 19] == np.inf:  # no box (a capsule or sphere): nothing more is read
        return
    for r in range(3):
        u0, u1, u2 = rotation[j, r, 0], rotation[j, r, 1], rotation[j, r, 2]
        for c in range(3):
            out[g, 7 + 3 * r + c] = u0 * rows[g, 7 + c] + u1 * rows[g, 10 + c] + u2 * rows[g, 13 + c]
        out[g, 16 + r] = origin[j, r] + u0 * rows[g, 16] + u1 * rows[g, 17] + u2 * rows[g, 18]


@njit(cache=True, nogil=True)
def pair_clear(rows, a, b, tolerance) -> bool:
    """True if placed rows a and b (in the world) are more than `tolerance` apart: the spheres
    about their capsules' middles, else their capsules, else a capsule against the other's box."""
    cx = rows[a, 0] + rows[a, 3] - rows[b, 0] - rows[b, 3]
    cy = rows[a, 1] + rows[a, 4] - rows[b, 1] - rows[b, 4]
    cz = rows[a, 2] + rows[a, 5] - rows[b, 2] - rows[b, 5]
    apart = 2.0 * (rows[a, _REACH] + rows[b, _REACH] + tolerance)  # |cx, cy, cz| is twice the centres' gap
    if cx * cx + cy * cy + cz * cz > apart * apart:
        return True
    if segment_floor(rows, a, b) - rows[a, 6] - rows[b, 6] > tolerance:
        return True
    if rows[b, 19] < np.inf and capsule_clears_box(rows, a, b, tolerance):
        return True
    return rows[a, 19] < np.inf and capsule_clears_box(rows, b, a, tolerance)


@njit(cache=True, nogil=True)
def _unpack(floats, ints):
    """The parts of `FreeCertifier._packed`, as views."""
    nj, ng, npairs, ntables, naxes, nused = ints[0], ints[1], ints[2], ints[3], ints[4], ints[5]
    joint_rows = floats[ints[6] : ints[6] + nj * 15].reshape((nj, 15))
    rows = floats[ints[7] : ints[7] + ng * _ROW].reshape((ng, _ROW))
    axis_floats = floats[ints[8] : ints[8] + naxes * 2].reshape((naxes, 2))
    joint_ints = ints[ints[9] : ints[9] + nj * 3].reshape((nj, 3))
    carrier = ints[ints[10] : ints[10] + ng]
    pairs = ints[ints[11] : ints[11] + npairs * 5].reshape((npairs, 5))
    tables = ints[ints[12] : ints[12] + ntables * 3].reshape((ntables, 3))
    axis_ints = ints[ints[13] : ints[13] + naxes * 3].reshape((naxes, 3))
    children = ints[ints[14] : ints[14] + nused * 2].reshape((nused, 2))
    bits = ints[ints[15] :]
    return joint_rows, rows, axis_floats, joint_ints, carrier, pairs, tables, axis_ints, children, bits


@njit(cache=True, nogil=True)
def _pieces_clear(rows, carrier, children, rotation, origin, placed, a, b) -> bool:
    """True if geometries a and b are clear, each taken whole or, where that fails, as its
    mesh's pieces (which hold all its triangles): the pieces are placed here, as few states
    need them."""
    for g in (a, b):
        for piece in range(children[g, 0], children[g, 0] + children[g, 1]):
            _place(rows, piece, rotation, origin, carrier[piece], placed)
    first_a, count_a = children[a, 0], children[a, 1]
    first_b, count_b = children[b, 0], children[b, 1]
    for i in range(max(count_a, 1)):
        x = a if count_a == 0 else first_a + i
        if pair_clear(placed, x, b, BOUND_TOLERANCE):
            continue
        if count_b == 0:
            return False
        for j in range(count_b):
            if not pair_clear(placed, x, first_b + j, BOUND_TOLERANCE):
                return False
    return True


@njit(cache=True, nogil=True)
def _verdict(q, floats, ints, placed, left) -> int:
    """-1 if more pairs may touch at `q` than `left` holds (stopped there); else the tables
    that do not certify `q` (bit k for table k) plus 2^32 times the count of pairs that may
    touch, whose ids `left` gets from left[1] on: 0 is free. A run of pairs with one group
    passes at once when its sphere is clear. `placed` holds the rows on no joint already
    (placed once, when packed)."""
    joint_rows, rows, axis_floats, joint_ints, carrier, pairs, tables, axis_ints, children, bits = _unpack(floats, ints)
    nj = joint_rows.shape[0]
    rotation, origin = np.empty((nj, 3, 3)), np.empty((nj, 3))
    place_joints(q, joint_rows, joint_ints, rotation, origin)
    for g in range(children.shape[0]):
        if carrier[g] != 0:
            _place(rows, g, rotation, origin, carrier[g], placed)
    count, k = 0, 0
    while k < pairs.shape[0]:
        a, b, group, end = pairs[k, 0], pairs[k, 1], pairs[k, 2], pairs[k, 3]
        if end > 0 and pair_clear(placed, a, group, BOUND_TOLERANCE):
            k = end
            continue
        if not pair_clear(placed, a, b, BOUND_TOLERANCE) and (
            (children[a, 1] == 0 and children[b, 1] == 0)
            or not _pieces_clear(rows, carrier, children, rotation, origin, placed, a, b)
        ):
            if count + 1 == left.shape[0]:
                return -1
            count += 1
            left[count] = pairs[k, 4]
        k += 1
    return _uncertified_tables(q, tables, axis_ints, axis_floats, bits) + (count << 32)


@njit(cache=True, nogil=True)
def _verdict_one(q, floats, ints, placed, left) -> int:
    return _verdict(q, floats, ints, placed, left)


@njit(cache=True, nogil=True)
def _verdicts(qs, floats, ints, placed, left) -> np.ndarray:
    """Per state (row n of `left` its pairs that may touch)."""
    out = np.empty(qs.shape[0], dtype=np.int64)
    for n in range(qs.shape[0]):
        out[n] = _verdict(qs[n], floats, ints, placed, left[n])
    return out
