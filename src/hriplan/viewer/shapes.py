"""meshcat geometry for hriplan's shapes, with URDF axes and compact mesh buffers.

- Meshes are sent as indexed triangle buffers (float32 positions, 16-bit indices when they fit)
  taken from the geometry pinocchio already loaded: about a sixth of the size of the UR5's COLLADA
  text, and the same triangles the collision code sees. Materials shade them flat, so no
  normals are sent.
- three.js cylinders and cones have their axis along y; URDF and coal put it along z. Each part
  therefore carries a local transform that turns y into z.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import coal
import meshcat.geometry as mg
import numpy as np
import pinocchio as pin
import umsgpack

from hriplan.robots.mesh_arrays import mesh_arrays

Y_TO_Z = pin.SE3(pin.rpy.rpyToMatrix(math.pi / 2, 0.0, 0.0), np.zeros(3)).homogeneous
_UINT16_EXT, _UINT32_EXT, _FLOAT32_EXT = 0x14, 0x16, 0x17  # msgpack-lite's typed-array codes


def _packed(array: np.ndarray, item_size: int) -> dict:
    kinds = {
        np.dtype("<f4"): ("Float32Array", _FLOAT32_EXT),
        np.dtype("<u2"): ("Uint16Array", _UINT16_EXT),
        np.dtype("<u4"): ("Uint32Array", _UINT32_EXT),
    }
    name, code = kinds[array.dtype]
    return {"itemSize": item_size, "type": name, "array": umsgpack.Ext(code, array.tobytes()), "normalized": False}


class IndexedMesh(mg.Geometry):
    """A triangle mesh as a three.js BufferGeometry with an index (shared vertices)."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        super().__init__()
        self.vertices = np.ascontiguousarray(vertices, dtype="<f4")
        index_type = "<u2" if len(vertices) < 2**16 else "<u4"
        self.faces = np.ascontiguousarray(faces, dtype=index_type)

    def lower(self, object_data: dict) -> dict:
        return {
            "uuid": self.uuid,
            "type": "BufferGeometry",
            "data": {
                "attributes": {"position": _packed(self.vertices.ravel(), 3)},
                "index": _packed(self.faces.ravel(), 1),
            },
        }


class Frustum(mg.Geometry):
    """three.js CylinderGeometry with every option: cones (a zero radius), open ends, sectors."""

    def __init__(
        self,
        height: float,
        radius_top: float,
        radius_bottom: float,
        open_ended: bool = False,
        theta_start: float = 0.0,
        theta_length: float = 2 * math.pi,
        segments: int = 48,
    ) -> None:
        super().__init__()
        self.params = {
            "height": height,
            "radiusTop": radius_top,
            "radiusBottom": radius_bottom,
            "radialSegments": segments,
            "heightSegments": 1,
            "openEnded": open_ended,
            "thetaStart": theta_start,
            "thetaLength": theta_length,
        }

    def lower(self, object_data: dict) -> dict:
        return {"uuid": self.uuid, "type": "CylinderGeometry", **self.params}


@dataclass(frozen=True)
class Part:
    """One drawable piece of a shape and its pose in the shape's frame."""

    geometry: mg.Geometry
    local: np.ndarray  # 4x4


def translation(xyz: tuple[float, float, float] | np.ndarray) -> np.ndarray:
    matrix = np.eye(4)
    matrix[:3, 3] = xyz
    return matrix


def parts(shape: coal.CollisionGeometry) -> list[Part]:
    """Drawable parts of a coal shape (what pinocchio and the scene's `geometry()` give)."""
    if isinstance(shape, coal.BVHModelBase):
        return [Part(IndexedMesh(*mesh_arrays(shape)), np.eye(4))]
    if isinstance(shape, coal.Box):
        return [Part(mg.Box(list(2.0 * shape.halfSide)), np.eye(4))]
    if isinstance(shape, coal.Sphere):
        return [Part(mg.Sphere(shape.radius), np.eye(4))]
    if isinstance(shape, coal.Cylinder):
        return [Part(Frustum(2 * shape.halfLength, shape.radius, shape.radius), Y_TO_Z)]
    if isinstance(shape, coal.Cone):  # coal: base at -h/2, apex at +h/2
        return [Part(Frustum(2 * shape.halfLength, 0.0, shape.radius), Y_TO_Z)]
    if isinstance(shape, coal.Capsule):
        half = shape.halfLength
        return [
            Part(Frustum(2 * half, shape.radius, shape.radius, open_ended=True), Y_TO_Z),
            Part(mg.Sphere(shape.radius), translation((0.0, 0.0, half))),
            Part(mg.Sphere(shape.radius), translation((0.0, 0.0, -half))),
        ]
    raise TypeError(f"cannot draw a {type(shape).__name__}")


def tube(points: np.ndarray, radius: float, sides: int = 8) -> IndexedMesh | None:
    """A tube along a polyline: WebGL draws lines one pixel wide, too thin to follow a path."""
    keep = np.r_[True, np.linalg.norm(np.diff(points, axis=0), axis=1) > 1e-6]
    points = points[keep]
    if len(points) < 2:
        return None
    tangents = np.gradient(points, axis=0)
    tangents /= np.linalg.norm(tangents, axis=1, keepdims=True)
    reference = np.where(np.abs(tangents[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    normal = np.cross(tangents, reference)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    binormal = np.cross(tangents, normal)
    angles = np.linspace(0.0, 2 * np.pi, sides, endpoint=False)
    rings = points[:, None] + radius * (
        np.cos(angles)[None, :, None] * normal[:, None] + np.sin(angles)[None, :, None] * binormal[:, None]
    )
    k, s = np.meshgrid(np.arange(len(points) - 1), np.arange(sides), indexing="ij")
    a, b = k * sides + s, k * sides + (s + 1) % sides
    faces = np.concatenate([np.stack([a, b, a + sides], -1), np.stack([b, b + sides, a + sides], -1)]).reshape(-1, 3)
    return IndexedMesh(rings.reshape(-1, 3), faces)


def beads(points: np.ndarray, radius: float) -> IndexedMesh:
    """A small octahedron at every point, as one mesh."""
    corners = radius * np.vstack([np.eye(3), -np.eye(3)])  # +x +y +z -x -y -z
    octahedron = np.array([[0, 1, 2], [1, 3, 2], [3, 4, 2], [4, 0, 2], [1, 0, 5], [3, 1, 5], [4, 3, 5], [0, 4, 5]])
    vertices = (points[:, None] + corners[None]).reshape(-1, 3)
    faces = (octahedron[None] + 6 * np.arange(len(points))[:, None, None]).reshape(-1, 3)
    return IndexedMesh(vertices, faces)
