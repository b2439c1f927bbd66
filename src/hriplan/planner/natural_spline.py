"""The path TOPP-RA retimes: a natural cubic spline through the knots, parameterised by arc length.

scipy's `CubicSpline(bc_type="natural")` (what `toppra.SplineInterpolator` wraps) computes the same
curve; importing scipy.interpolate cost the demo's `plan` process about 0.5 s of CPU (a quarter of
it) for a tridiagonal solve and a piecewise cubic. Tests check this spline against scipy's.

It offers what TOPP-RA asks of a geometric path: positions and their first and second
derivatives at path positions (`path(s, order)`), `dof` and `path_interval`. Beyond the ends each
end's cubic goes on, as scipy's does. With the kernels on (`kernels_on()`) its coefficients (the
solve) and its evaluation are compiled (`spline_kernels.py`, the same bits).
"""

from __future__ import annotations

import numpy as np

from hriplan.robots.kernel_switch import kernels_on


class NaturalSpline:
    """The C2 piecewise cubic through (s_i, knots_i) with zero second derivative at both ends."""

    def __init__(self, s: np.ndarray, knots: np.ndarray) -> None:
        self.s = np.ascontiguousarray(s, dtype=float)  # as the compiled route reads it
        knots = np.asarray(knots, dtype=float)
        if self.s.ndim != 1 or len(self.s) < 2 or knots.shape[:1] != self.s.shape or knots.ndim != 2:
            raise ValueError(
                f"a natural spline needs n >= 2 increasing positions and (n, dof) knots, got {knots.shape}"
            )
        h = np.diff(self.s)
        if not np.all(h > 0.0):
            raise ValueError("a natural spline's path positions must increase strictly")
        self._horner = _horner_forms(self.s, h, knots)
        self._coefficients = self._horner[0]
        self._at: bytes | None = None  # the path positions last asked about, and their values by order
        self._values: dict[int, np.ndarray] = {}
        self._place: tuple[np.ndarray, np.ndarray] | None = None  # their intervals and offsets in them

    @property
    def dof(self) -> int:
        return self._coefficients.shape[2]

    def horner(self, order: int) -> np.ndarray:
        """The Horner coefficients of the derivative of `order` (0, 1, 2): (terms, intervals, dof),
        of (s - s_i)^0.. on interval i, as `spline_kernels.evaluate` reads them (not a copy)."""
        return self._horner[order]

    @property
    def path_interval(self) -> np.ndarray:
        return np.array([self.s[0], self.s[-1]])

    def __call__(self, at: float | np.ndarray, order: int = 0) -> np.ndarray:
        """Positions (order 0) or their derivatives (1, 2) at path positions `at`: (dof,) for a
        number, (len(at), dof) for an array. The values at the positions last asked about are
        kept (a copy is returned): TOPP-RA's constraints each ask for the first derivative at the
        same gridpoints, its trajectory for the path at the same samples again (8 of a re-plan's
        34 evaluations)."""
        if order not in (0, 1, 2):
            raise ValueError(f"a cubic path has derivatives of order 0, 1 and 2, not {order}")
        points = np.asarray(at, dtype=float)
        key = points.tobytes() + bytes(str(points.shape), "ascii")
        if key != self._at:
            self._at, self._values, self._place = key, {}, None
        kept = self._values.get(order)
        if kept is None:
            kept = self._values[order] = self._evaluated(points, order)
        return kept.copy()

    def _evaluated(self, points: np.ndarray, order: int) -> np.ndarray:
        if kernels_on():
            from hriplan.planner import spline_kernels  # numba: imported with the kernels on

            value = np.empty((points.size, self.dof))
            spline_kernels.evaluate(self.s, self._horner[order], np.ascontiguousarray(points.reshape(-1)), value)
            return value.reshape(points.shape + (self.dof,))
        if self._place is None:  # each point's interval and offset, found once for every order
            flat = points.reshape(-1)
            # The interval's index is the count of inner knots at or before the point (before the
            # first knot: 0, from the last on: the last interval); np.clip's Python wrapper cost more.
            interval = np.searchsorted(self.s[1:-1], flat, side="right")
            self._place = interval, (flat - self.s[interval])[:, None]
        interval, t = self._place
        # The Horner form c0 + t (c1 + t (c2 + t c3)) (order 1: c1, 2 c2, 3 c3; order 2: 2 c2,
        # 6 c3) in place, each product and sum as written (the same bits): the coefficients
        # gathered by np.take into one contiguous block (indexing gives strided rows, and a new
        # array at every step cost 2-4 times as much, on a thousand points).
        coefficients = np.take(self._horner[order], interval, axis=1)
        value = coefficients[-1] * t
        for c in coefficients[-2:0:-1]:
            value += c
            value *= t
        value += coefficients[0]
        return value.reshape(points.shape + (self.dof,))


def _horner_forms(s: np.ndarray, h: np.ndarray, knots: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per knot interval, the cubic's coefficients of (s - s_i)^k, k = 0..3, and by order the
    coefficients of its Horner form: the derivatives' factors 2, 3 and 6 applied once here, not
    to the rows gathered at every evaluation (the same products, so the same bits). With the
    kernels on one compiled call (`spline_kernels.horner`)."""
    if kernels_on():
        from hriplan.planner import spline_kernels  # numba: imported with the kernels on

        n, dof = knots.shape
        forms = (np.empty((4, n - 1, dof)), np.empty((3, n - 1, dof)), np.empty((2, n - 1, dof)))
        spline_kernels.horner(s, np.ascontiguousarray(knots), *forms)
        return forms
    slope = np.diff(knots, axis=0) / h[:, None]
    second = _second_derivatives(h, slope)  # (n, dof)
    c0, c1 = knots[:-1], slope - h[:, None] * (2.0 * second[:-1] + second[1:]) / 6.0
    c2, c3 = second[:-1] / 2.0, np.diff(second, axis=0) / (6.0 * h[:, None])
    values = np.stack([c0, c1, c2, c3])
    return values, np.stack([c1, 2.0 * c2, 3.0 * c3]), np.stack([2.0 * c2, 6.0 * c3])


def _second_derivatives(h: np.ndarray, slope: np.ndarray) -> np.ndarray:
    """The spline's second derivative at every knot (n, dof): 0 at the natural ends; inside, the
    continuity of the first derivative, a symmetric, strictly diagonally dominant tridiagonal
    system (row i: h[i], 2 (h[i] + h[i + 1]), h[i + 1]) solved by Thomas' algorithm without
    pivoting. On Python floats: paths have tens of knots, where numpy's per-call cost dominates
    (compiled with the kernels on: `spline_kernels.horner`)."""
    n = len(h) + 1
    second = np.zeros((n, slope.shape[1]))
    off, diagonal = h[1:-1].tolist(), (2.0 * (h[:-1] + h[1:])).tolist()
    factors = []
    for i in range(1, n - 2):  # eliminate the sub-diagonal
        factors.append(off[i - 1] / diagonal[i - 1])
        diagonal[i] -= factors[-1] * off[i - 1]
    for joint, rhs in enumerate((6.0 * np.diff(slope, axis=0)).T.tolist()):
        for i in range(1, n - 2):
            rhs[i] -= factors[i - 1] * rhs[i - 1]
        if rhs:
            rhs[-1] /= diagonal[-1]
        for i in range(n - 4, -1, -1):
            rhs[i] = (rhs[i] - off[i] * rhs[i + 1]) / diagonal[i]
        second[1:-1, joint] = rhs
    return second
