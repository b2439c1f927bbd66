"""Shapes fitted to meshes, kept on disk between processes.

Fitting a robot's collision parts or a person's capsules reads every visual mesh (about a second
each, most of a CLI command's time), while the result changes only with the description, the mesh
package, the library versions and the fitting rules. Results are JSON under
`$XDG_CACHE_HOME/hriplan/` (default `~/.cache/hriplan/`), named by a hash of all of those, beside
the allowed-collision matrices (acm.py); a file that cannot be read is fitted again.
"""

from __future__ import annotations

import base64
import gzip
import hashlib
import json
import os
from collections.abc import Callable
from importlib.metadata import version
from pathlib import Path
from typing import Any

import coal
import numpy as np
import pinocchio as pin

from hriplan.files import write_atomically

# Fits shipped with hriplan (`tools/seed_fits.py` writes them), gzipped under the names the cache
# gives them: those that take long (a built-in robot's clearance sub-cells, ~25 s of CPU) are
# read from here on a machine that has not fitted them yet, instead of computed at a first use.
SEEDS = Path(__file__).parent / "data" / "fits"


def cache_dir() -> Path:
    return Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "hriplan"


def fit_versions() -> dict[str, str]:
    """What a fit depends on besides its key: the mesh package's, pinocchio's and coal's versions."""
    return {"example-robot-data": version("example-robot-data"), "pin": pin.__version__, "coal": coal.__version__}


def fit_name(kind: str, key: object) -> str:
    """The file name of `kind`'s fit for `key` with this mesh package and these pinocchio and
    coal versions."""
    text = repr((key, *fit_versions().values()))
    return f"{kind}-{hashlib.sha256(text.encode()).hexdigest()[:16]}.json"


def cached_fit(kind: str, key: object, fit: Callable[[], dict[str, Any]]) -> dict[str, Any]:
    """`fit()`'s JSON-able result for `key` (anything with a stable repr), from disk if fitted
    before with the same mesh package and pinocchio/coal versions, or shipped (`SEEDS`)."""
    name = fit_name(kind, key)
    path = cache_dir() / name
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        pass
    try:
        result = json.loads(gzip.decompress((SEEDS / f"{name}.gz").read_bytes()))
    except (OSError, ValueError, EOFError):
        result = fit()
    write_atomically(path, json.dumps(result))
    return result


def array_data(points: np.ndarray) -> str:
    """An array of float64 as base64 text of its little-endian bytes: exact, and a person's hull
    vertices (about 25,000) read back in a millisecond where JSON numbers took some 40 ms."""
    return base64.b64encode(np.ascontiguousarray(points, dtype="<f8").tobytes()).decode("ascii")


def array(text: str, columns: int) -> np.ndarray:
    """The (n, columns) float64 array of `array_data`'s text."""
    return np.frombuffer(base64.b64decode(text), dtype="<f8").reshape(-1, columns).astype(float)


def se3_data(placement: pin.SE3) -> list[list[float]]:
    return placement.homogeneous.tolist()


def se3(data: list[list[float]]) -> pin.SE3:
    matrix = np.asarray(data, dtype=float)
    return pin.SE3(matrix[:3, :3], matrix[:3, 3])


def shape_data(shape: coal.CollisionGeometry) -> dict[str, Any]:
    """A primitive as JSON: capsule, cylinder, box or sphere."""
    if isinstance(shape, coal.Capsule):
        return {"type": "capsule", "radius": shape.radius, "length": 2.0 * shape.halfLength}
    if isinstance(shape, coal.Cylinder):
        return {"type": "cylinder", "radius": shape.radius, "length": 2.0 * shape.halfLength}
    if isinstance(shape, coal.Box):
        return {"type": "box", "size": (2.0 * np.asarray(shape.halfSide)).tolist()}
    if isinstance(shape, coal.Sphere):
        return {"type": "sphere", "radius": shape.radius}
    raise TypeError(f"cannot keep a {type(shape).__name__} as a fitted shape")


def shape(data: dict[str, Any]) -> coal.CollisionGeometry:
    kind = data["type"]
    if kind == "capsule":
        return coal.Capsule(data["radius"], data["length"])
    if kind == "cylinder":
        return coal.Cylinder(data["radius"], data["length"])
    if kind == "box":
        return coal.Box(*data["size"])
    return coal.Sphere(data["radius"])
