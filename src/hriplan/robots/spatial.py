"""Poses: one pydantic model for every pose in hriplan, and its conversion to pinocchio SE3.

Orientation is given either as a quaternion (x, y, z, w) or as roll-pitch-yaw in the URDF
convention (R = Rz(yaw) * Ry(pitch) * Rx(roll)); never both.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pinocchio as pin
from pydantic import BaseModel, ConfigDict, field_validator, model_validator

QUATERNION_NORM_TOLERANCE = 1e-3
# A rigid transform to compose and invert (pinocchio's SE3): the one type for placing objects
# relative to each other, so modules above the robot model compose poses without pinocchio.
Transform = pin.SE3


def norm(v: np.ndarray) -> float:
    """np.linalg.norm of a vector, its arithmetic (the square root of the dot product) without
    its checks and dispatch (~4 us a call, on paths asked thousands of times)."""
    return math.sqrt(v.dot(v))


def cross(a: Sequence[float], b: Sequence[float]) -> tuple[float, float, float]:
    """a x b of two 3-vectors in scalars: the products and differences np.cross takes, so the
    same bits, without its ~20-30 us of set-up (goals and rules cross a few vectors a re-plan)."""
    a0, a1, a2 = a
    b0, b1, b2 = b
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


def _finite(values: tuple[float, ...], what: str) -> tuple[float, ...]:
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f"{what} must be finite numbers, got {list(values)}")
    return values


class Immutable(BaseModel):
    """A frozen model of immutable values only (numbers, strings, tuples of them): a deep copy of
    a model holding it shares it, since no one can change it in place. A scene is deep-copied
    whenever a checker is given it (its caller may change theirs later), a dozen times a
    re-plan: copying its poses and shapes was half of each copy (~50 us of ~85)."""

    model_config = ConfigDict(frozen=True)

    def __deepcopy__(self, memo: dict[int, object] | None = None) -> Immutable:
        return self


class Pose(Immutable):
    """A rigid transform: translation `xyz` (m) and orientation `quat_xyzw` or `rpy` (rad)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    quat_xyzw: tuple[float, float, float, float] | None = None
    rpy: tuple[float, float, float] | None = None

    @field_validator("xyz", "rpy")
    @classmethod
    def _check_finite(cls, v):
        return None if v is None else _finite(v, "pose values")

    @field_validator("quat_xyzw")
    @classmethod
    def _check_unit(cls, v):
        if v is None:
            return v
        _finite(v, "quaternion")
        norm = math.sqrt(sum(c * c for c in v))
        if abs(norm - 1.0) > QUATERNION_NORM_TOLERANCE:
            raise ValueError(f"quaternion {list(v)} is not a unit quaternion (norm {norm:.4f})")
        return tuple(c / norm for c in v)

    @model_validator(mode="after")
    def _one_orientation(self) -> Pose:
        if self.quat_xyzw is not None and self.rpy is not None:
            raise ValueError("give the orientation as quat_xyzw or rpy, not both")
        return self

    def rotation(self) -> np.ndarray:
        if self.quat_xyzw is not None:
            x, y, z, w = self.quat_xyzw
            return pin.Quaternion(w, x, y, z).toRotationMatrix()
        if self.rpy is not None:
            return pin.rpy.rpyToMatrix(*self.rpy)
        return np.eye(3)

    def se3(self) -> pin.SE3:
        return pin.SE3(self.rotation(), np.array(self.xyz, dtype=float))

    def matrix(self) -> np.ndarray:
        return self.se3().homogeneous

    @classmethod
    def from_se3(cls, placement: pin.SE3) -> Pose:
        q = pin.Quaternion(placement.rotation)
        return cls(xyz=tuple(placement.translation), quat_xyzw=(q.x, q.y, q.z, q.w))

    @classmethod
    def from_matrix(cls, matrix: np.ndarray) -> Pose:
        return cls.from_se3(pin.SE3(np.asarray(matrix, dtype=float)))
