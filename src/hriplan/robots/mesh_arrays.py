"""A coal mesh's vertices and triangles as numpy arrays, read once per mesh.

Why: coal gives a mesh's triangles one Python call at a time (~1.5 us each: ~8 ms for a mesh of
a few thousand); the clearance tables, the mesh pairs' box trees, the certifier's capsule trees
and the viewer each read them, and MADAR's first plan read its meshes three times over.
"""

from __future__ import annotations

import coal
import numpy as np

# By mesh: its id, the mesh kept alive with its arrays so that no other takes the id.
_READ: dict[int, tuple[coal.BVHModelBase, np.ndarray, np.ndarray]] = {}


def mesh_arrays(mesh: coal.BVHModelBase) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V, 3) and triangles (T, 3: vertex indices, int64) of a loaded coal mesh, in its
    own frame; read-only (shared by every caller)."""
    if id(mesh) not in _READ:
        vertices = np.array(mesh.vertices(), dtype=float).reshape(-1, 3)
        corners = (mesh.tri_indices(k) for k in range(mesh.num_tris))
        triangles = np.array([(t[0], t[1], t[2]) for t in corners], dtype=np.int64).reshape(-1, 3)
        vertices.flags.writeable = triangles.flags.writeable = False
        _READ[id(mesh)] = (mesh, vertices, triangles)
    return _READ[id(mesh)][1:]
