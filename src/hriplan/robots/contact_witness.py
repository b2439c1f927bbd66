"""Contacts of a tabled mesh pair proven from the triangles that touched last.

Why: MADAR's forearm and wrist 2 meshes touch in over half the states its peg-in-hole planner
asks coal about (their clearance table cannot certify them), and coal takes ~50 us to find that
out each time, while a walk's states touch at the same few triangles again and again. The
triangle pairs coal reported in contact are kept (a few per pair); at the next state those are
tested first: an edge of one triangle passing through the other's inside, both ends farther than
`DEPTH` from its plane and the crossing farther than `DEPTH` inside each of its edges, means the
meshes intersect there, so coal finds them collide too. A witness proves nothing otherwise: coal
decides, as before. Compiled (numba), used only with the kernels on.
"""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin
from numba import njit

WITNESSES = 8  # triangle pairs kept per mesh pair, the most recent first
DEPTH = 1e-5  # m: how clearly an edge must pass through a triangle for a proof


class ContactWitnesses:
    """The triangle pairs last found in contact, per mesh pair of a collision model; a proof
    from them that a pair collides at the current placement."""

    def __init__(self) -> None:
        self._corners: dict[tuple[int, str], np.ndarray] = {}  # (geometry, name): corners (T, 3, 3), own frame
        # Per collision pair id: the model it is of, its geometries, their corners and the
        # witnesses (<= WITNESSES, 2), the most recent first: made when coal first finds it collide.
        self._kept: dict[int, tuple[pin.GeometryModel, int, int, np.ndarray, np.ndarray, np.ndarray]] = {}

    def proven(self, geom_model: pin.GeometryModel, geom_data: pin.GeometryData, pair: int) -> bool:
        """True if a kept witness shows collision pair `pair` intersecting where `geom_data`
        places it (coal would find it collide); False says nothing. ~3 us."""
        kept = self._kept.get(pair)
        if kept is None or kept[0] is not geom_model:
            return False
        _, first, second, corners_first, corners_second, witnesses = kept
        at_first, at_second = geom_data.oMg[first].homogeneous, geom_data.oMg[second].homogeneous
        return crossing(corners_first, at_first, corners_second, at_second, witnesses)

    def remember(self, geom_model: pin.GeometryModel, geom_data: pin.GeometryData, pair: int) -> None:
        """Keep the triangles of collision pair `pair`'s contacts as coal last computed them."""
        found = [(c.b1, c.b2) for c in geom_data.collisionResults[pair].getContacts()]
        kept = self._kept.get(pair)
        if kept is None or kept[0] is not geom_model:
            p = geom_model.collisionPairs[pair]
            corners = self._corners_of(geom_model, p.first), self._corners_of(geom_model, p.second)
            kept = (geom_model, p.first, p.second, *corners, np.zeros((0, 2), dtype=np.int64))
        witnesses = np.vstack([np.array(found, dtype=np.int64).reshape(-1, 2), kept[5]])[:WITNESSES]
        self._kept[pair] = (*kept[:5], witnesses)

    def _corners_of(self, geom_model: pin.GeometryModel, g: int) -> np.ndarray:
        """The triangles' corners of mesh geometry g, in its own frame (read once)."""
        key = (g, geom_model.geometryObjects[g].name)
        if key not in self._corners:
            shape = geom_model.geometryObjects[g].geometry
            assert isinstance(shape, coal.BVHModelBase)
            vertices = np.asarray(shape.vertices(), dtype=float)
            triangles = [[t[0], t[1], t[2]] for t in (shape.tri_indices(i) for i in range(shape.num_tris))]
            self._corners[key] = np.ascontiguousarray(vertices[np.array(triangles, dtype=np.int64)])
        return self._corners[key]


@njit(cache=True, nogil=True)
def crossing(
    first: np.ndarray, at_first: np.ndarray, second: np.ndarray, at_second: np.ndarray, pairs: np.ndarray
) -> bool:
    """True if for a pair (i, j) of `pairs`, triangle i of `first` placed at `at_first` (4, 4)
    and triangle j of `second` at `at_second` clearly intersect: an edge of one through the
    other (`_edge_through`). Indices outside either mesh prove nothing."""
    a, b = np.empty((3, 3)), np.empty((3, 3))
    for k in range(pairs.shape[0]):
        i, j = pairs[k, 0], pairs[k, 1]
        if not (0 <= i < first.shape[0] and 0 <= j < second.shape[0]):
            continue
        for c in range(3):
            for r in range(3):
                a[c, r] = at_first[r, 3] + at_first[r, 0] * first[i, c, 0] + at_first[r, 1] * first[i, c, 1]
                a[c, r] += at_first[r, 2] * first[i, c, 2]
                b[c, r] = at_second[r, 3] + at_second[r, 0] * second[j, c, 0] + at_second[r, 1] * second[j, c, 1]
                b[c, r] += at_second[r, 2] * second[j, c, 2]
        if _edge_through(a, b) or _edge_through(b, a):
            return True
    return False


@njit(cache=True, nogil=True)
def _edge_through(a: np.ndarray, t: np.ndarray) -> bool:
    """True if an edge of triangle `a` (3, 3) passes through triangle `t`: its ends on either
    side of t's plane by more than DEPTH, and the point where it crosses the plane more than
    DEPTH inside each of t's edges (distances along t's unit normal and within its plane)."""
    ux, uy, uz = t[1, 0] - t[0, 0], t[1, 1] - t[0, 1], t[1, 2] - t[0, 2]
    vx, vy, vz = t[2, 0] - t[0, 0], t[2, 1] - t[0, 1], t[2, 2] - t[0, 2]
    nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    norm = np.sqrt(nx * nx + ny * ny + nz * nz)
    if norm == 0.0:
        return False
    nx, ny, nz = nx / norm, ny / norm, nz / norm
    for e in range(3):
        p, q = a[e], a[(e + 1) % 3]
        dp = (p[0] - t[0, 0]) * nx + (p[1] - t[0, 1]) * ny + (p[2] - t[0, 2]) * nz
        dq = (q[0] - t[0, 0]) * nx + (q[1] - t[0, 1]) * ny + (q[2] - t[0, 2]) * nz
        if not ((dp > DEPTH and dq < -DEPTH) or (dp < -DEPTH and dq > DEPTH)):
            continue
        s = dp / (dp - dq)
        x = (p[0] + (q[0] - p[0]) * s, p[1] + (q[1] - p[1]) * s, p[2] + (q[2] - p[2]) * s)
        inside = True
        for c in range(3):
            o, d = t[c], t[(c + 1) % 3]
            ex, ey, ez = d[0] - o[0], d[1] - o[1], d[2] - o[2]
            length = np.sqrt(ex * ex + ey * ey + ez * ez)
            wx, wy, wz = x[0] - o[0], x[1] - o[1], x[2] - o[2]
            # (e x w) . n / |e|: the crossing's distance inside edge c (t's corners turn about n)
            across = ((ey * wz - ez * wy) * nx + (ez * wx - ex * wz) * ny + (ex * wy - ey * wx) * nz) / length
            if not across > DEPTH:
                inside = False
                break
        if inside:
            return True
    return False
