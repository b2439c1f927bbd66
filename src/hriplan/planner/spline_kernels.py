"""The natural spline's coefficients (its tridiagonal solve) and its evaluation compiled (numba),
for `natural_spline.NaturalSpline` with the kernels on.

Why: a timing builds one spline (its solve is a loop over the knots on Python floats, ~0.1 ms for
a UR5 motion's ~90 knots and 6 joints, with numpy's products around it) and evaluates it about
ten times at hundreds to a thousand path positions (numpy's gathers and Horner steps on
(points, dof) arrays, ~0.2 ms in all). Each is a scalar loop here, with the same operations in
the same order as `natural_spline.py`'s (divisions, products and sums as written, no fused
multiply-add), so the same bits
(tests/planner/test_natural_spline.py compares both routes). Every jitted function lives in this
one file (numba keys a function's disk cache by its own file only); numba is imported only
when the kernels are on (`natural_spline.py` imports this module then).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def second_derivatives(h: np.ndarray, slope: np.ndarray, second: np.ndarray) -> None:
    """`natural_spline._second_derivatives` into `second` (n, dof, zeros): Thomas' algorithm on
    the rows h[i], 2 (h[i] + h[i + 1]), h[i + 1], the sub-diagonal eliminated once for every joint."""
    inner = h.shape[0] - 1  # the unknowns: the second derivatives at the inner knots
    if inner < 1:
        return
    diagonal = 2.0 * (h[:-1] + h[1:])
    factors = np.empty(inner)
    for i in range(1, inner):
        factors[i - 1] = h[i] / diagonal[i - 1]
        diagonal[i] -= factors[i - 1] * h[i]
    for joint in range(slope.shape[1]):
        rhs = 6.0 * (slope[1:, joint] - slope[:-1, joint])
        for i in range(1, inner):
            rhs[i] -= factors[i - 1] * rhs[i - 1]
        rhs[inner - 1] /= diagonal[inner - 1]
        for i in range(inner - 2, -1, -1):
            rhs[i] = (rhs[i] - h[i + 1] * rhs[i + 1]) / diagonal[i]
        second[1:-1, joint] = rhs


@njit(cache=True, nogil=True)
def evaluate(s: np.ndarray, coefficients: np.ndarray, points: np.ndarray, out: np.ndarray) -> None:
    """The Horner form of `coefficients` (k, intervals, dof: of (s - s_i)^0..k-1, an order's) at
    the path positions `points` into `out` (len(points), dof): each point in the interval of the
    inner knots at or before it (before the first: 0, from the last on: the last), as
    `NaturalSpline._evaluated`'s numpy route."""
    inner = s[1:-1]
    last = coefficients.shape[0] - 1
    for p in range(points.shape[0]):
        i = np.searchsorted(inner, points[p], side="right")
        t = points[p] - s[i]
        for j in range(coefficients.shape[2]):
            value = coefficients[last, i, j] * t
            for c in range(last - 1, 0, -1):
                value = (value + coefficients[c, i, j]) * t
            out[p, j] = value + coefficients[0, i, j]


@njit(cache=True, nogil=True)
def horner(s: np.ndarray, knots: np.ndarray, values: np.ndarray, first: np.ndarray, second: np.ndarray) -> None:
    """`NaturalSpline.__init__`'s coefficients on knots (n, dof) at path positions `s`: per knot
    interval those of (s - s_i)^0..3 into `values` (4, n - 1, dof), the first derivative's Horner
    form into `first` (3, ...) and the second's into `second` (2, ...), from the slopes and the
    second derivatives at the knots (`second_derivatives`), with the same products."""
    n, dof = knots.shape
    h = s[1:] - s[:-1]
    slope = np.empty((n - 1, dof))
    for i in range(n - 1):
        for j in range(dof):
            slope[i, j] = (knots[i + 1, j] - knots[i, j]) / h[i]
    curvature = np.zeros((n, dof))
    second_derivatives(h, slope, curvature)
    for i in range(n - 1):
        for j in range(dof):
            c1 = slope[i, j] - h[i] * (2.0 * curvature[i, j] + curvature[i + 1, j]) / 6.0
            c2 = curvature[i, j] / 2.0
            c3 = (curvature[i + 1, j] - curvature[i, j]) / (6.0 * h[i])
            values[0, i, j], values[1, i, j], values[2, i, j], values[3, i, j] = knots[i, j], c1, c2, c3
            first[0, i, j], first[1, i, j], first[2, i, j] = c1, 2.0 * c2, 3.0 * c3
            second[0, i, j], second[1, i, j] = 2.0 * c2, 6.0 * c3
