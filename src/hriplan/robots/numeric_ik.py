"""Numeric IK for any serial arm: damped least squares on pinocchio, with random restarts.

A closed form exists only for a few arms (the UR family, robots/ik.py); every other arm is
solved here. Levenberg-Marquardt steps (damping grows with the squared error, as in Sugihara's
method: long steps far away are tamed, and near a solution it converges quadratically), no joint
moving more than a radian per step, clamped to the joint limits; a start that stalls (a limit,
a singularity, a far branch) is replaced by a random one within the limits. Measured on
example-robot-data's Panda and UR10 (benchmarks/REPORT-ik.md): >= 99 % of reachable poses,
in a median of about a millisecond.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

DAMPING = 1e-6  # plus the squared error (m^2 + rad^2)
MAX_STEP = 1.0  # rad (or m) per joint and iteration
MAX_ITERATIONS = 80
RESTARTS = 30  # after the first start; most targets need none (REPORT-ik.md)
STALL_RATIO = 0.999  # an iteration that does not shrink the error by this factor counts as a stall
STALLS = 8
IDENTITY = np.eye(6)


@dataclass
class Chain:
    """What a solve needs of one arm in the planning model: its tool frame and joint indices."""

    model: pin.Model
    data: pin.Data
    frame: int
    idx_q: np.ndarray
    idx_v: np.ndarray
    lower: np.ndarray
    upper: np.ndarray


def _error(chain: Chain, q: np.ndarray, target: np.ndarray, axis: int | None) -> tuple[np.ndarray, np.ndarray]:
    """The 6-vector from the tool pose to the target (world axes) and its 6 x n Jacobian. With a
    free axis only that axis's direction counts: rotation about it is projected out."""
    # reshaped: a model with one velocity gets a 6-vector from eigenpy, not a 6 x 1 matrix
    full = pin.computeFrameJacobian(chain.model, chain.data, q, chain.frame, pin.LOCAL_WORLD_ALIGNED).reshape(6, -1)
    jac = full[:, chain.idx_v]
    pose = chain.data.oMf[chain.frame]
    position = target[:3, 3] - pose.translation
    if axis is None:
        return np.concatenate([position, pin.log3(target[:3, :3] @ pose.rotation.T)]), jac
    a, goal = pose.rotation[:, axis], target[:3, axis]
    cross = np.cross(a, goal)
    sine = np.linalg.norm(cross)
    angle = math.atan2(sine, float(a @ goal))
    rotation = cross * (angle / sine) if sine > 1e-12 else np.zeros(3)
    if sine <= 1e-12 and angle > 1.0:  # exactly opposite: turn about any perpendicular axis
        rotation = np.cross(a, np.eye(3)[np.argmin(np.abs(a))]) * angle
    projected = jac.copy()
    projected[3:] -= np.outer(a, a @ jac[3:])
    return np.concatenate([position, rotation]), projected


def _descend(chain: Chain, q: np.ndarray, target: np.ndarray, axis: int | None, tolerance: float) -> np.ndarray | None:
    """Damped least squares from `q` (a full configuration, changed in place) to the target."""
    best, stalls = math.inf, 0
    for _ in range(MAX_ITERATIONS):
        error, jac = _error(chain, q, target, axis)
        squared = float(error @ error)
        if squared < tolerance**2:
            return q
        stalls = stalls + 1 if squared > STALL_RATIO * best else 0
        if stalls >= STALLS:
            return None
        best = min(best, squared)
        step = jac.T @ np.linalg.solve(jac @ jac.T + (DAMPING + squared) * IDENTITY, error)
        largest = np.abs(step).max()
        if largest > MAX_STEP:
            step *= MAX_STEP / largest
        q[chain.idx_q] = np.minimum(np.maximum(q[chain.idx_q] + step, chain.lower), chain.upper)
    return None


def solutions(
    chain: Chain,
    base_q: np.ndarray,
    target: np.ndarray,
    axis: int | None,
    seed: np.ndarray,
    tolerance: float,
    rng: np.random.Generator,
    restarts: int = RESTARTS,
) -> Iterator[np.ndarray]:
    """Arm values (group order) reaching the target, from `seed` and then from random starts within
    the limits, as they are found: a caller stops when one suits it (a collision check)."""
    starts = [np.clip(seed, chain.lower, chain.upper)]
    for k in range(restarts + 1):
        start = starts[k] if k < len(starts) else rng.uniform(chain.lower, chain.upper)
        q = base_q.copy()
        q[chain.idx_q] = start
        reached = _descend(chain, q, target, axis, tolerance)
        if reached is not None:
            yield reached[chain.idx_q].copy()
