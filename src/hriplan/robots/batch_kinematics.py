"""Forward kinematics with velocities for many configurations at once, in numpy.

Why: pinocchio computes one configuration per call, and the ISO/TS 15066 monitor asks for the
joints that carry the moved parts at every point of a path (hundreds at a time): reading each
placement and velocity back from pinocchio's data in Python cost twenty times the kinematics
itself. Here the serial chains are walked once for all configurations: each joint's placement
in its parent times its own motion (revolute, continuous or prismatic, about any axis), the
world velocities carried along. A chain holding another kind of joint (free-flyer, planar,
spherical, ...) is computed by pinocchio one configuration at a time, with the same result.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import pinocchio as pin

from hriplan.robots.kernel_switch import kernels_on


@dataclass(frozen=True)
class Frames:
    """The asked joints' world frames over N configurations: rotations (N, F, 3, 3), origins,
    and the origins' linear and the bodies' angular velocities (N, F, 3)."""

    rotation: np.ndarray
    origin: np.ndarray
    linear: np.ndarray
    angular: np.ndarray


@dataclass(frozen=True)
class _Joint:
    parent: int  # index into the walk (-1: the world)
    rotation: np.ndarray  # (3, 3) placement in the parent's frame
    translation: np.ndarray  # (3,)
    axis: np.ndarray  # (3,) unit, in the joint's frame
    turns: bool  # revolute (else prismatic)
    idx_q: int
    nq: int  # 2: a continuous joint given as (cos, sin)
    idx_v: int
    along: np.ndarray  # (3, 3) a a^T, a the axis: what a rotation about it keeps
    across: np.ndarray  # (3, 3) I - a a^T
    cross: np.ndarray  # (3, 3) [a]x


class BatchKinematics:
    """The world frames and velocities of `joints` of `model`, for many configurations at once."""

    def __init__(self, model: pin.Model, joints: Collection[int]) -> None:
        self.model, self.joints = model, list(joints)
        chain = sorted({j for joint in self.joints for j in model.supports[joint] if j > 0})
        neutral = pin.neutral(model)
        walk = [_joint(model, j, chain.index(model.parents[j]) if model.parents[j] > 0 else -1, neutral) for j in chain]
        self._walk = None if any(joint is None for joint in walk) else walk
        self._asked = [chain.index(j) for j in self.joints]
        self._data = model.createData()

    def __call__(self, qs: np.ndarray, dqs: np.ndarray) -> Frames:
        """At configurations `qs` (N, nq) moving with joint velocities `dqs` (N, nv)."""
        if self._walk is None:
            return self._one_by_one(qs, dqs)
        if kernels_on():
            return self._compiled(qs, dqs)
        return Frames(*self._walked(qs, dqs))

    def placements(self, qs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The rotations (N, F, 3, 3) and origins (N, F, 3) alone, at configurations `qs`: the
        same numbers as `__call__`'s, without the velocities' walk (a distance bound needs none)."""
        if self._walk is None:
            frames = self(qs, np.zeros((len(qs), self.model.nv)))
            return frames.rotation, frames.origin
        if kernels_on():  # C-contiguous, as the kernels read them
            from hriplan.robots.certifier_kernels import place_many  # numba: imported with the kernels on

            rows, ints, _ = self._walk_tables
            rotation, origin = np.empty((len(qs), len(self.joints), 3, 3)), np.empty((len(qs), len(self.joints), 3))
            place_many(np.ascontiguousarray(qs, dtype=float), rows, ints, self._asked_rows, rotation, origin)
            return rotation, origin
        rotation, origin, _, _ = self._walked(qs, None)
        return rotation, origin

    @cached_property
    def _walk_tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The walk as the compiled code reads it (`kernel_fk.walk_tables`), made when first asked."""
        from hriplan.robots.kernel_fk import walk_tables

        return walk_tables(self._walk)

    @cached_property
    def _asked_rows(self) -> np.ndarray:
        """The asked joints' rows in `_walk_tables` (the world first)."""
        return np.array([k + 1 for k in self._asked], dtype=np.int64)

    def _compiled(self, qs: np.ndarray, dqs: np.ndarray) -> Frames:
        """The walk in compiled code (`certifier_kernels.walk_frames`), state by state: the numpy
        walk's passes over (N, 3, 3) arrays cost ~50 us a joint, ten times the arithmetic."""
        from hriplan.robots.certifier_kernels import walk_frames  # numba: imported with the kernels on

        rows, ints, idx_v = self._walk_tables
        n, size = len(qs), len(rows)
        rotation, origin = np.empty((n, size, 3, 3)), np.empty((n, size, 3))
        linear, angular = np.empty((n, size, 3)), np.empty((n, size, 3))
        qs, dqs = np.ascontiguousarray(qs, dtype=float), np.ascontiguousarray(dqs, dtype=float)
        walk_frames(qs, dqs, rows, ints, idx_v, rotation, origin, linear, angular)
        asked = self._asked_rows
        return Frames(rotation[:, asked], origin[:, asked], linear[:, asked], angular[:, asked])

    def _walked(
        self, qs: np.ndarray, dqs: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None]:
        """The walk down the chains: rotations, origins and (unless `dqs` is None) linear and
        angular velocities of the asked joints."""
        n, moves = len(qs), dqs is not None
        rotation, origin = np.empty((n, len(self._walk), 3, 3)), np.empty((n, len(self._walk), 3))
        linear, angular = (np.empty_like(origin), np.empty_like(origin)) if moves else (None, None)
        for k, joint in enumerate(self._walk):
            if joint.parent < 0:
                place, offset = np.broadcast_to(joint.rotation, (n, 3, 3)), np.broadcast_to(joint.translation, (n, 3))
                spin, moving, at = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
            else:
                up = rotation[:, joint.parent]
                place, at = up @ joint.rotation, origin[:, joint.parent]
                offset = at + up @ joint.translation
                if moves:
                    spin, moving = angular[:, joint.parent], linear[:, joint.parent]
            axis = place @ joint.axis  # the world axis: a joint's own motion leaves it fixed
            if joint.turns:
                cos, sin = _angle(qs, joint)
                rotation[:, k] = place @ _rotation(joint, cos, sin)
                origin[:, k] = offset
                if moves:
                    angular[:, k] = spin + axis * dqs[:, joint.idx_v, None]
                    linear[:, k] = moving + cross(spin, offset - at)
            else:
                rotation[:, k] = place
                origin[:, k] = offset + axis * qs[:, joint.idx_q, None]
                if moves:
                    angular[:, k] = spin
                    linear[:, k] = moving + cross(spin, origin[:, k] - at) + axis * dqs[:, joint.idx_v, None]
        asked = self._asked
        if not moves:
            return rotation[:, asked], origin[:, asked], None, None
        return rotation[:, asked], origin[:, asked], linear[:, asked], angular[:, asked]

    def _one_by_one(self, qs: np.ndarray, dqs: np.ndarray) -> Frames:
        """pinocchio per configuration (a chain with a joint the walk does not know)."""
        n, f = len(qs), len(self.joints)
        frames, twists = np.empty((n, f, 4, 4)), np.empty((n, f, 6))
        model, data = self.model, self._data
        for i, (q, dq) in enumerate(zip(qs, dqs)):
            pin.forwardKinematics(model, data, q, dq)
            for k, j in enumerate(self.joints):
                frames[i, k], twists[i, k] = data.oMi[j].homogeneous, data.v[j].vector
        rotation = frames[..., :3, :3]
        # data.v is the joint's spatial velocity in its own frame: rotate it to the world.
        linear, angular = (rotation @ twists[..., :3, None])[..., 0], (rotation @ twists[..., 3:, None])[..., 0]
        return Frames(rotation, frames[..., :3, 3], linear, angular)


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b over the last axis (same shapes), the products and differences np.cross takes, so
    the same numbers, without its ~20 us of set-up per call (a walk crosses once per joint)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def _joint(model: pin.Model, j: int, parent: int, neutral: np.ndarray) -> _Joint | None:
    """Joint `j` for the walk, or None if it is not a one-axis revolute or prismatic joint."""
    joint = model.joints[j]
    if joint.nv != 1 or joint.nq not in (1, 2):
        return None
    data = joint.createData()
    joint.calc(data, neutral)
    motion = np.array(data.S).reshape(6)  # (linear, angular) of its one degree of freedom
    turns = bool(np.linalg.norm(motion[3:]) > 0.0)
    if turns == bool(np.linalg.norm(motion[:3]) > 0.0) or (joint.nq == 2 and not turns):
        return None  # a screw (both parts) or none: not walked here
    placement = model.jointPlacements[j]
    axis = motion[3:] if turns else motion[:3]
    a = axis / np.linalg.norm(axis)
    along = np.outer(a, a)
    cross = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return _Joint(
        parent,
        placement.rotation.copy(),
        placement.translation.copy(),
        a,
        turns,
        joint.idx_q,
        joint.nq,
        joint.idx_v,
        along,
        np.eye(3) - along,
        cross,
    )


def _angle(qs: np.ndarray, joint: _Joint) -> tuple[np.ndarray, np.ndarray]:
    """(cos, sin) of a revolute joint's angle, each (N,): a continuous joint stores them."""
    if joint.nq == 2:
        return qs[:, joint.idx_q], qs[:, joint.idx_q + 1]
    angle = qs[:, joint.idx_q]
    return np.cos(angle), np.sin(angle)


def _rotation(joint: _Joint, cos: np.ndarray, sin: np.ndarray) -> np.ndarray:
    """Rotations about the joint's unit axis by angles given as cos and sin (N,): (N, 3, 3), as
    Rodrigues' a a^T + cos (I - a a^T) + sin [a]x."""
    return joint.along + cos[:, None, None] * joint.across + sin[:, None, None] * joint.cross
