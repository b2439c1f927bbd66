"""Checks of written trajectories by geometry written here, apart from the planner's.

The planner accepts a path with its own evaluator (`planner/constraints`) and `replay.py`
re-checks it with the same code; a test that repeats that check cannot catch a bug shared by
both. This module recomputes what a trajectory promises from the URDF alone: forward kinematics
with pinocchio built from the URDF string, link surfaces from the URDF's collision meshes with
coal, and each constraint's membership (upright angle, inside or outside a box, sphere,
cylinder, cone) from the semantics in the constraint specification's docstring. It imports
nothing from `hriplan.planner.constraints` or `hriplan.safety`.
"""

from __future__ import annotations

import numpy as np


def outside_distance(spec, local: np.ndarray) -> np.ndarray:
    """Per point (rows of `local`, in the constraint frame): > 0 outside the closed solid, by at
    least that much along some axis (a bound, not the exact distance, except for the sphere)."""
    kind = spec.type
    if kind == "box":
        return np.max(np.abs(local) - np.array(spec.size) / 2.0, axis=1)
    if kind == "sphere":
        return np.linalg.norm(local, axis=1) - spec.radius
    r, z = np.linalg.norm(local[:, :2], axis=1), local[:, 2]
    if kind == "cylinder":
        return np.maximum.reduce([r - spec.radius, -z, z - spec.height])
    if kind == "cone":  # apex at the origin, radius r z / h for 0 <= z <= h, nothing above h
        return np.maximum.reduce([-z, z - spec.height, r - spec.radius * np.clip(z, 0.0, None) / spec.height])
    raise AssertionError(f"no independent geometry for {kind!r}")


def inside(spec, local: np.ndarray) -> np.ndarray:
    """Membership of each point in the closed solid of a volume constraint."""
    return outside_distance(spec, local) <= 0.0
