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


def _mesh(vertices: np.ndarray, triangles: np.ndarray) -> coal.BVHModelOBBRSS:
    mesh = coal.BVHModelOBBRSS()
    mesh.beginModel(len(triangles), len(vertices))
    mesh.addVertices(vertices)
    mesh.addTriangles(triangles)
    mesh.endModel()
    return mesh


def test_a_mesh_gone_leaves_its_arrays_to_no_other_mesh():
    """Kept by the mesh's address: the mesh is kept alive with its arrays, so a mesh made after
    another was dropped never finds the dropped one's arrays (without the keeping, coal hands out
    the freed address again within a few meshes)."""
    rng = np.random.default_rng(4)
    for k in range(20):
        vertices = rng.normal(size=(6, 3))
        triangles = np.array([[0, 1, 2], [3, 4, 5]]) if k % 2 else np.array([[0, 1, 2]])
        read, corners = mesh_arrays(_mesh(vertices, triangles))  # the mesh is dropped at once
        assert np.array_equal(read, vertices) and np.array_equal(corners, triangles)


def test_the_robots_of_one_description_share_their_mesh_arrays_trees_and_pieces(monkeypatch):
    """A hand's new posture is a new robot (a release's retreat), and MADAR's arms carry the same
    seven meshes: what is made from a mesh is made once for all of them."""
    from hriplan.robots import free_certifier, mesh_pairs
    from hriplan.robots import mesh_arrays as arrays
    from hriplan.robots.collision import CollisionChecker
    from hriplan.robots.model import load_robot

    for module, name in ((arrays, "_READ"), (free_certifier, "_PIECES"), (mesh_pairs, "_TREES")):
        monkeypatch.setattr(module, name, {})
    closed, opened = (CollisionChecker(load_robot("madar", {"left": p, "right": p})) for p in ("power", "open"))
    meshes = [
        [g for g in c.geom_model.geometryObjects if g.name.endswith("fore_arm_link (mesh)")] for c in (closed, opened)
    ]
    assert [g.name for g in meshes[0]] == ["left_fore_arm_link (mesh)", "right_fore_arm_link (mesh)"]
    pieces = [free_certifier._pieces_of(g) for g in meshes[0] + meshes[1]]
    trees = [mesh_pairs.MeshTree.of(g.geometry) for g in meshes[0] + meshes[1]]
    assert all(p is pieces[0] for p in pieces) and all(t is trees[0] for t in trees)
    assert len(arrays._READ) == len(free_certifier._PIECES) == len(mesh_pairs._TREES) == 1
    assert len(trees[0].triangles) == meshes[1][1].geometry.num_tris == 1050
