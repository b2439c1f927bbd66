"""robots/mesh_arrays.py: a coal mesh's vertices and triangles, read once and shared read-only."""

import coal
import numpy as np
import pytest

from hriplan.robots.mesh_arrays import mesh_arrays


def test_a_mesh_reads_back_as_built_once_and_read_only():
    rng = np.random.default_rng(3)
    vertices = rng.normal(size=(40, 3))
    triangles = rng.integers(0, 40, size=(25, 3))
    mesh = coal.BVHModelOBBRSS()
    mesh.beginModel(len(triangles), len(vertices))
    mesh.addVertices(vertices)
    mesh.addTriangles(triangles)
    mesh.endModel()
    read, corners = mesh_arrays(mesh)
    assert np.array_equal(read, vertices) and np.array_equal(corners, triangles) and corners.dtype == np.int64
    again = mesh_arrays(mesh)
    assert again[0] is read and again[1] is corners
    with pytest.raises(ValueError):
        corners[0, 0] = 1
