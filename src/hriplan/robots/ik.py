"""Inverse kinematics, so goals can be given as tool poses, by the solver kind each arm's
description names (`ArmDescription.ik`): `numeric` (any serial arm, robots/numeric_ik.py) or an
analytic UR solver (`ur5_analytic`, `ur10e_analytic`, ...: `ANALYTIC_IK`).

`ur_analytic_ik` gives every closed-form UR branch (up to 8) in microseconds, for a flange pose
in its base frame with joint values that are ours. Where its frames sit in a robot's URDF is
measured once per arm (`_analytic_frames`): the DH base is the arm's base link turned about z
(by 0 for the MADAR description, by pi for ROS-Industrial's), the tool a fixed transform from the
flange; an arm it does not fit (another model, other joint signs) is refused. So a tool target
only has to be moved into the solver's base frame and back from tool to flange.
"""

from __future__ import annotations

import functools
import math
from collections import Counter
from collections.abc import Callable, Sequence

import numpy as np
import pinocchio as pin
import ur_analytic_ik
from pydantic import BaseModel

from hriplan import HriplanError
from hriplan.recent import Recent
from hriplan.robots import numeric_ik_search
from hriplan.robots.collision import ZONE_NAMING
from hriplan.robots.descriptions.description import IK_KINDS, NUMERIC_IK, UR_MODELS
from hriplan.robots.model import Robot
from hriplan.robots.spatial import norm

AXES = {"x": 0, "y": 1, "z": 2}
ORTHONORMAL_TOLERANCE = 1e-6
LAST_ROW = np.array([0.0, 0.0, 0.0, 1.0])
LAST_ROW_TOLERANCE = 1e-8 + 1e-5 * LAST_ROW  # np.allclose's atol + rtol * |expected|
_EYE3 = np.eye(3)
POLISH_ITERATIONS = 10
POLISH_DAMPING = 1e-6
TWO_PI = 2.0 * math.pi
# Per analytic IK kind an arm description names: the solver's module (forward_kinematics,
# inverse_kinematics: every closed-form solution for a flange pose in the solver's base frame).
ANALYTIC_IK = {f"{model}_analytic": getattr(ur_analytic_ik, model) for model in UR_MODELS}
DEFAULT_TOLERANCE = 1e-6  # m and rad
DISTINCT = 1e-3  # rad: numeric solutions closer than this in every joint are one solution
CALIBRATION_SAMPLES = 20
CALIBRATION_TOLERANCE = 1e-6  # m (and rotation-matrix entries): the solver's FK must be the URDF's


class IKResult(BaseModel):
    """Outcome of `solve_ik`; `q` is in the arm group's joint order, None on failure."""

    success: bool
    q: list[float] | None = None
    position_error: float = math.inf
    orientation_error: float = math.inf
    message: str


class _Arm:
    """What one solve needs about an arm: its group, frames and, for an analytic solver, where
    the solver's base and flange are (`_analytic_frames`)."""

    def __init__(self, robot: Robot, arm: str, base_q: np.ndarray | None) -> None:
        self.tool = robot.tool_frame(arm)
        self.group = robot.arm_group(arm)
        description = robot.description.arms[arm]
        self.kind = description.ik
        if self.kind not in IK_KINDS:
            raise HriplanError(
                f"the {arm} arm's IK solver {self.kind!r} is not supported; supported: {', '.join(IK_KINDS)}"
            )
        self.n = len(robot.group_indices(self.group))
        if base_q is None:
            self.base_q = robot.q_neutral.copy()
        else:
            self.base_q = _vector(base_q, robot.model.nq, "base_q")
        # Neither pose depends on this arm's joints: read them at any configuration.
        self.base = robot.frame_pose(description.base_link, self.base_q)
        self.shoulder = robot.frame_pose(description.joints[0], self.base_q)[:3, 3]
        if self.kind != NUMERIC_IK:
            self.solver = ANALYTIC_IK[self.kind]
            self.solver_base, self.flange_to_tool = _analytic_frames(robot, arm)


@functools.cache
def _analytic_frames(robot: Robot, arm: str) -> tuple[np.ndarray, np.ndarray]:
    """Where the arm's analytic solver sits in the robot (`fit_analytic`); an arm it does not
    fit is one line naming the arm."""
    description = robot.description.arms[arm]

    def relative_tool(values: np.ndarray) -> np.ndarray:
        q = robot.configuration(values, description.group)
        return np.linalg.inv(robot.frame_pose(description.base_link, q)) @ robot.frame_pose(description.tool_frame, q)

    try:
        return fit_analytic(description.ik, relative_tool, len(description.joints))
    except HriplanError as exc:
        raise HriplanError(f"the {arm} arm {exc}; use another analytic kind or ik: numeric") from None


def fit_analytic(kind: str, relative_tool: Callable[[np.ndarray], np.ndarray], n: int) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) with relative_tool(q) = A . FK_solver(q) . B for every q, `relative_tool` being the
    tool pose in the arm's base link: A a turn about the base's z (the DH base differs from a
    URDF's by such a turn), B found at q = 0, both checked on random configurations."""
    solver = ANALYTIC_IK[kind]
    if n != 6:
        raise HriplanError(f"has {n} joints; the {kind} solver is for 6")
    samples = np.random.default_rng(0).uniform(-math.pi, math.pi, (CALIBRATION_SAMPLES, n))
    zero, best = np.zeros(n), math.inf
    for quarter in range(4):
        turn = _spin(2, quarter * math.pi / 2)
        flange_to_tool = np.linalg.inv(solver.forward_kinematics(*zero)) @ np.linalg.inv(turn) @ relative_tool(zero)
        worst = max(
            np.abs(turn @ solver.forward_kinematics(*v) @ flange_to_tool - relative_tool(v)).max() for v in samples
        )
        if worst < CALIBRATION_TOLERANCE:
            return turn, flange_to_tool
        best = min(best, worst)
    raise HriplanError(f"does not match the {kind} solver (its forward kinematics differ by up to {best:.3g} m)")


def _vector(values: np.ndarray, size: int, what: str) -> np.ndarray:
    vec = np.asarray(values, dtype=float).ravel()
    if vec.shape != (size,) or not np.isfinite(vec).all():
        raise HriplanError(f"{what} must be {size} finite numbers, got {np.asarray(values).tolist()}")
    return vec


def _check_target(target: np.ndarray) -> np.ndarray:
    t = np.asarray(target, dtype=float)
    if t.shape != (4, 4):
        raise HriplanError(f"IK target must be a 4x4 homogeneous pose, got shape {t.shape}")
    if not np.isfinite(t).all():
        raise HriplanError("IK target contains NaN or infinite values")
    rot = t[:3, :3]
    if not (np.abs(t[3] - LAST_ROW) <= LAST_ROW_TOLERANCE).all():  # np.allclose's test, without its overhead
        raise HriplanError(f"IK target's last row must be [0, 0, 0, 1], got {t[3].tolist()}")
    if np.abs(rot.T @ rot - _EYE3).max() > ORTHONORMAL_TOLERANCE or _determinant(rot.tolist()) < 0:
        raise HriplanError("IK target's rotation part is not a proper orthonormal rotation matrix")
    return t


def _determinant(m: list[list[float]]) -> float:
    """A 3x3 determinant in floats: only its sign is read, of a matrix orthonormal to 1e-6 (so
    +-1 within 1e-5), where np.linalg.det's checks and LAPACK call cost ~10 us an IK solve."""
    (a, b, c), (d, e, f), (g, h, i) = m
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)


def _free_axis(free_axes: Sequence[str]) -> int | None:
    """Index of the one free tool axis, or None. Two free axes would leave only a direction
    constraint on the third, which sampling one angle cannot cover: refuse them."""
    unknown = [a for a in free_axes if a not in AXES]
    if unknown:
        raise HriplanError(f"unknown free axis {unknown[0]!r}; choose from x, y, z")
    axes = sorted(set(free_axes))
    if len(axes) > 1:
        raise HriplanError(f"at most one free axis is supported, got {', '.join(axes)}")
    return AXES[axes[0]] if axes else None


def _spin(axis: int, angle: float) -> np.ndarray:
    spin = np.eye(4)
    spin[:3, :3] = pin.exp3(angle * np.eye(3)[axis])
    return spin


@functools.cache
def _spins(axis: int, samples: int) -> tuple[np.ndarray, ...]:
    """The turns about a free tool axis `_branches` spins a target by: `samples` evenly spaced."""
    return tuple(_spin(axis, angle) for angle in np.arange(samples) * TWO_PI / samples)


# Inverted frames by their values (`_inverse`).
_INVERSES: Recent[bytes, np.ndarray] = Recent(16)


def _inverse(frame: np.ndarray) -> np.ndarray:
    """np.linalg.inv of a 4x4 frame, kept by its values: an arm's solver base and flange stand
    where they stood (~10 us each an IK solve, ~12 solves a re-plan)."""
    key = frame.tobytes()
    inverse = _INVERSES.get(key)
    if inverse is None:
        inverse = np.linalg.inv(frame)
        _INVERSES.put(key, inverse)
    return inverse


def _branches(arm: _Arm, target: np.ndarray, axis: int | None, samples: int) -> tuple[np.ndarray, np.ndarray]:
    """Every analytic solution (rows, angles in (-pi, pi]) and the exact tool pose each reaches;
    with a free axis, the target spun about it at `samples` evenly spaced angles."""
    if samples < 1:
        raise HriplanError(f"samples_per_free_axis must be at least 1, got {samples}")
    to_solver, from_tool = _inverse(arm.base @ arm.solver_base), _inverse(arm.flange_to_tool)
    solutions, poses = [], []
    for pose in [target] if axis is None else [target @ spin for spin in _spins(axis, samples)]:
        flange = to_solver @ pose @ from_tool
        for q in arm.solver.inverse_kinematics(np.ascontiguousarray(flange)):
            solutions.append(q)
            poses.append(pose)
    return np.reshape(solutions, (-1, arm.n)), np.reshape(poses, (-1, 4, 4))


def _fit_limits(
    solutions: np.ndarray, lower: np.ndarray, upper: np.ndarray, reference: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Shift each joint by the multiple of 2*pi that is within limits and nearest the reference.

    Returns the shifted solutions and a mask of those whose every joint fits."""
    k_min = np.ceil((lower - solutions) / TWO_PI)
    k_max = np.floor((upper - solutions) / TWO_PI)
    k = np.minimum(np.maximum(np.rint((reference - solutions) / TWO_PI), k_min), k_max)  # np.clip's, np.round's
    return solutions + TWO_PI * k, np.all(k_min <= k_max, axis=1)


def _errors(pose: np.ndarray, target: np.ndarray, axis: int | None) -> tuple[float, float]:
    """Position error (m) and orientation error (rad); with a free axis only its direction counts."""
    position = norm(target[:3, 3] - pose[:3, 3])
    if axis is None:
        return position, norm(pin.log3(target[:3, :3].T @ pose[:3, :3]))
    a, b = target[:3, axis], pose[:3, axis]
    return position, float(math.atan2(np.linalg.norm(np.cross(a, b)), float(a @ b)))


def _polish(
    robot: Robot, arm: _Arm, q: np.ndarray, target: np.ndarray, tolerance: float
) -> tuple[np.ndarray, np.ndarray | None]:
    """Damped Gauss-Newton steps on the tool pose, to absorb the analytic solver's round-off: the
    configuration, and the tool pose it reaches if that is within `tolerance` of `target` (else None)."""
    for _ in range(POLISH_ITERATIONS):
        pose = robot.frame_pose(arm.tool, q)
        if max(_errors(pose, target, None)) < tolerance:
            return q, pose
        error = np.concatenate([target[:3, 3] - pose[:3, 3], pin.log3(target[:3, :3] @ pose[:3, :3].T)])
        jac = robot.frame_jacobian(arm.tool, q, arm.group)
        step = jac.T @ np.linalg.solve(jac @ jac.T + POLISH_DAMPING * np.eye(6), error)
        q = robot.configuration(robot.group_values(q, arm.group) + step, arm.group, base=q)
    pose = robot.frame_pose(arm.tool, q)
    return q, pose if max(_errors(pose, target, None)) < tolerance else None


def _reached(robot: Robot, arm: _Arm, values: np.ndarray) -> np.ndarray:
    """The tool pose a numeric solution reaches (within the tolerance of the target; with a free
    axis, the target turned about it)."""
    return robot.frame_pose(arm.tool, robot.configuration(values, arm.group, base=arm.base_q))


def _reference(arm: _Arm, reference: np.ndarray | None) -> np.ndarray:
    return np.zeros(arm.n) if reference is None else _vector(reference, arm.n, "reference")


def _ranked(
    robot: Robot, arm: _Arm, target: np.ndarray, axis: int | None, reference: np.ndarray, samples: int
) -> tuple[int, np.ndarray, np.ndarray]:
    """(number of analytic solutions, those within limits nearest-first, the pose each reaches)."""
    solutions, poses = _branches(arm, target, axis, samples)
    shifted, fits = _fit_limits(solutions, *robot.limits(arm.group), reference)
    shifted, poses = shifted[fits], poses[fits]
    order = np.argsort(np.linalg.norm(shifted - reference, axis=1), kind="stable")
    return len(solutions), shifted[order], poses[order]


def ik_solutions(
    robot: Robot,
    arm: str,
    target: np.ndarray,
    free_axes: Sequence[str] = (),
    *,
    reference: np.ndarray | None = None,
    base_q: np.ndarray | None = None,
    samples_per_free_axis: int = 36,
) -> list[np.ndarray]:
    """All solutions (group order) within joint limits, nearest the reference first: every analytic
    branch, or the distinct ones numeric IK finds from all its starts.

    Lets a caller (e.g. a goal sampler) choose among branches itself; `solve_ik` picks one."""
    target = _check_target(target)
    axis = _free_axis(free_axes)
    info = _Arm(robot, arm, base_q)
    if info.kind == NUMERIC_IK:
        found: list[np.ndarray] = []
        search = numeric_ik_search.Search(robot, info, arm, target, axis, reference, DEFAULT_TOLERANCE)
        for values in filter(lambda v: v is not None, search.attempts()):
            if all(np.abs(values - other).max() > DISTINCT for other in found):
                found.append(values)
        nearest = _reference(info, reference)
        return sorted(found, key=lambda values: float(np.linalg.norm(values - nearest)))
    _, solutions, _ = _ranked(robot, info, target, axis, _reference(info, reference), samples_per_free_axis)
    return list(solutions)


def solve_ik(
    robot: Robot,
    arm: str,
    target: np.ndarray,
    *,
    free_axes: Sequence[str] = (),
    reference: np.ndarray | None = None,
    base_q: np.ndarray | None = None,
    is_valid: Callable[[np.ndarray], bool] | None = None,
    why_invalid: Callable[[np.ndarray], list[str]] | None = None,
    samples_per_free_axis: int = 36,
    tolerance: float = DEFAULT_TOLERANCE,
) -> IKResult:
    """Joint values putting `arm`'s tool frame at `target` (4x4 world pose), nearest `reference`.

    Rotation about the tool axes in `free_axes` is left free (at most one axis). Candidates are
    tried nearest-first, so `is_valid` (given the full configuration, e.g. a collision check)
    runs only until one passes. `why_invalid` names what is wrong with a rejected configuration
    ("collides: a - b", "violates c"), so that a failure says what collides and what would help.
    Numeric IK tries its solutions in the order it finds them (the first starts at `reference`)."""
    target = _check_target(target)
    axis = _free_axis(free_axes)
    if not tolerance > 0:
        raise HriplanError(f"IK tolerance must be positive, got {tolerance}")
    info = _Arm(robot, arm, base_q)
    distance = norm(target[:3, 3] - info.shoulder)
    if info.kind == NUMERIC_IK:
        length = numeric_ik_search.reach(robot, info, arm)
        if length is not None and distance > length + tolerance:
            return IKResult(
                success=False, message=f"no numeric solution: {numeric_ik_search.beyond_reach(distance, arm, length)}"
            )
        search = numeric_ik_search.Search(robot, info, arm, target, axis, reference, tolerance)
        candidates = ((values, _reached(robot, info, values)) for values in search.candidates())
    else:
        n_analytic, solutions, poses = _ranked(
            robot, info, target, axis, _reference(info, reference), samples_per_free_axis
        )
        if n_analytic == 0:
            return IKResult(
                success=False, message=f"target is out of reach of the {arm} arm ({distance:.3f} m from the shoulder)"
            )
        if len(solutions) == 0:
            return IKResult(success=False, message=f"no solution within joint limits ({n_analytic} analytic solutions)")
        candidates = zip(solutions, poses)
        message = f"nearest valid of {len(solutions)} solutions within joint limits"
    lower, upper = robot.limits(info.group)
    n_tried, n_accurate, reasons = 0, 0, Counter()
    for values, pose in candidates:
        n_tried += 1
        q, reached = _polish(robot, info, robot.configuration(values, info.group, base=info.base_q), pose, tolerance)
        polished = robot.group_values(q, info.group)
        inside = (polished >= lower).all() and (polished <= upper).all()
        if not inside or reached is None:
            continue
        n_accurate += 1
        if is_valid is None or is_valid(q):
            position, orientation = _errors(reached, target, axis)
            return IKResult(
                success=True,
                q=polished.tolist(),
                position_error=position,
                orientation_error=orientation,
                message=f"the first valid of {n_tried} numeric solutions" if info.kind == NUMERIC_IK else message,
            )
        if why_invalid is not None:
            reasons.update(why_invalid(q))
    if n_tried == 0:
        return IKResult(
            success=False,
            message=f"no numeric solution from {search.starts} start{'s' * (search.starts != 1)}: {search.failure()}",
        )
    if n_accurate == 0:
        return IKResult(success=False, message=f"no solution reached the tolerance of {tolerance:g} (singular target?)")
    return IKResult(success=False, message=rejection_message(n_accurate, reasons))


def rejection_message(n: int, reasons: Counter) -> str:
    """Why all `n` IK solutions were rejected (the most frequent reasons), and what would help."""
    if not reasons:
        return f"all {n} solutions are rejected by is_valid"
    top = ", ".join(f"{reason} ({count} of {n})" for reason, count in reasons.most_common(3))
    hints = []
    if any(ZONE_NAMING in r for r in reasons):
        hints.append(
            "meet the person farther from the body parts named (ISO/TS 15066 minimum separation; contact is "
            "allowed only at their contact regions)"
        )
    if any(r.startswith("collides") and ZONE_NAMING not in r for r in reasons):
        hints.append("move the goal away from what collides (e.g. higher above a table) or hold the object another way")
    if any(r.startswith("violates") for r in reasons):
        hints.append("choose a goal orientation the violated constraint allows")
    return f"all {n} solutions are rejected: {top}; would help: {'; '.join(hints)}"


ArmTarget = tuple[str, np.ndarray, Sequence[str]]  # arm, 4x4 tool target, free axes


def solve_two_arms(
    robot: Robot, first: ArmTarget, second: ArmTarget, base_q: np.ndarray, is_valid: Callable[[np.ndarray], bool]
) -> np.ndarray | None:
    """A full configuration with both arms at their targets, or None.

    The first arm's branches are tried nearest `base_q` first, each with the second arm's
    nearest valid solution: the arms must not only reach but also clear each other."""
    (arm_a, target_a, free_a), (arm_b, target_b, free_b) = first, second
    group_a, group_b = robot.arm_group(arm_a), robot.arm_group(arm_b)
    for values in ik_solutions(
        robot, arm_a, target_a, free_a, reference=robot.group_values(base_q, group_a), base_q=base_q
    ):
        q = robot.configuration(values, group_a, base=base_q)
        res = solve_ik(
            robot,
            arm_b,
            target_b,
            free_axes=free_b,
            base_q=q,
            reference=robot.group_values(base_q, group_b),
            is_valid=is_valid,
        )
        if res.success:
            return robot.configuration(res.q, group_b, base=q)
    return None
