"""A meshcat scene under construction: commands, shared meshes and animation tracks.

Commands are meshcat's own (`SetObject`, `SetTransform`, `SetProperty`, `SetAnimation`), so the
bundled client plays them as it would from a server. One addition: a mesh drawn again (the second
UR5 arm, the fingers, a person's left and right limbs) is not sent twice but listed as a clone of
the first, which the page copies in the browser (three.js shares the geometry).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence

import meshcat.geometry as mg
import numpy as np
import pinocchio as pin
import umsgpack
from meshcat.animation import Animation, AnimationClip, AnimationTrack
from meshcat.commands import SetAnimation, SetObject, SetProperty, SetTransform
from meshcat.path import Path

from hriplan.viewer.shapes import IndexedMesh, Part


def material(color: int, opacity: float = 1.0, **properties: object) -> mg.MeshPhongMaterial:
    """Phong material with flat shading (meshes carry no normals); see-through below opacity 1."""
    if opacity < 1.0:
        properties.setdefault("depthWrite", False)  # volumes never hide what lies inside them
    return mg.MeshPhongMaterial(color=color, opacity=opacity, flatShading=True, **properties)


def rgba_color(rgba: Sequence[float]) -> tuple[int, float]:
    """(0xRRGGBB, opacity) from an RGBA colour in [0, 1]."""
    r, g, b = (int(round(255 * float(c))) for c in rgba[:3])
    return (r << 16) | (g << 8) | b, float(rgba[3])


def _mesh_key(part: Part, look: mg.Material) -> tuple[bytes, str] | None:
    """What makes two mesh drawings the same: their triangles and their look."""
    if not isinstance(part.geometry, IndexedMesh):
        return None
    triangles = hashlib.sha1(part.geometry.vertices.tobytes() + part.geometry.faces.tobytes()).digest()
    return triangles, json.dumps({k: v for k, v in look.lower({}).items() if k != "uuid"}, sort_keys=True)


def _y_up(point: np.ndarray) -> list[float]:
    """The client's camera and orbit controls live in three.js's y-up frame: (x, y, z) is (x, z, -y)."""
    return [float(point[0]), float(point[2]), float(-point[1])]


def _path(path: str) -> Path:
    return Path(tuple(p for p in path.split("/") if p))


class Drawing:
    """meshcat commands in the order the page plays them, plus what meshcat cannot say itself."""

    def __init__(self) -> None:
        self.commands: list[object] = []
        self.clones: list[tuple[str, str]] = []  # (drawn object's path, path of its copy)
        self._drawn: dict[tuple[bytes, str], str] = {}
        self._clips: dict[Path, AnimationClip] = {}
        self.camera: dict[str, object] = {}  # for the page: meshcat has no command to aim the camera

    # -- static content ------------------------------------------------------------------------
    def draw(self, path: str, parts: Sequence[Part], look: mg.Material) -> None:
        """Draw a shape's parts under `path` (whose transform places the shape).

        A mesh already drawn with the same look is cloned from its first drawing, not sent again."""
        for i, part in enumerate(parts):
            sub = f"{path}/{i}" if len(parts) > 1 or not np.allclose(part.local, np.eye(4)) else path
            if sub != path:
                self.place(sub, part.local)
            key = _mesh_key(part, look)
            if key in self._drawn:
                self.clones.append((self._drawn[key], sub))
                continue
            if key is not None:
                self._drawn[key] = sub
            self.commands.append(SetObject(part.geometry, look, _path(sub)))

    def place(self, path: str, matrix: np.ndarray | pin.SE3) -> None:
        matrix = matrix.homogeneous if isinstance(matrix, pin.SE3) else np.asarray(matrix, dtype=float)
        self.commands.append(SetTransform(matrix, _path(path)))

    def set(self, path: str, key: str, value: object) -> None:
        self.commands.append(SetProperty(key, value, _path(path)))

    def look(self, eye: np.ndarray, target: np.ndarray, fov: float) -> None:
        """Start the view at `eye` looking at `target` (world, m) with a vertical field of view (deg)."""
        self.camera = {"eye": _y_up(eye), "target": _y_up(target), "fov": float(fov)}

    # -- animation -----------------------------------------------------------------------------
    def animate(self, path: str, prop: str, values: Sequence[Sequence[float]]) -> None:
        """One key per animation frame for `position`, `quaternion` (x, y, z, w) or `scale`."""
        clip = self._clips.setdefault(_path(path), AnimationClip())
        kind = "quaternion" if prop == "quaternion" else "vector3"
        rows = [[float(v) for v in value] for value in values]
        clip.tracks[prop] = AnimationTrack(prop, kind, list(range(len(rows))), rows)

    def animate_poses(self, path: str, poses: Sequence[pin.SE3]) -> None:
        self.animate(path, "position", [p.translation for p in poses])
        self.animate(path, "quaternion", [pin.Quaternion(p.rotation).coeffs() for p in poses])  # x, y, z, w

    def finish_animation(self, fps: float) -> None:
        """Queue the animation (frames `fps` apart); it plays once when the page opens.

        Once, not looping: a looping clip shows its first frame at its very end, so the time
        slider (and #t=) at the end would show the start."""
        if not self._clips:
            return
        for clip in self._clips.values():
            clip.fps = fps
        self.commands.append(SetAnimation(Animation(self._clips), play=True, repetitions=1))

    def packed(self) -> list[bytes]:
        """Every command as meshcat's msgpack message (floats as float32: positions to 0.1 um)."""
        return [umsgpack.packb(c.lower(), force_float_precision="single") for c in self.commands]
