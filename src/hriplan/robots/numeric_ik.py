"""Numeric IK for any serial arm: damped least squares on pinocchio, with restarts.

A closed form exists only for a few arms (the UR family, robots/ik.py); every other arm is
solved here. Levenberg-Marquardt steps (damping grows with the squared error, as in Sugihara's
method: long steps far away are tamed, and near a solution it converges quadratically), no joint
moving more than a radian per step, a joint at a limit the step would push it past left out of
the step (`_step`); a start that stalls (a local minimum at the limits, a singularity, a far
branch) is replaced by a random one within the limits, drawn from the target. Measured on
example-robot-data's Panda, UR10, UR5, TALOS's and TIAGo Pro's arms (benchmarks/REPORT-ik.md)."""

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
    a = pose.rotation[:, axis]
    projected = jac.copy()
    projected[3:] -= np.outer(a, a @ jac[3:])
    return np.concatenate([position, swing(a, target[:3, axis])]), projected


def swing(a: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """The shortest turn (a rotation vector) taking unit direction `a` onto unit direction `goal`:
    no spin about either, so a frame turned by it keeps its rotation about that axis."""
    cross = np.cross(a, goal)
    sine = np.linalg.norm(cross)
    angle = math.atan2(sine, float(a @ goal))
    if sine > 1e-12:
        return cross * (angle / sine)
    if angle > 1.0:  # exactly opposite: turn about any perpendicular axis
        perpendicular = np.cross(a, np.eye(3)[np.argmin(np.abs(a))])
        return perpendicular / np.linalg.norm(perpendicular) * angle
    return np.zeros(3)


def _descend(
    chain: Chain, q: np.ndarray, target: np.ndarray, axis: int | None, tolerance: float, rows: int
) -> np.ndarray | None:
    """Damped least squares from `q` (a full configuration, changed in place) to the target (its
    first `rows` error rows: 3 asks for the position alone)."""
    best, stalls = math.inf, 0
    for _ in range(MAX_ITERATIONS):
        error, jac = _error(chain, q, target, axis)
        error, jac = error[:rows], jac[:rows]
        squared = float(error @ error)
        if squared < tolerance**2:
            return q
        stalls = stalls + 1 if squared > STALL_RATIO * best else 0
        if stalls >= STALLS:
            return None
        best = min(best, squared)
        values = q[chain.idx_q]
        q[chain.idx_q] = np.minimum(
            np.maximum(values + _step(chain, values, jac, error, squared), chain.lower), chain.upper
        )
    return None


def _step(chain: Chain, values: np.ndarray, jac: np.ndarray, error: np.ndarray, squared: float) -> np.ndarray:
    """The damped least-squares step, solved again without each joint that it pushes past a limit
    it sits at: clamped afterwards, such a joint's share of the step would be lost (the descent
    then crawls along the limit, as TIAGo Pro's elbow did), so the free joints take it up."""
    diagonal = slice(None, None, len(error) + 1)
    at_lower, at_upper = values <= chain.lower, values >= chain.upper
    moving = jac
    for _ in range(len(values)):
        normal = moving @ moving.T
        normal.flat[diagonal] += DAMPING + squared  # the damping, without building an identity
        step = moving.T @ np.linalg.solve(normal, error)
        largest = np.abs(step).max()
        if largest > MAX_STEP:
            step *= MAX_STEP / largest
        # a joint already left out has a zero column, so a step of exactly 0: never blocked again
        blocked = (at_lower & (step < 0.0)) | (at_upper & (step > 0.0))
        if not blocked.any():
            break
        moving = moving * ~blocked
    return step


def attempts(
    chain: Chain,
    base_q: np.ndarray,
    target: np.ndarray,
    axis: int | None,
    seed: np.ndarray,
    tolerance: float,
    restarts: int = RESTARTS,
    position_only: bool = False,
) -> Iterator[np.ndarray | None]:
    """For each start in turn, `seed` and then random ones within the limits, the arm values
    (group order) it reaches the target (or only its position) with, or None: a caller counts
    the starts it pays for, and stops when a solution suits it (or when none can come).

    The starts are drawn from the target's own bytes: the same target gives the same answer, and
    one draw is not shared by every target (a draw that missed a region of poses near the limits
    failed all of them for one arm and none for its mirror image: TIAGo Pro, 9 of 90 mirrored
    poses solved by the left arm only, 1 by the right)."""
    rng = np.random.default_rng(np.frombuffer(np.ascontiguousarray(target, dtype=float).tobytes(), dtype=np.uint32))
    spread = rng.uniform(chain.lower, chain.upper, (restarts, len(seed)))
    for start in [np.clip(seed, chain.lower, chain.upper), *spread]:
        q = base_q.copy()
        q[chain.idx_q] = start
        reached = _descend(chain, q, target, axis, tolerance, 3 if position_only else 6)
        yield None if reached is None else reached[chain.idx_q].copy()
