"""Joint-space tables that certify a mesh pair free without touching its meshes.

Two links with one link between them (a UR5's base and upper arm, its forearm and wrist 2) are
checked on their URDF meshes (acm.MESH), which sit 1-2 cm apart in most states: coal's check of
those two pairs is most of a UR5's collision check (23 of 32 us). Their relative pose depends
only on the joints between them, so a grid over those joints, computed once per robot, says
where the pair cannot touch. A cell is certified free when, at each of its corners, every slab
of the child link's triangles is farther from the parent's shapes than that slab can move
inside the cell: a point turning about a joint moves at most its distance from the joint's
origin times the angle. A state in a certified cell skips the meshes; any other state checks
them exactly, so the answer is always the meshes' answer.
"""

from __future__ import annotations

import base64
import hashlib
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import coal
import numpy as np
import pinocchio as pin

from hriplan.robots.acm import MESH
from hriplan.robots.fit_cache import cached_fit
from hriplan.robots.mesh_arrays import mesh_arrays
from hriplan.robots.model import Robot
from hriplan.robots.robot_geometry import RobotPart, part_collision_shapes

RULES = "v1: 1-2 revolute joints between; median clearance < 5 cm; 128 cells a turn; 8 slabs; 0.1 mm"
CELLS_PER_TURN = 128
# Each cell a table does not certify is cut into FINE sub-cells along each joint (FINE^2 = 64: one
# word a cell) and those certified the same way, at the sub-cells' corners with their smaller
# margin: a planner's states near contact (MADAR's wrist 2 a few mm from its forearm, with the
# tool held level) fall in cells the coarse grid cannot certify. Cells whose corners all touch
# are not cut (they lie in contact).
FINE = 8
FINE_RULES = f"v1: {FINE} sub-cells a joint in each uncertified cell, unless every corner touches"
SLABS = 8
EPSILON = 1e-4  # m beyond the bound, for coal's own tolerance
# A pair whose meshes are farther apart than this in half of the sampled states is cheap to
# check (coal's bounding volumes part them early): it keeps no table.
NEAR = 0.05
NEAR_SAMPLES = 64
_REVOLUTE = {"JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRevoluteUnaligned"}


@dataclass(frozen=True)
class Slab:
    """Some of the child link's triangles, placed in the child joint's frame, and per joint
    between the links a bound on how fast any of its points moves about that joint (m/rad)."""

    shape: coal.CollisionGeometry
    placement: pin.SE3
    reach: np.ndarray


@dataclass(frozen=True)
class ClearanceTable:
    """Certified-free cells of one part pair over the joints between its two links."""

    parts: tuple[str, str]
    q_index: tuple[int, ...]  # the joints' places in q
    lower: tuple[float, ...]
    step: tuple[float, ...]
    cells: tuple[int, ...]
    periodic: tuple[bool, ...]  # a full turn or more: the grid wraps
    free: np.ndarray  # bool, flat, row-major over `cells`
    # Per cell, its certified sub-cells (`FINE` a joint, row-major: bit s0 * FINE + s1), as
    # uint64; None: every sub-cell of a free cell, none of another's.
    words: np.ndarray | None = None
    _axes: tuple = field(init=False, repr=False, compare=False)
    _words: list = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:  # plain Python for `certified`, asked at every collision check
        axes = tuple(zip(self.q_index, self.lower, self.step, self.cells, self.periodic))
        object.__setattr__(self, "_axes", axes)
        if self.words is None:
            object.__setattr__(self, "words", np.where(self.free, np.uint64(full_word(len(axes))), np.uint64(0)))
        object.__setattr__(self, "_words", self.words.tolist())

    def certified(self, q: Sequence[float]) -> bool:
        """True if the pair cannot touch at `q` (a list is quickest); False says nothing: check the
        meshes."""
        flat, sub = 0, 0
        for i, lower, step, n, wrap in self._axes:
            x = (q[i] - lower) / step
            c = math.floor(x)
            s = min(max(math.floor((x - c) * FINE), 0), FINE - 1)
            if wrap:
                c %= n
            elif c == n and q[i] - lower <= step * n:  # the upper limit itself: its last sub-cell
                c, s = n - 1, FINE - 1
            elif not 0 <= c < n:
                return False
            flat, sub = flat * n + c, sub * FINE + s
        return self._words[flat] >> sub & 1 == 1

    def certified_many(self, qs: np.ndarray) -> np.ndarray:
        """`certified` of every row of `qs` (N, nq) at once, by the same arithmetic (a path's
        states are asked together: one numpy pass instead of a Python loop per state)."""
        certain, flat = np.ones(len(qs), dtype=bool), np.zeros(len(qs), dtype=np.int64)
        sub = np.zeros(len(qs), dtype=np.uint64)
        for i, lower, step, n, wrap in self._axes:
            offset = qs[:, i] - lower
            x = offset / step
            c = np.floor(x)
            s = np.clip(np.floor((x - c) * FINE), 0, FINE - 1)
            if wrap:
                c = np.mod(c, n)
            else:
                top = (c == n) & (offset <= step * n)
                c, s = np.where(top, n - 1, c), np.where(top, FINE - 1, s)
                certain &= (c >= 0) & (c < n)
            flat = flat * n + np.where(certain, c, 0).astype(np.int64)
            sub = sub * np.uint64(FINE) + np.where(certain, s, 0).astype(np.uint64)
        return certain & (self.words[flat] >> sub & np.uint64(1) == 1)


def full_word(axes: int) -> int:
    """The word of a cell whose every sub-cell is certified."""
    return (1 << FINE**axes) - 1


def _chain(model: pin.Model, joint: int) -> list[int]:
    """The joint and its ancestors, without the universe."""
    out = []
    while joint:
        out.append(joint)
        joint = model.parents[joint]
    return out


def joints_between(model: pin.Model, parent_joint: int, child_joint: int) -> list[int] | None:
    """The joints that move `child_joint`'s body relative to `parent_joint`'s, root first; None if
    the child is not below the parent."""
    above = _chain(model, child_joint)
    if parent_joint and parent_joint not in above:
        return None
    return sorted(set(above) - set(_chain(model, parent_joint)))


def _points(shape: pin.GeometryObject) -> np.ndarray:
    """Points whose hull holds the shape, in its joint's frame: a mesh's vertices, a primitive's
    bounding-box corners."""
    geometry = shape.geometry
    if isinstance(geometry, coal.BVHModelBase):
        local = np.asarray(geometry.vertices())
    else:
        geometry.computeLocalAABB()
        box = geometry.aabb_local
        local = np.array(list(itertools.product(*zip(box.min_, box.max_))))
    return local @ shape.placement.rotation.T + shape.placement.translation


def slabs(model: pin.Model, joints: list[int], shapes: list[pin.GeometryObject], count: int = SLABS) -> list[Slab]:
    """The child's shapes, meshes cut into `count` slabs along their longest extent, each with its
    reach about every joint in `joints`: the offsets of the joints after that joint plus the slab's
    farthest point from the last joint (a bound on its distance from the joint's axis, whatever
    the joints between)."""
    pieces: list[tuple[coal.CollisionGeometry, pin.SE3, np.ndarray]] = []
    for shape in shapes:
        geometry = shape.geometry
        if not (isinstance(geometry, coal.BVHModelBase) and geometry.num_tris > 0):
            pieces.append((geometry, shape.placement, _points(shape)))
            continue
        vertices = _points(shape)
        triangles = mesh_arrays(geometry)[1]
        centres = vertices[triangles].mean(axis=1)
        along = np.argsort(centres[:, np.argmax(np.ptp(centres, axis=0))])
        for chosen in np.array_split(along, count):
            mesh = coal.BVHModelOBBRSS()
            mesh.beginModel(len(chosen), 3 * len(chosen))
            for t in chosen:
                mesh.addTriangle(*vertices[triangles[t]])
            mesh.endModel()
            pieces.append((mesh, pin.SE3.Identity(), vertices[triangles[chosen]].reshape(-1, 3)))
    offsets = [float(np.linalg.norm(model.jointPlacements[j].translation)) for j in joints]
    return [
        Slab(piece, placement, np.array([radius + sum(offsets[k + 1 :]) for k in range(len(joints))]))
        for piece, placement, points in pieces
        for radius in [float(np.linalg.norm(points, axis=1).max())]
    ]


@dataclass(frozen=True)
class _Grid:
    q_index: tuple[int, ...]
    lower: tuple[float, ...]
    step: tuple[float, ...]
    cells: tuple[int, ...]
    periodic: tuple[bool, ...]

    def nodes(self) -> list[np.ndarray]:
        """Per joint, its node values: a wrapped axis has as many nodes as cells."""
        return [
            lower + step * np.arange(n if wrap else n + 1)
            for lower, step, n, wrap in zip(self.lower, self.step, self.cells, self.periodic)
        ]


def _grid(model: pin.Model, joints: list[int]) -> _Grid:
    turn = 2.0 * math.pi
    q_index, lower, step, cells, periodic = [], [], [], [], []
    for j in joints:
        i = model.idx_qs[j]
        low, high = float(model.lowerPositionLimit[i]), float(model.upperPositionLimit[i])
        wrap = high - low >= turn - 1e-9
        n = CELLS_PER_TURN if wrap else max(1, math.ceil((high - low) / turn * CELLS_PER_TURN))
        q_index.append(i)
        lower.append(0.0 if wrap else low)
        step.append((turn if wrap else high - low) / n)
        cells.append(n)
        periodic.append(wrap)
    return _Grid(tuple(q_index), tuple(lower), tuple(step), tuple(cells), tuple(periodic))


class _RelativePose:
    """The child joint's placement in the parent joint's frame, for values of the joints between."""

    def __init__(self, model: pin.Model, parent: int, child: int, q_index: tuple[int, ...]) -> None:
        self.model, self.data, self.parent, self.child, self.q_index = model, model.createData(), parent, child, q_index
        self.q = pin.neutral(model)

    def __call__(self, values: tuple[float, ...]) -> pin.SE3:
        for i, v in zip(self.q_index, values):
            self.q[i] = v
        pin.forwardKinematics(self.model, self.data, self.q)
        return self.data.oMi[self.parent].actInv(self.data.oMi[self.child])


def _transform(placement: pin.SE3) -> coal.Transform3s:
    return coal.Transform3s(placement.rotation, placement.translation)


def _eligible_joints(model: pin.Model, parent: list[pin.GeometryObject], child: list[pin.GeometryObject]):
    """The joints between the two parts' links if the pair can have a table (see RULES)."""
    if len({s.parentJoint for s in parent}) > 1 or len({s.parentJoint for s in child}) > 1:
        return None
    joints = joints_between(model, parent[0].parentJoint, child[0].parentJoint)
    if not joints or len(joints) > 2 or any(model.joints[j].shortname() not in _REVOLUTE for j in joints):
        return None
    return joints


def _rounded(array: np.ndarray) -> list:
    """Rounded to a micrometre, well inside EPSILON (and -0.0 made 0.0), so that two mounts of
    one arm give one key."""
    return (np.round(array, 6) + 0.0).tolist()


def _shape_key(shape: pin.GeometryObject, frame: pin.SE3) -> tuple:
    """A shape's content, placed in `frame`."""
    geometry = shape.geometry
    if isinstance(geometry, coal.BVHModelBase):
        vertices = np.asarray(geometry.vertices()).round(9)
        content = hashlib.sha256(vertices.tobytes() + mesh_arrays(geometry)[1].tobytes()).hexdigest()
    else:
        content = repr(_rounded(_points(shape)))
    return (type(geometry).__name__, content, _rounded(frame.actInv(shape.placement).homogeneous))


def _content_key(model: pin.Model, joints: list[int], parent: list[pin.GeometryObject], child) -> tuple:
    """What a pair's table depends on, whichever robot it belongs to and wherever it is mounted
    (MADAR's arms and the UR5 share their tables): the shapes, seen from the first joint between,
    the joints' kinds, placements after the first and limits."""
    grid = _grid(model, joints)
    first = model.jointPlacements[joints[0]]
    return (
        RULES,
        [_shape_key(s, first) for s in parent],
        [_shape_key(s, pin.SE3.Identity()) for s in child],
        [model.joints[j].shortname() for j in joints],
        [_rounded(model.jointPlacements[j].homogeneous) for j in joints[1:]],
        grid.lower,
        grid.step,
        grid.cells,
        grid.periodic,
    )


def _free_cells(model: pin.Model, joints: list[int], parent: list[pin.GeometryObject], child) -> np.ndarray | None:
    """The certified cells (flat), or None for a pair that is not near enough to need them."""
    grid = _grid(model, joints)
    pose = _RelativePose(model, parent[0].parentJoint, child[0].parentJoint, grid.q_index)
    fixed = [(s.geometry, _transform(s.placement)) for s in parent]
    lows = [model.lowerPositionLimit[i] for i in grid.q_index]
    highs = [model.upperPositionLimit[i] for i in grid.q_index]
    clearances = []
    for values in np.random.default_rng(0).uniform(lows, highs, size=(NEAR_SAMPLES, len(joints))):
        where = pose(tuple(values))
        clearances += [
            coal.distance(
                g, t, s.geometry, _transform(where * s.placement), coal.DistanceRequest(), coal.DistanceResult()
            )
            for g, t in fixed
            for s in child
        ]
    if np.median(clearances) >= NEAR:
        return None
    moving = slabs(model, joints, child)
    requests = []
    for slab in moving:
        request = coal.CollisionRequest()
        request.security_margin = float(slab.reach @ np.array(grid.step)) / 2.0 + EPSILON
        requests.append(request)
    axes = grid.nodes()
    clear = np.zeros([len(a) for a in axes], dtype=bool)
    for index in itertools.product(*(range(len(a)) for a in axes)):
        where = pose(tuple(a[k] for a, k in zip(axes, index)))
        clear[index] = not any(
            coal.collide(g, t, slab.shape, _transform(where * slab.placement), request, coal.CollisionResult())
            for slab, request in zip(moving, requests)
            for g, t in fixed
        )
    return cells_with_clear_corners(clear, grid.periodic).ravel()


def _fine_words(model: pin.Model, joints: list[int], parent: list, child: list, free: np.ndarray) -> np.ndarray:
    """Per cell of the grid (flat), its certified sub-cells as a word (`ClearanceTable.words`):
    every one of a free cell; in another, each block of sub-cells (halves of the cell along
    every joint, halved again where not certified, down to a sub-cell) whose corners are all
    clear of the parent by the block's margin (the slabs' reach times half its steps), as
    `_free_cells` certifies a cell. A cell whose corners all touch the parent is not cut."""
    grid = _grid(model, joints)
    pose = _RelativePose(model, parent[0].parentJoint, child[0].parentJoint, grid.q_index)
    fixed = [(s.geometry, _transform(s.placement)) for s in parent]
    moving = slabs(model, joints, child)
    fine = np.array(grid.step) / FINE
    axes = len(joints)
    requests: dict[int, list[coal.CollisionRequest]] = {}  # per block size (sub-cells a joint)
    for size in (1, 2, FINE // 2):
        requests[size] = []
        for slab in moving:
            request = coal.CollisionRequest()
            request.security_margin = float(slab.reach @ fine) * size / 2.0 + EPSILON
            requests[size].append(request)
    shapes = [(s.geometry, s.placement) for s in child]

    def where(index: tuple[int, ...], node: tuple[int, ...]) -> pin.SE3:  # a node of the sub-cells of a cell
        return pose(
            tuple(lower + step * k + f * o for lower, step, k, f, o in zip(grid.lower, grid.step, index, fine, node))
        )

    def touches(index: tuple[int, ...]) -> bool:  # the child at a node of the grid
        placed, request = where(index, (0,) * axes), coal.CollisionRequest()
        return any(
            coal.collide(g, t, shape, _transform(placed * placement), request, coal.CollisionResult())
            for shape, placement in shapes
            for g, t in fixed
        )

    def clear(index: tuple[int, ...], node: tuple[int, ...], size: int) -> bool:  # by a block's margin
        placed = where(index, node)
        return not any(
            coal.collide(g, t, slab.shape, _transform(placed * slab.placement), request, coal.CollisionResult())
            for slab, request in zip(moving, requests[size])
            for g, t in fixed
        )

    words = np.where(free, np.uint64(full_word(axes)), np.uint64(0))
    corners = list(itertools.product((0, 1), repeat=axes))
    touching: dict[tuple[int, ...], bool] = {}
    for cell in np.flatnonzero(~free).tolist():
        index = tuple(int(k) for k in np.unravel_index(cell, grid.cells))
        nodes = [tuple(k + o for k, o in zip(index, corner)) for corner in corners]
        nodes = [tuple(k % n if wrap else k for k, n, wrap in zip(node, grid.cells, grid.periodic)) for node in nodes]
        for node in nodes:
            if node not in touching:
                touching[node] = touches(node)
        if all(touching[node] for node in nodes):
            continue
        asked: dict[tuple[tuple[int, ...], int], bool] = {}
        word, blocks = 0, [(origin, FINE // 2) for origin in itertools.product((0, FINE // 2), repeat=axes)]
        while blocks:
            origin, size = blocks.pop()
            ends = [tuple(o + size * c for o, c in zip(origin, corner)) for corner in corners]
            for node in ends:
                if (node, size) not in asked:
                    asked[node, size] = clear(index, node, size)
            if all(asked[node, size] for node in ends):
                for sub in itertools.product(range(size), repeat=axes):
                    word |= 1 << _sub_bit(tuple(o + k for o, k in zip(origin, sub)))
            elif size > 1:
                half = size // 2
                blocks += [(tuple(o + half * c for o, c in zip(origin, corner)), half) for corner in corners]
        words[cell] = np.uint64(word)
    return words


def _sub_bit(sub: tuple[int, ...]) -> int:
    """A sub-cell's bit in its cell's word (row-major)."""
    bit = 0
    for s in sub:
        bit = bit * FINE + s
    return bit


def cells_with_clear_corners(clear: np.ndarray, periodic: tuple[bool, ...]) -> np.ndarray:
    """Per cell, whether all its corner nodes are clear. A wrapped axis has as many nodes as
    cells (its last cell closes on node 0); another has one node more."""
    free = clear
    for axis, wrap in enumerate(periodic):
        before = (slice(None),) * axis
        upper = np.roll(free, -1, axis=axis) if wrap else free[(*before, slice(1, None))]
        free = (free if wrap else free[(*before, slice(0, -1))]) & upper
    return free


def clearance_tables(robot: Robot, parts: tuple[RobotPart, ...], acm: dict[str, str]) -> list[ClearanceTable]:
    """The tables of the robot's mesh pairs that have one. Kept on disk per robot description (a
    read of one file) and per pair's content (shared by arms mounted elsewhere, computed once per
    machine: a few seconds a pair)."""
    pairs = sorted(pair for pair, reason in acm.items() if reason == MESH)
    key = (RULES, FINE_RULES, robot.urdf, robot.spec.hand_postures, robot.finger_values, robot.model_key, pairs)
    tables = cached_fit("clearance-robot", key, lambda: {"tables": _robot_tables(robot, parts, pairs)})["tables"]
    made = [
        ClearanceTable(
            tuple(t["parts"]),
            tuple(t["q_index"]),
            tuple(t["lower"]),
            tuple(t["step"]),
            tuple(t["cells"]),
            tuple(t["periodic"]),
            _bits(t["free"], math.prod(t["cells"])),
            np.frombuffer(base64.b64decode(t["words"]), dtype="<u8").astype(np.uint64),
        )
        for t in tables
    ]
    return [table for table in made if table.free.any()]  # one that certifies nothing only costs a look-up


def _bits(text: str, count: int) -> np.ndarray:
    return np.unpackbits(np.frombuffer(base64.b64decode(text), dtype=np.uint8))[:count].astype(bool)


def _robot_tables(robot: Robot, parts: tuple[RobotPart, ...], pairs: list[str]) -> list[dict]:
    """Each table as JSON, its cells from the cache by the pair's content, or computed."""
    by_name = {part.name: part for part in parts}
    tables = []
    for pair in pairs:
        names = pair.split("|")
        shapes = [part_collision_shapes(robot, by_name[name]) for name in names]
        if not all(shapes):
            continue
        if joints_between(robot.model, shapes[1][0].parentJoint, shapes[0][0].parentJoint) is not None:
            shapes.reverse()  # the parent first
        joints = _eligible_joints(robot.model, *shapes)
        if joints is None:
            continue

        def compute(joints: list[int] = joints, shapes: list = shapes) -> dict:
            free = _free_cells(robot.model, joints, *shapes)
            return {"free": None if free is None else base64.b64encode(np.packbits(free).tobytes()).decode()}

        content = _content_key(robot.model, joints, *shapes)
        free = cached_fit("clearance", content, compute)["free"]
        if free is not None:
            grid = _grid(robot.model, joints)

            def refine(
                joints: list[int] = joints, shapes: list = shapes, free: str = free, cells: int = math.prod(grid.cells)
            ) -> dict:
                words = _fine_words(robot.model, joints, *shapes, _bits(free, cells))
                return {"words": base64.b64encode(words.astype("<u8").tobytes()).decode()}

            words = cached_fit("clearance-fine", (FINE_RULES, content), refine)["words"]
            tables.append(
                {
                    "parts": names,
                    **{f: list(getattr(grid, f)) for f in _Grid.__dataclass_fields__},
                    "free": free,
                    "words": words,
                }
            )
    return tables
