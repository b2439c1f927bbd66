"""A coal mesh's vertices and triangles as numpy arrays, read once per mesh.

Why: coal gives a mesh's triangles one Python call at a time (~1.5 us each: ~8 ms for a mesh of
a few thousand); the clearance tables, the mesh pairs' box trees, the certifier's capsule trees
and the viewer each read them, and MADAR's first plan read its meshes three times over.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

import coal
import numpy as np

T = TypeVar("T")

# By mesh (`mesh_key`), the mesh kept alive with its arrays (`made_from_mesh`).
_READ: dict[tuple, tuple[coal.BVHModelBase, tuple[np.ndarray, np.ndarray]]] = {}


def mesh_key(mesh: coal.CollisionGeometry) -> int:
    """The address of coal's mesh object, which names it for the caches of what is made from a
    mesh (its arrays, its trees): the robots of one description share their meshes (each file is
    loaded once, `model.urdf_geometry`), so a hand's new posture or the other arm finds them made;
    Python's `id` of a wrapper does not (one wrapper per geometry object). Keep the mesh alive
    beside what is cached, so that no other mesh takes the address."""
    return mesh.id()


def made_from_mesh(
    cache: dict[tuple, tuple[coal.CollisionGeometry, T]],
    mesh: coal.CollisionGeometry,
    make: Callable[[], T],
    *more: bytes,
) -> T:
    """What `make` makes from `mesh`, made once per mesh (`mesh_key`) and `more` (the rest of its
    key, e.g. a placement): kept in `cache` beside the mesh, alive with it."""
    key = (mesh_key(mesh), *more)
    if key not in cache:
        cache[key] = (mesh, make())
    return cache[key][1]


def mesh_arrays(mesh: coal.BVHModelBase) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V, 3) and triangles (T, 3: vertex indices, int64) of a loaded coal mesh, in its
    own frame; read-only (shared by every caller)."""
    return made_from_mesh(_READ, mesh, lambda: _read(mesh))


def _read(mesh: coal.BVHModelBase) -> tuple[np.ndarray, np.ndarray]:
    vertices = np.array(mesh.vertices(), dtype=float).reshape(-1, 3)
    corners = (mesh.tri_indices(k) for k in range(mesh.num_tris))
    triangles = np.array([(t[0], t[1], t[2]) for t in corners], dtype=np.int64).reshape(-1, 3)
    vertices.flags.writeable = triangles.flags.writeable = False
    return vertices, triangles
