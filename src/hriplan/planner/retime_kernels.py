"""A retiming under joint limits as compiled calls (numba): TOPP-RA's constraint rows made from
the path, its two passes and its verdict in one call (`passes`), toppra's trajectory set-up
(`constant_acceleration`), the grid check between gridpoints (`overshooting`), the trajectory's
samples (`samples`) and the limit check's largest ratio (`worst`), for `timing.py` with the
kernels on.

Why: with the passes compiled (`toppra_kernels.py`, ~0.2 ms a UR5 motion) what was left around
them was toppra's Python: its constraint objects' parameters (`compute_constraint_params`, the
interpolation scheme's copies, the solver set-up's matrix products), the algorithm object, its
trajectory call and hriplan's numpy check of the grid, ~0.6 ms a timing. Here the solver's rows
are written straight from the path's derivatives at the gridpoints, with the same numbers:

- joint velocity limits (toppra's `_create_velocity_constraint`): bounds on x = sd^2 only, the
  path speed's bounds kept in single precision as toppra's Cython keeps them (`cdef float`);
- joint acceleration limits, interpolation scheme (`canlinear_colloc_to_interpolate`, identical
  F): rows u q'_i + x q''_i <= amax and -(...) <= amax at gridpoint i, and at gridpoint i + 1
  reached with u over the stage (q'_{i+1} + 2 delta_i q''_{i+1}); toppra multiplies them out
  as matrix products with F = [I; -I] (BLAS: a zero comes out +0.0, `_entry`).

The passes are `toppra_kernels.controllable` and `forward` themselves, so the same bits
(tests/planner/test_retime_kernels.py compares the rows and the passes with toppra's, the rest
with timing.py's numpy). Numba
is imported only with the kernels on (`timing.py` imports this module then).
"""

from __future__ import annotations

import numpy as np

from hriplan.planner import spline_kernels, toppra_kernels
from hriplan.robots.kernel_cache import njit_keyed

_keyed = njit_keyed(spline_kernels, toppra_kernels)

# toppra.constants' (the passes' tolerances) and its joint velocity constraint's
_SMALL = 1e-5
_TINY = 1e-8
_MAX_TRIES = 10
_MAXSD = 1e8  # toppra's JVEL_MAXSD: the path speed's cap where no joint moves
# `passes`' answers: toppra's ParameterizationReturnCode Ok, FailUncontrollable, ErrUnknown
OK, UNCONTROLLABLE, UNKNOWN = 0, 1, 2


@_keyed
def joint_limit_rows(
    d1: np.ndarray,
    d2: np.ndarray,
    deltas: np.ndarray,
    vmax: np.ndarray,
    amax: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    c: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
) -> None:
    """`toppra_kernels.Stagewise`'s rows and bounds (stages + 1, 2 + 4 dof; zeros) for toppra's
    [JointVelocityConstraint(vmax), JointAccelerationConstraint(amax, Interpolation)] on a path
    with derivatives `d1`, `d2` at the gridpoints (stages + 1, dof), `deltas` apart."""
    points, dof = d1.shape
    stages = points - 1
    for i in range(points):
        for j in range(dof):  # F's blocks [I; -I]: on gridpoint i's (q', q''), then on i + 1's reached
            p, pp = d1[i, j], d2[i, j]
            if i < stages:
                reached, reached_pp = d1[i + 1, j] + 2 * deltas[i] * d2[i + 1, j], d2[i + 1, j]
            else:
                reached, reached_pp = p, pp
            column = 2 + j
            a[i, column], b[i, column] = _entry(p, 1.0), _entry(pp, 1.0)
            a[i, column + dof], b[i, column + dof] = _entry(p, -1.0), _entry(pp, -1.0)
            a[i, column + 2 * dof], b[i, column + 2 * dof] = _entry(reached, 1.0), _entry(reached_pp, 1.0)
            a[i, column + 3 * dof], b[i, column + 3 * dof] = _entry(reached, -1.0), _entry(reached_pp, -1.0)
            for block in range(4):
                c[i, column + block * dof] = 0.0 - amax[j]
        # x bounds of the velocity limits, toppra's float32 path speeds
        sdmin, sdmax = np.float32(-_MAXSD), np.float32(_MAXSD)
        for j in range(dof):
            q = d1[i, j]
            if q > 0:
                sdmax = np.float32(_min(vmax[j] / q, np.float64(sdmax)))
                sdmin = np.float32(_max(-vmax[j] / q, np.float64(sdmin)))
            elif q < 0:
                sdmax = np.float32(_min(-vmax[j] / q, np.float64(sdmax)))
                sdmin = np.float32(_max(vmax[j] / q, np.float64(sdmin)))
        lowest = _max(np.float64(sdmin), 0.0)
        x_low, x_high = lowest * lowest, np.float64(sdmax * sdmax)  # toppra: max(sdmin, 0.) ** 2, -(-powf(sdmax, 2))
        low[i, 0], high[i, 0] = toppra_kernels._VAR_MIN, toppra_kernels._VAR_MAX
        low[i, 1] = toppra_kernels._VAR_MIN if toppra_kernels._VAR_MIN > x_low else x_low
        high[i, 1] = toppra_kernels._VAR_MAX if toppra_kernels._VAR_MAX < x_high else x_high


@_keyed
def _entry(value: float, sign: float) -> float:
    """toppra's (a_intp F^T) entry where F's row holds `sign` against `value` and zeros
    elsewhere: `sign * value`, and +0.0 for a zero (BLAS sums the row from +0.0, and +0.0 plus
    zeros of either sign is +0.0)."""
    found = sign * value
    return found if found != 0.0 else 0.0


@_keyed
def _min(a: float, b: float) -> float:
    """toppra's float64_min: a if a <= b else b."""
    return a if a <= b else b


@_keyed
def _max(a: float, b: float) -> float:
    """toppra's float64_max: a if a >= b else b."""
    return a if a >= b else b


@_keyed
def passes(
    s: np.ndarray,
    velocity: np.ndarray,
    acceleration: np.ndarray,
    grid: np.ndarray,
    vmax: np.ndarray,
    amax: np.ndarray,
    xs: np.ndarray,
) -> int:
    """toppra's TOPPRA on the joint limits (`joint_limit_rows`) from rest to rest at `grid`, its
    seidel solver's passes (`toppra_kernels`, one warm start carried through both) and its
    verdict, as `timing._TOPPRA.compute_parameterization`: OK with the squared path speeds in
    `xs` (len(grid)), UNCONTROLLABLE (no controllable set reaches the start at rest) or UNKNOWN
    (the forward pass gave up: NaN in `xs`). `velocity` and `acceleration` are the path's
    first and second derivatives' Horner coefficients (`NaturalSpline.horner`) on knots `s`."""
    points, dof = grid.shape[0], vmax.shape[0]
    d1, d2 = np.empty((points, dof)), np.empty((points, dof))
    spline_kernels.evaluate(s, velocity, grid, d1)
    spline_kernels.evaluate(s, acceleration, grid, d2)
    deltas = grid[1:] - grid[:-1]
    rows = 2 + 4 * dof
    a, b, c = np.zeros((points, rows)), np.zeros((points, rows)), np.zeros((points, rows))
    low, high = np.empty((points, 2)), np.empty((points, 2))
    joint_limit_rows(d1, d2, deltas, vmax, amax, a, b, c, low, high)
    up, down, index_map = np.zeros(2, dtype=np.int64), np.zeros(2, dtype=np.int64), np.zeros(rows, dtype=np.int64)
    a_1d, b_1d, bx_c = np.zeros(rows + 4), np.zeros(rows + 4), np.zeros(rows)
    sets = np.zeros((points, 2))
    toppra_kernels.controllable(a, b, c, low, high, deltas, 0.0, up, down, index_map, a_1d, b_1d, bx_c, sets)
    if np.isnan(sets).any() or 0.0 + _SMALL < sets[0, 0] or sets[0, 1] + _SMALL < 0.0:
        return UNCONTROLLABLE
    xs[:] = 0.0
    us = np.zeros(points - 1)
    toppra_kernels.forward(a, b, c, low, high, deltas, sets, _TINY, _MAX_TRIES, True,
                           up, down, index_map, a_1d, b_1d, bx_c, xs, us)  # fmt: skip
    return UNKNOWN if np.isnan(xs).any() else OK


@_keyed
def overshooting(
    s: np.ndarray,
    velocity: np.ndarray,
    acceleration: np.ndarray,
    grid: np.ndarray,
    sd: np.ndarray,
    vmax: np.ndarray,
    amax: np.ndarray,
    velocity_tol: float,
    acceleration_tol: float,
    out: np.ndarray,
) -> None:
    """`timing._overshooting` into `out` (len(grid) - 1, booleans): the motion of constant path
    acceleration between gridpoints at 1/4, 1/2 and 3/4 of each interval, over a joint's limit
    by more than the tolerances (the same products; a NaN speed or acceleration in an interval
    makes numpy's max of it NaN, which exceeds nothing)."""
    intervals, dof = grid.shape[0] - 1, vmax.shape[0]
    at = np.empty(3 * intervals)
    for i in range(intervals):
        h = grid[i + 1] - grid[i]
        for k in range(3):
            at[3 * i + k] = grid[i] + h * (0.25 * (k + 1))
    d1, d2 = np.empty((3 * intervals, dof)), np.empty((3 * intervals, dof))
    spline_kernels.evaluate(s, velocity, at, d1)
    spline_kernels.evaluate(s, acceleration, at, d2)
    for i in range(intervals):
        h = grid[i + 1] - grid[i]
        x0, x1 = sd[i] * sd[i], sd[i + 1] * sd[i + 1]
        u = (x1 - x0) / (2 * h)
        fastest = strongest = 0.0
        fast_nan = strong_nan = False
        for k in range(3):
            x = x0 + 2 * u * (h * (0.25 * (k + 1)))
            x = x if x >= 0.0 or x != x else 0.0
            root = np.sqrt(x)
            for j in range(dof):
                p, pp = d1[3 * i + k, j], d2[3 * i + k, j]
                speed = abs(p) * root / vmax[j]
                push = abs(pp * x + p * u) / amax[j]
                fast_nan, strong_nan = fast_nan or speed != speed, strong_nan or push != push
                fastest = speed if speed > fastest else fastest
                strongest = push if push > strongest else strongest
        out[i] = (not fast_nan and fastest > 1 + velocity_tol) or (not strong_nan and strongest > 1 + acceleration_tol)


@_keyed
def samples(
    ts: np.ndarray,
    us: np.ndarray,
    speeds: np.ndarray,
    grid: np.ndarray,
    s: np.ndarray,
    path: tuple[np.ndarray, np.ndarray, np.ndarray],
    times: np.ndarray,
    positions: np.ndarray,
    velocities: np.ndarray,
    accelerations: np.ndarray,
) -> None:
    """`timing._ConstantAcceleration.samples` into the three (len(times), dof) arrays: the
    trajectory of path accelerations `us` between the gridpoints `grid`, reached at times `ts`
    with path speeds `speeds`, on the path of Horner coefficients `path` (orders 0, 1, 2) on
    knots `s`, at `times` (the same products; a time before ts[0] reads each array's last
    entry, as numpy's index -1 does)."""
    count, last = times.shape[0], us.shape[0] - 1
    ss, vs, accel = np.empty(count), np.empty(count), np.empty(count)
    for p in range(count):
        i = np.searchsorted(ts, times[p], side="right") - 1
        i = i if i < last else last
        at, u = (i, i) if i >= 0 else (ts.shape[0] - 1, last)  # numpy's index -1 in each array
        dt = times[p] - ts[at]
        ss[p] = grid[at] + dt * speeds[at] + 0.5 * (dt * dt) * us[u]
        vs[p], accel[p] = speeds[at] + dt * us[u], us[u]
    spline_kernels.evaluate(s, path[0], ss, positions)
    spline_kernels.evaluate(s, path[1], ss, velocities)
    spline_kernels.evaluate(s, path[2], ss, accelerations)
    for p in range(count):
        v, v2, u = vs[p], vs[p] * vs[p], accel[p]
        for j in range(positions.shape[1]):
            d1 = velocities[p, j]
            velocities[p, j] = d1 * v
            accelerations[p, j] = accelerations[p, j] * v2 + d1 * u


@_keyed
def constant_acceleration(grid: np.ndarray, xs: np.ndarray, sd: np.ndarray, ts: np.ndarray, us: np.ndarray) -> None:
    """toppra's ParametrizeConstAccel set-up as `timing._ConstantAcceleration` makes it, from
    the forward pass's squared speeds `xs`: the path speeds into `sd` (np.sqrt), the path
    accelerations between gridpoints into `us` (from the speeds squared again, as toppra's) and
    the times at the gridpoints into `ts` (from 0, one after the other, as np.cumsum)."""
    for i in range(grid.shape[0]):
        sd[i] = np.sqrt(xs[i])
    ts[0] = 0.0
    for i in range(grid.shape[0] - 1):
        ds = grid[i + 1] - grid[i]
        us[i] = 0.5 * (sd[i + 1] * sd[i + 1] - sd[i] * sd[i]) / ds
        ts[i + 1] = ts[i] + 2 * ds / (sd[i] + sd[i + 1])


@_keyed
def worst(values: np.ndarray, limits: np.ndarray) -> tuple[float, int, int]:
    """The largest |value| / its joint's limit of the (samples, joints) `values`, and where:
    np.argmax's first largest (or first NaN) of that ratio."""
    best, at_sample, at_joint = -np.inf, 0, 0
    for i in range(values.shape[0]):
        for j in range(values.shape[1]):
            ratio = abs(values[i, j]) / limits[j]
            if ratio != ratio:
                return ratio, i, j
            if ratio > best:
                best, at_sample, at_joint = ratio, i, j
    return best, at_sample, at_joint
