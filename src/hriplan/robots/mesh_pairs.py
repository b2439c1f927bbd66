"""Box trees over a mesh's triangles, and a mesh pair decided on them (`mesh_pair_kernels.py`)
before coal is asked.

Why: the mesh pairs a clearance table does not certify at a state (MADAR's forearm and wrist 2
near contact) were coal's to decide, ~74 us a free state and ~18 us a colliding one. The
compiled walk over two trees proves most of them either way in a few microseconds; the few it
cannot prove (triangles within the margin of touching) still go to coal, so the answer is
always coal's.
"""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin

from hriplan.robots import mesh_pair_kernels as kernels
from hriplan.robots.mesh_arrays import made_from_mesh, mesh_arrays
from hriplan.robots.mesh_tree_kernels import split

# Triangles closer than this (m) or overlapping by less are left to coal: far above rounding
# (~1e-15 m) and coal's GJK tolerance (~1e-6 m), far below the gaps a search meets.
MARGIN = 1e-5
_WITNESSES = 16  # touching pairs kept: 4 proved 80 % of the peg-in-hole's colliding states, 16 98 %


class MeshTree:
    """A mesh's triangles in its frame, in leaf order (T, 9: their vertices), under a tree of
    boxes (N, 6: centre, half sides) whose nodes (N, 4) are rows of `mesh_pair_kernels` (LEFT,
    RIGHT, FIRST, COUNT), the root first, a child after its parent. A leaf holds one triangle
    (more made the free states ~1.2-1.7x slower: a triangle pair costs more than a box pair)."""

    def __init__(self, geometry: coal.BVHModelBase) -> None:
        vertices, indices = mesh_arrays(geometry)
        triangles = vertices[indices].reshape(-1, 9)
        order, nodes = split(triangles.reshape(-1, 3, 3).mean(axis=1))
        self.triangles = np.ascontiguousarray(triangles[order])
        self.nodes = nodes
        self.boxes = _boxes(self.triangles.reshape(-1, 3, 3), nodes)

    @staticmethod
    def of(geometry: coal.BVHModelBase) -> MeshTree:
        """A mesh's tree, made once per mesh (`made_from_mesh`: ~1-2 ms a MADAR arm link, and the
        robots of a task and both arms share their meshes)."""
        return made_from_mesh(_TREES, geometry, lambda: MeshTree(geometry))


_TREES: dict[tuple, tuple[coal.BVHModelBase, MeshTree]] = {}  # by mesh (`made_from_mesh`)


def _boxes(triangles: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """Each node's box (centre, half sides) about its triangles (T, 3, 3), in leaf order."""
    lower = np.vstack([triangles.min(axis=1), np.zeros(3)])  # a row past the end: reduceat's bound
    upper = np.vstack([triangles.max(axis=1), np.zeros(3)])
    first = nodes[:, kernels.FIRST]
    bounds = np.stack([first, first + nodes[:, kernels.COUNT]], axis=1).ravel()  # [first, end) of each
    low, high = np.minimum.reduceat(lower, bounds)[::2], np.maximum.reduceat(upper, bounds)[::2]
    return np.hstack([(low + high) / 2.0, (high - low) / 2.0])


class MeshPair:
    """Two meshes (coal's first and second of a collision pair) and the pairs of their triangles
    found touching lately (`mesh_pair_kernels.decide`'s witnesses)."""

    def __init__(self, first: coal.BVHModelBase, second: coal.BVHModelBase) -> None:
        self.first, self.second = MeshTree.of(first), MeshTree.of(second)
        self.witnesses = np.full((_WITNESSES, 2), -1, dtype=np.int64)

    @staticmethod
    def of(first: coal.CollisionGeometry, second: coal.CollisionGeometry) -> MeshPair | None:
        """The pair's trees if both are triangle meshes (a table's part may be a box: coal's)."""
        meshes = all(isinstance(g, coal.BVHModelBase) and g.num_tris > 0 for g in (first, second))
        return MeshPair(first, second) if meshes else None

    def touches(self, first: pin.SE3, second: pin.SE3) -> bool | None:
        """Do the meshes, placed at `first` and `second`, collide as coal's `collide` would say;
        None when not proven either way (ask coal)."""
        placement = first.actInv(second).homogeneous
        a, b = self.first, self.second
        verdict = kernels.decide(
            a.boxes, a.nodes, a.triangles, b.boxes, b.nodes, b.triangles, placement, MARGIN, self.witnesses
        )
        return None if verdict == kernels.UNDECIDED else verdict == kernels.TOUCHING


def load_kernel() -> None:
    """Compile (or load from numba's cache) the walk, deciding two one-triangle meshes apart: a
    process that loads its kernels at start (`planner/kernels.py`) pays it there, not at the
    first state a search asks."""
    meshes = []
    for corners in (np.eye(3), np.eye(3) + 1.0):
        mesh = coal.BVHModelOBBRSS()
        mesh.beginModel(1, 3)
        mesh.addTriangle(*corners)
        mesh.endModel()
        meshes.append(mesh)
    MeshPair(*meshes).touches(pin.SE3.Identity(), pin.SE3.Identity())
