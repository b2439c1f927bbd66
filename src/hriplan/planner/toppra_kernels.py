"""TOPP-RA's two passes compiled (numba): toppra's seidel solver ported to scalar code, and the
controllable sets (backwards) and the greedy forward pass each as one kernel over every stage.

Why a port of toppra's solver and not toppra's: hriplan already drives toppra's Cython seidel
solver itself (`timing._TOPPRA`), one `solve_stagewise_optim` call a stage and pass from a
Python loop, ~1.7 us a call of which the LP itself is ~0.1-0.3 us (compiled here: two 2-D LPs
~0.5 us a stage); the rest is Python and Cython's argument handling (memoryviews, the returned
list, the loop): the passes of a 334-gridpoint problem 1.66 -> 0.23 ms
(benchmarks/REPORT-toppra.md, 2026-12-05). toppra has no call that runs a whole
pass in compiled code, and its solver's coefficients (`a_arr`, ...) are private to its Cython
class, so a compiled pass needs its own copy of the solver and of its set-up (`Stagewise`).

The port is toppra 0.6's `cy_seidel_solverwrapper.pyx` (the same release line as the installed
0.6.10): `cy_solve_lp1d`, `cy_solve_lp2d` and `seidelWrapper.solve_stagewise_optim`, with the
same arithmetic in the same order (`pow(x, 2)` as x * x, which gcc folds it to, and the tests
find no difference), the same warm start (the last active constraints of the upper and of the
lower solver, kept between calls) and the same answers on failure (NaN; ZeroDivisionError where
toppra's Cython divides by zero, a violated all-zero row), so the passes give toppra's bits
(tests/planner/test_toppra_kernels.py compares it with toppra's solver). Its set-up is
`seidelWrapper.__init__`'s with the same numpy products. Every jitted function lives in this
one file (numba keys a function's disk cache by its own file only); numba is imported only
when the kernels are on (`timing.py` imports this module then).
"""

from __future__ import annotations

import numpy as np
from numba import njit

# cy_seidel_solverwrapper.pyx's constants (not toppra.constants')
_TINY = 1e-10
_SMALL = 1e-8
_VAR_MIN = -100000000.0
_VAR_MAX = 100000000.0
_INF = 10000000000.0


@njit(cache=True, nogil=True, inline="always")
def _lp1d(v0: float, nrows: int, a: np.ndarray, b: np.ndarray, low: float, high: float) -> tuple[int, float, int]:
    """cy_solve_lp1d: max v0 x subject to a x + b <= 0 (rows < nrows), low <= x <= high.
    (result: 1 solved, 0 infeasible; x; the active row, -1 low, -2 high)."""
    cur_min, active_min = low, -1
    cur_max, active_max = high, -2
    for i in range(nrows):
        if a[i] > _TINY:
            cur_x = -b[i] / a[i]
            if cur_x < cur_max:
                cur_max, active_max = cur_x, i
        elif a[i] < -_TINY:
            cur_x = -b[i] / a[i]
            if cur_x > cur_min:
                cur_min, active_min = cur_x, i
    if cur_min > cur_max:
        return 0, np.nan, 0
    if abs(v0) < _TINY or v0 < 0:
        return 1, cur_min, active_min
    return 1, cur_max, active_max


@njit(cache=True, nogil=True, inline="always")
def _lp2d(
    v0: float,
    v1: float,
    a: np.ndarray,
    b: np.ndarray,
    c: np.ndarray,
    low0: float,
    low1: float,
    high0: float,
    high1: float,
    active: np.ndarray,
    index_map: np.ndarray,
    a_1d: np.ndarray,
    b_1d: np.ndarray,
) -> tuple[int, float, float, int, int]:
    """cy_solve_lp2d: max v . (x0, x1) subject to a x0 + b x1 + c <= 0, low <= x <= high, the
    rows `active` (the last call's active pair) first. (result, x0, x1, active pair); the
    fixed bounds are -1 (low0), -2 (high0), -3 (low1), -4 (high1)."""
    nrows = a.shape[0]
    if low0 > high0 or low1 > high1:
        return 0, np.nan, np.nan, 0, 0
    if v0 > _TINY:
        cur0, active0 = high0, -2
    else:
        cur0, active0 = low0, -1
    if v1 > _TINY:
        cur1, active1 = high1, -4
    else:
        cur1, active1 = low1, -3
    first, second = active[0], active[1]
    if first >= 0 and first < nrows and second >= 0 and second < nrows and first != second:
        index_map[0], index_map[1] = second, first
        row = 2
        for i in range(nrows):
            if i != first and i != second:
                index_map[row] = i
                row += 1
    else:
        for i in range(nrows):
            index_map[i] = i
    for k in range(nrows):
        i = index_map[k]
        if a[i] * cur0 + b[i] * cur1 + c[i] < _TINY:
            continue
        active0 = i
        ai, bi, ci = a[i], b[i], c[i]
        zero0 = -ai * ci / (ai * ai + bi * bi)
        zero1 = -bi * ci / (ai * ai + bi * bi)
        tan0, tan1 = -bi, ai
        v_1d = tan0 * v0 + tan1 * v1
        rows_1d = 4 + k
        for j in range(rows_1d):
            if j == k:
                aj, bj, cj = -1.0, 0.0, low0
            elif j == k + 1:
                aj, bj, cj = 1.0, 0.0, -high0
            elif j == k + 2:
                aj, bj, cj = 0.0, -1.0, low1
            elif j == k + 3:
                aj, bj, cj = 0.0, 1.0, -high1
            else:
                aj, bj, cj = a[index_map[j]], b[index_map[j]], c[index_map[j]]
            denom = tan0 * aj + tan1 * bj
            if denom > _TINY:
                limit = -(cj + zero1 * bj + zero0 * aj) / denom
                a_1d[j], b_1d[j] = 1.0, -limit
            elif denom < -_TINY:
                limit = -(cj + zero1 * bj + zero0 * aj) / denom
                a_1d[j], b_1d[j] = -1.0, limit
            else:  # parallel to the new line: infeasible if it cuts the line away
                if cj + zero1 * bj + zero0 * aj > _SMALL:
                    return 0, np.nan, np.nan, 0, 0
                a_1d[j], b_1d[j] = 0.0, -1.0
        found, t, on = _lp1d(v_1d, rows_1d, a_1d, b_1d, -_INF, _INF)
        if found == 0:
            return 0, np.nan, np.nan, 0, 0
        cur0 = zero0 + t * tan0
        cur1 = zero1 + t * tan1
        if on < 0:  # the 1-D problem's own bounds (toppra compares them unsigned: none matches)
            return 0, np.nan, np.nan, 0, 0
        if on < k:
            active1 = index_map[on]
        elif on == k:
            active1 = -1
        elif on == k + 1:
            active1 = -2
        elif on == k + 2:
            active1 = -3
        elif on == k + 3:
            active1 = -4
        else:
            return 0, np.nan, np.nan, 0, 0
    return 1, cur0, cur1, active0, active1


@njit(cache=True, nogil=True)
def stage(
    i: int,
    a: np.ndarray,
    b: np.ndarray,
    c: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    deltas: np.ndarray,
    g0: float,
    g1: float,
    x_min: float,
    x_max: float,
    x_next_min: float,
    x_next_max: float,
    lp1d: bool,
    up: np.ndarray,
    down: np.ndarray,
    index_map: np.ndarray,
    a_1d: np.ndarray,
    b_1d: np.ndarray,
    bx_c: np.ndarray,
) -> tuple[float, float]:
    """seidelWrapper.solve_stagewise_optim: min (u, x) . g at stage i, x within [x_min, x_max]
    and x + 2 delta_i u within [x_next_min, x_next_max] (NaN: not bounded); (u, x), NaN if
    infeasible. Writes stage i's first two rows and the warm start (`up`, `down`), as toppra."""
    low0, low1, high0, high1 = low[i, 0], low[i, 1], high[i, 0], high[i, 1]
    if x_min == x_min:
        low1 = low1 if low1 > x_min else x_min
    if x_max == x_max:
        high1 = high1 if high1 < x_max else x_max
    if i < deltas.shape[0]:
        if x_next_min != x_next_min:
            a[i, 0], b[i, 0], c[i, 0] = 0.0, 0.0, -1.0
        else:
            a[i, 0], b[i, 0], c[i, 0] = -2 * deltas[i], -1.0, x_next_min
        if x_next_max != x_next_max:
            a[i, 1], b[i, 1], c[i, 1] = 0.0, 0.0, -1.0
        else:
            a[i, 1], b[i, 1], c[i, 1] = 2 * deltas[i], 1.0, -x_next_max
    else:
        a[i, 0], b[i, 0], c[i, 0] = 0.0, 0.0, -1.0
        a[i, 1], b[i, 1], c[i, 1] = 0.0, 0.0, -1.0
    v0, v1 = -g0, -g1
    if x_min == x_max and lp1d:
        for row in range(a.shape[1]):
            bx_c[row] = b[i, row] * x_min + c[i, row]
        found, u, on = _lp1d(v0, a.shape[1], a[i], bx_c, low0, high0)
        if found == 0:
            return np.nan, np.nan
        if g1 > 0:
            up[0] = on
        else:
            down[0] = on
        return u, x_min
    active = up if g1 > 0 else down
    found, u, x, first, second = _lp2d(
        v0, v1, a[i], b[i], c[i], low0, low1, high0, high1, active, index_map, a_1d, b_1d
    )
    if found == 0:
        return np.nan, np.nan
    active[0], active[1] = first, second
    return u, x


@njit(cache=True, nogil=True)
def controllable(
    a: np.ndarray,
    b: np.ndarray,
    c: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    deltas: np.ndarray,
    x_end: float,
    up: np.ndarray,
    down: np.ndarray,
    index_map: np.ndarray,
    a_1d: np.ndarray,
    b_1d: np.ndarray,
    bx_c: np.ndarray,
    sets: np.ndarray,
) -> None:
    """`timing._TOPPRA._controllable`'s pass: the controllable sets of squared path speed into
    `sets` (stages + 1, 2, zeros), from the end (x_end) back to the first NaN, which is kept."""
    stages = deltas.shape[0]
    lowest = highest = x_end
    sets[stages, 0], sets[stages, 1] = lowest, highest
    for i in range(stages - 1, -1, -1):
        upper = stage(i, a, b, c, low, high, deltas, 1e-9, -1.0, np.nan, np.nan, lowest, highest, True,
                      up, down, index_map, a_1d, b_1d, bx_c)[1]  # fmt: skip
        lower = stage(i, a, b, c, low, high, deltas, -1e-9, 1.0, np.nan, np.nan, lowest, highest, True,
                      up, down, index_map, a_1d, b_1d, bx_c)[1]  # fmt: skip
        lowest, highest = 0.0 if lower < 0 else lower, upper
        sets[i, 0], sets[i, 1] = lowest, highest
        if lower != lower or upper != upper:
            break


@njit(cache=True, nogil=True)
def forward(
    a: np.ndarray,
    b: np.ndarray,
    c: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    deltas: np.ndarray,
    sets: np.ndarray,
    tiny: float,
    max_tries: int,
    lp1d: bool,
    up: np.ndarray,
    down: np.ndarray,
    index_map: np.ndarray,
    a_1d: np.ndarray,
    b_1d: np.ndarray,
    bx_c: np.ndarray,
    xs: np.ndarray,
    us: np.ndarray,
) -> None:
    """`timing._TOPPRA.compute_parameterization`'s greedy forward pass from xs[0]: the squared
    speeds into `xs` (stages + 1) and the path accelerations into `us` (stages, zeros); a stage
    with no answer lowers its speed and tries again, as toppra (after `max_tries`: NaN onwards)."""
    stages = deltas.shape[0]
    tries, i = 0, 0
    while i < stages:
        lowest, highest = sets[i + 1, 0], sets[i + 1, 1]
        g0 = -2 * deltas[i]
        x = xs[i]
        u = np.nan
        if x == x:
            u = stage(i, a, b, c, low, high, deltas, g0, -1.0, x, x, lowest, highest, lp1d,
                      up, down, index_map, a_1d, b_1d, bx_c)[0]  # fmt: skip
        if u != u:
            if tries == max_tries:
                xs[i + 1 :] = np.nan
                break
            lowered, scaled = x - tiny, 0.999 * x
            xs[i] = scaled if scaled > lowered else lowered  # Python's max(x - tiny, 0.999 * x)
            tries += 1
            continue
        us[i], tries = u, 0
        reached = x + 2 * deltas[i] * u
        lowered, scaled = reached - tiny, 0.9999 * reached
        reached = scaled if scaled > lowered else lowered
        reached = reached if reached > lowest else lowest  # max(low, ...)
        xs[i + 1] = reached if reached < highest else highest  # min(high, ...)
        i += 1


class Stagewise:
    """toppra's seidelWrapper (0.6) with its stages solved by `stage` and its passes by
    `controllable` and `forward`: the same coefficients (its set-up's numpy products), the same
    warm start, the same answers."""

    def __init__(self, constraints: list, path: object, gridpoints: np.ndarray, solve_lp1d: bool = True) -> None:
        from toppra.constraint import ConstraintType

        self.constraints, self.path = constraints, path
        grid = np.array(gridpoints)
        self.N = len(grid) - 1
        self.deltas = grid[1:] - grid[:-1]
        self._lp1d = bool(solve_lp1d)
        rows, params = 2, []
        for constraint in constraints:
            if constraint.get_constraint_type() != ConstraintType.CanonicalLinear:
                raise NotImplementedError
            found = constraint.compute_constraint_params(path, grid)
            if found[0] is not None:
                rows += found[3].shape[0] if constraint.identical else found[3].shape[1]
            params.append(found)
        self._params = params
        stages = self.N + 1
        self.a_arr, self.b_arr = np.zeros((stages, rows)), np.zeros((stages, rows))
        self.c_arr = np.zeros((stages, rows))
        self.low_arr, self.high_arr = np.ones((stages, 2)) * _VAR_MIN, np.ones((stages, 2)) * _VAR_MAX
        at = 2
        for constraint, (a, b, c, F, h, ubound, xbound) in zip(constraints, params):
            if a is not None:
                if constraint.identical:
                    count = F.shape[0]
                    ta, tb, tc = a.dot(F.T), b.dot(F.T), c.dot(F.T) - h
                else:
                    count = F.shape[1]
                    ta = np.array([np.dot(F[i], a[i]) for i in range(stages)]).reshape(stages, count)
                    tb = np.array([np.dot(F[i], b[i]) for i in range(stages)]).reshape(stages, count)
                    tc = np.array([np.dot(F[i], c[i]) - h[i] for i in range(stages)]).reshape(stages, count)
                self.a_arr[:, at : at + count] = ta
                self.b_arr[:, at : at + count] = tb
                self.c_arr[:, at : at + count] = tc
                at += count
            for bound, column in ((ubound, 0), (xbound, 1)):  # toppra's dbl_max / dbl_min, NaN and -0 alike
                if bound is not None:
                    lows, highs = self.low_arr[:, column], self.high_arr[:, column]
                    self.low_arr[:, column] = np.where(lows > bound[:, 0], lows, bound[:, 0])
                    self.high_arr[:, column] = np.where(highs < bound[:, 1], highs, bound[:, 1])
        self._up, self._down = np.zeros(2, dtype=np.int64), np.zeros(2, dtype=np.int64)
        self._index_map = np.zeros(rows, dtype=np.int64)
        self._a_1d, self._b_1d, self._bx_c = np.zeros(rows + 4), np.zeros(rows + 4), np.zeros(rows)

    @property
    def params(self) -> list:
        return self._params

    def get_no_vars(self) -> int:
        return 2

    def get_no_stages(self) -> int:
        return self.N

    def get_deltas(self) -> np.ndarray:
        return self.deltas

    def setup_solver(self) -> None:
        pass

    def close_solver(self) -> None:
        pass

    def _work(self) -> tuple:
        return self._up, self._down, self._index_map, self._a_1d, self._b_1d, self._bx_c

    def _coefficients(self) -> tuple:
        return self.a_arr, self.b_arr, self.c_arr, self.low_arr, self.high_arr, self.deltas

    def solve_stagewise_optim(self, i, H, g, x_min, x_max, x_next_min, x_next_max) -> list[float]:
        """One stage (toppra's call, H unused): [u, x], NaN if infeasible."""
        if not 0 <= i <= self.N:
            raise AssertionError
        found = stage(
            int(i), *self._coefficients(), float(g[0]), float(g[1]), float(x_min), float(x_max),
            float(x_next_min), float(x_next_max), self._lp1d, *self._work(),
        )  # fmt: skip
        return [found[0], found[1]]

    def controllable(self, x_end: float) -> np.ndarray:
        """The controllable sets (stages + 1, 2) ending at x_end, as `timing._TOPPRA._controllable`."""
        sets = np.zeros((self.N + 1, 2))
        controllable(*self._coefficients(), float(x_end), *self._work(), sets)
        return sets

    def forward(self, x_start: float, sets: np.ndarray, tiny: float, max_tries: int) -> tuple[np.ndarray, np.ndarray]:
        """The forward pass's squared speeds (stages + 1) and path accelerations (stages)."""
        xs, us = np.zeros(self.N + 1), np.zeros(self.N)
        xs[0] = x_start
        forward(*self._coefficients(), sets, float(tiny), int(max_tries), self._lp1d, *self._work(), xs, us)
        return xs, us
