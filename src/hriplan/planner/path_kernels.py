"""The path's preparation for TOPP-RA as compiled calls (numba), for `timing.py` with the kernels
on: the knots and their arc lengths (`knots`), the spline's deviation from the polyline
(`deviation`) and the initial gridpoints (`gridpoints`); and `validate.densify`'s interpolation
(`densified`), of the paths timed and of the states validated.

Why: each is a few dozen numpy calls on arrays of tens to hundreds of rows, where numpy's cost
per call dominates (~0.3 ms a UR5 timing in all). Here they are loops with the same operations
in the same order as `timing.py`'s numpy, so the same bits, including numpy's own orders where
they matter: a row's norm sums its squares pairwise as numpy's add.reduce does (`_norm`), and
`_interp` is np.interp's interpolation (tests/planner/test_path_kernels.py compares them).
Numba is imported only with the kernels on (`timing.py` imports this module then).
"""

from __future__ import annotations

import numpy as np

from hriplan.planner import spline_kernels
from hriplan.robots import pairwise_sums
from hriplan.robots.kernel_cache import njit_keyed
from hriplan.robots.pairwise_sums import pairwise_sum

_keyed = njit_keyed(spline_kernels, pairwise_sums)


@_keyed
def _maximum(a: float, b: float) -> float:
    """np.maximum's: NaN if either is."""
    return a if a >= b or a != a else b


@_keyed
def _minimum(a: float, b: float) -> float:
    """np.minimum's: NaN if either is."""
    return a if a <= b or a != a else b


@_keyed
def _norm(row: np.ndarray, squares: np.ndarray) -> float:
    """np.linalg.norm(rows, axis=1)'s value for one row: the root of its squares' pairwise sum
    (`squares`: room for them)."""
    for j in range(row.shape[0]):
        squares[j] = row[j] * row[j]
    return np.sqrt(pairwise_sum(squares, 0, row.shape[0]))


@_keyed
def _interp(x: float, xp: np.ndarray, fp: np.ndarray) -> float:
    """np.interp(x, xp, fp) for xp increasing strictly: the ends' values outside, a knot's own
    value at it, else the slope from the knot below (from the one above if that gives NaN)."""
    if x != x:
        return x
    j = np.searchsorted(xp, x, side="right") - 1
    if j < 0:
        return fp[0]
    if j >= xp.shape[0] - 1:
        return fp[xp.shape[0] - 1]
    if xp[j] == x:
        return fp[j]
    slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
    found = slope * (x - xp[j]) + fp[j]
    if found != found:
        found = slope * (x - xp[j + 1]) + fp[j + 1]
        if found != found and fp[j] == fp[j + 1]:
            found = fp[j]
    return found


@_keyed
def _subdivided(points: np.ndarray, pieces: np.ndarray) -> np.ndarray:
    """`timing._subdivided` for points (k, dof): segment i split into max(1, pieces[i]) equal
    parts (pieces: whole numbers as floats)."""
    counts = np.empty(pieces.shape[0], dtype=np.int64)
    for i in range(pieces.shape[0]):
        counts[i] = int(pieces[i]) if pieces[i] > 1 else 1
    out = np.empty((counts.sum() + 1, points.shape[1]))
    row = 0
    for i in range(counts.shape[0]):
        for step in range(counts[i]):
            fraction = step / counts[i]
            for j in range(points.shape[1]):
                out[row, j] = points[i, j] + fraction * (points[i + 1, j] - points[i, j])
            row += 1
    out[row] = points[-1]
    return out


@_keyed
def densified(rows: np.ndarray, step: float) -> np.ndarray:
    """`validate.densify` of rows (m >= 1, dof): segment i split in n_i = ceil(its largest
    |change| / step) parts, at least 1 (also where numpy's cast to int gives its minimum: NaN,
    infinite or beyond int64), row k of it a + change * (k / n_i)."""
    counts = np.empty(rows.shape[0] - 1, dtype=np.int64)
    for i in range(counts.shape[0]):
        largest = 0.0
        for j in range(rows.shape[1]):
            largest = _maximum(largest, abs(rows[i + 1, j] - rows[i, j]))
        pieces = np.ceil(largest / step)
        counts[i] = int(pieces) if 1.0 <= pieces < 2.0**63 else 1
    out = np.empty((counts.sum() + 1, rows.shape[1]))
    out[0] = rows[0]
    row = 1
    for i in range(counts.shape[0]):
        for k in range(1, counts[i] + 1):
            fraction = k / counts[i]
            for j in range(rows.shape[1]):
                out[row, j] = rows[i, j] + (rows[i + 1, j] - rows[i, j]) * fraction
            row += 1
    return out


@_keyed
def knots(q: np.ndarray, max_spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """`timing._densified(q)` (segments split so that none is longer than `max_spacing`) and
    the arc lengths at its knots (timing's cumulative sum of their distances from 0.0)."""
    squares = np.empty(q.shape[1])
    step = np.empty(q.shape[1])
    pieces = np.empty(q.shape[0] - 1)
    for i in range(q.shape[0] - 1):
        for j in range(q.shape[1]):
            step[j] = q[i + 1, j] - q[i, j]
        pieces[i] = np.ceil(_norm(step, squares) / max_spacing)
    dense = _subdivided(q, pieces)
    s = np.empty(dense.shape[0])
    s[0] = 0.0
    for i in range(dense.shape[0] - 1):
        for j in range(dense.shape[1]):
            step[j] = dense[i + 1, j] - dense[i, j]
        s[i + 1] = s[i] + _norm(step, squares)
    return dense, s


@_keyed
def deviation(s: np.ndarray, knots: np.ndarray, positions: np.ndarray, fractions: np.ndarray) -> float:
    """`timing._deviation`: the largest |spline - polyline| over the joints at `fractions` of
    every knot interval, the spline of Horner coefficients `positions` on knots `s` (NaN if
    any difference is)."""
    intervals, inside = s.shape[0] - 1, fractions.shape[0]
    at = np.empty(intervals * inside)
    for i in range(intervals):
        for k in range(inside):
            at[i * inside + k] = s[i] + (s[i + 1] - s[i]) * fractions[k]
    spline = np.empty((at.shape[0], knots.shape[1]))
    spline_kernels.evaluate(s, positions, at, spline)
    worst = 0.0
    for i in range(intervals):
        for k in range(inside):
            for j in range(knots.shape[1]):
                off = abs(knots[i, j] + fractions[k] * (knots[i + 1, j] - knots[i, j]) - spline[i * inside + k, j])
                if off != off:
                    return off
                worst = off if off > worst else worst
    return worst


@_keyed
def gridpoints(
    s: np.ndarray,
    velocity: np.ndarray,
    acceleration: np.ndarray,
    vmax: np.ndarray,
    amax: np.ndarray,
    amax_norm: float,
    tolerances: np.ndarray,
    counts: np.ndarray,
) -> np.ndarray:
    """`timing._gridpoints` on the spline of first and second derivatives' Horner coefficients
    `velocity`, `acceleration` on knots `s`: `amax_norm` is np.linalg.norm(amax) (numpy's dot,
    BLAS's order), `tolerances` (velocity, acceleration, largest spacing) those of the grid,
    `counts` (fewest, most) its gridpoints (see there for why the grid is so)."""
    knots, dof = s.shape[0], vmax.shape[0]
    velocity_tol, acceleration_tol, max_spacing = tolerances[0], tolerances[1], tolerances[2]
    d1, d2 = np.empty((knots, dof)), np.empty((knots, dof))
    spline_kernels.evaluate(s, velocity, s, d1)
    spline_kernels.evaluate(s, acceleration, s, d2)
    squares = np.empty(dof)
    x = np.empty(knots)  # bound on x = sd^2 at each knot
    for i in range(knots):
        slowest = np.inf
        for j in range(dof):
            q = abs(d1[i, j])
            ratio = vmax[j] / _maximum(q, 1e-12)
            slowest = _minimum(slowest, ratio * ratio)
        x[i] = _minimum(slowest, amax_norm / _maximum(_norm(d2[i], squares), 1e-12))
    jerk = np.empty((knots - 1, dof))
    spacing = np.empty(knots - 1)
    cells = np.empty(knots)
    cells[0] = 0.0
    strongest = amax.max()
    for i in range(knots - 1):
        h = s[i + 1] - s[i]
        speed = np.sqrt(_maximum(x[i], x[i + 1]))
        worst = 0.0  # of values >= 0
        for j in range(dof):
            jerk[i, j] = (d2[i + 1, j] - d2[i, j]) / h
            by_speed = speed / (8 * vmax[j] * velocity_tol)
            by_push = 5 * strongest / (8 * amax[j] * acceleration_tol)
            worst = _maximum(worst, abs(jerk[i, j]) * _maximum(by_speed, by_push))
        spacing[i] = _minimum(max_spacing, 1.0 / np.sqrt(_maximum(worst, 1e-12)))
        cells[i + 1] = cells[i] + h / spacing[i]
    total = cells[knots - 1]
    scale = _minimum(_maximum(total, counts[0]), counts[1]) / total  # np.clip
    for i in range(knots):
        cells[i] *= scale
    marks = [0]
    for i in range(knots - 2):
        worst = 0.0  # of values >= 0
        for j in range(dof):
            worst = _maximum(worst, abs(jerk[i + 1, j] - jerk[i, j]) / amax[j])
        if worst * x[i + 1] * _maximum(spacing[i], spacing[i + 1]) / 4 > acceleration_tol:
            marks.append(i + 1)
    marks.append(knots - 1)
    ends = np.empty((len(marks), 1))
    for m in range(len(marks)):
        ends[m, 0] = cells[marks[m]]
    pieces = np.empty(len(marks) - 1)
    for m in range(len(marks) - 1):
        pieces[m] = np.ceil(ends[m + 1, 0] - ends[m, 0])
    places = _subdivided(ends, pieces)
    grid = np.empty(places.shape[0])
    for p in range(places.shape[0]):
        grid[p] = _interp(places[p, 0], cells, s)
    return grid
