"""TOPP-RA's passes compiled (`planner/toppra_kernels.py`) give toppra's seidel solver's answers,
bit for bit: stage by stage on random and degenerate stagewise problems (infeasible stages and
bounds, unbounded directions, equal bounds, the one-variable LP, the last stage, rows that are
all zero, constraints given per gridpoint, the warm start carried between calls), and whole
passes (`timing._TOPPRA` with the kernels on) against toppra's TOPPRA: on joint limits, on a
varying path-speed limit, from and to speeds, uncontrollable starts and paths, and forward
passes that retry (and give up) by themselves. A path toppra cannot time fails alike."""

import numpy as np
import pytest

pytest.importorskip("numba")

import toppra
import toppra.algorithm
import toppra.constraint

from hriplan import HriplanError
from hriplan.planner import timing
from hriplan.planner.toppra_kernels import Stagewise
from hriplan.robots.kernel_switch import use_kernels

VMAX = np.array([1.0, 1.5, 2.0, 2.0, 3.0, 3.0])
AMAX = np.array([3.0, 4.0, 6.0, 6.0, 8.0, 8.0])
CODES = toppra.algorithm.ParameterizationReturnCode


def _path(seed: int, waypoints: int = 30) -> toppra.SplineInterpolator:
    rng = np.random.default_rng(seed)
    knots = np.cumsum(rng.normal(0.0, 0.08, (waypoints, 6)), axis=0)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(knots, axis=0), axis=1))])
    return toppra.SplineInterpolator(s, knots, bc_type="natural")


def _limited(path, sd_max) -> list:
    at = np.linspace(0.0, path.path_interval[1], len(sd_max))
    return [*timing._joint_limits(VMAX, AMAX), timing._PathSpeedLimit(path, VMAX, at, np.asarray(sd_max))]


class _Rows(toppra.constraint.LinearConstraint):
    """A canonical linear constraint of given coefficients: identical F and g at every gridpoint
    (F: k x m), or one per gridpoint (F: N+1 x k x m); u and x bounds optional."""

    def __init__(self, a, b, c, F, g, ubound=None, xbound=None) -> None:
        super().__init__()
        self._made = (a, b, c, F, g, ubound, xbound)
        self.identical = F is not None and F.ndim == 2
        self.dof = 6

    def compute_constraint_params(self, path, gridpoints, *args, **kwargs):
        return self._made


def _random_rows(rng, stages: int, identical: bool, zero: bool) -> _Rows:
    m, k = 3, 4
    a, b, c = (rng.normal(size=(stages, m)) for _ in range(3))
    if zero:  # rows with a = b = 0: parallel to every line, kept or infeasible by c
        a[:, 0] = b[:, 0] = 0.0
        a[::3, 1] = b[::3, 1] = 0.0
    F = rng.normal(size=(k, m) if identical else (stages, k, m))
    g = rng.uniform(0.5, 3.0, size=k if identical else (stages, k))
    ubound = np.column_stack([rng.uniform(-20, -1, stages), rng.uniform(1, 20, stages)])
    xbound = np.column_stack([np.where(rng.random(stages) < 0.5, 0.0, -0.0), rng.uniform(0.5, 4, stages)])
    xbound[::7, 0] = 1.0  # some gridpoints' x bounds empty or equal: low >= high
    xbound[::7, 1] = rng.choice([0.5, 1.0], size=len(xbound[::7]))
    # NaN bounds at random gridpoints: toppra's max(a, b) and min(a, b) keep a NaN b and drop a NaN a
    for bounds in (xbound, ubound):
        bounds[rng.random(stages) < 0.08, 0] = np.nan
        bounds[rng.random(stages) < 0.08, 1] = np.nan
    return _Rows(a, b, c, F, g, ubound if rng.random() < 0.5 else None, xbound)


def _calls(rng, count: int, stages: int):
    """Random solve_stagewise_optim arguments: NaN or finite bounds, x_min == x_max often,
    empty ranges, objectives of both signs, tiny and zero components, every stage and the last."""
    for _ in range(count):
        i = int(rng.integers(0, stages + 1))
        g = rng.normal(size=2) * rng.choice([1.0, 1e-9, 1e-11, 0.0], size=2)
        bounds = [float(rng.choice([np.nan, rng.uniform(-0.5, 4.0)])) for _ in range(4)]
        if rng.random() < 0.4:
            bounds[1] = bounds[0]
        if rng.random() < 0.2:
            bounds[3] = bounds[2]
        yield i, g, bounds


def _compare_stages(constraints, path, grid, rng, count: int) -> tuple[int, int, int]:
    """Both solvers asked the same sequence of stages; (feasible, infeasible, ZeroDivisionError)
    answers seen."""
    theirs = toppra.solverwrapper.seidelWrapper(constraints, path, grid, solve_lp1d=True)
    ours = Stagewise(constraints, path, grid, solve_lp1d=True)
    seen = [0, 0, 0]
    for i, g, bounds in _calls(rng, count, len(grid) - 1):
        expected, found = (_answer(solver, i, g, bounds) for solver in (theirs, ours))
        if isinstance(expected, ZeroDivisionError):  # a violated row 0 u + 0 x + c <= 0: toppra divides by 0
            assert isinstance(found, ZeroDivisionError), (i, g, bounds, found)
            seen[2] += 1
            continue
        assert np.array_equal(found, expected, equal_nan=True), (i, g, bounds, found, expected)
        assert np.array_equal(np.signbit(found), np.signbit(expected))  # -0.0 as -0.0
        seen[bool(np.isnan(expected[0]))] += 1
    return seen[0], seen[1], seen[2]


def _answer(solver, i, g, bounds):
    try:
        return np.asarray(solver.solve_stagewise_optim(i, None, g, *bounds))
    except ZeroDivisionError as error:
        return error


@pytest.mark.parametrize("seed", range(4))
def test_each_stage_is_toppras_on_joint_and_speed_limits(kernels, seed):
    path = _path(seed)
    grid = np.linspace(0.0, path.path_interval[1], 60 + 13 * seed)
    rng = np.random.default_rng(seed)
    constraints = _limited(path, rng.uniform(0.0, 2.0, 40)) if seed % 2 else timing._joint_limits(VMAX, AMAX)
    feasible, infeasible, divisions = _compare_stages(constraints, path, grid, rng, 3000)
    assert feasible > 500 and infeasible > 100


@pytest.mark.parametrize("identical", [True, False])
@pytest.mark.parametrize("zero", [False, True])
def test_each_stage_is_toppras_on_random_rows(kernels, identical, zero):
    """Random rows (given once or per gridpoint), rows that are all zero, u bounds or none, x
    bounds with 0.0 and -0.0, empty and equal: the set-up and every stage as toppra's."""
    path = _path(11)
    grid = np.linspace(0.0, path.path_interval[1], 40)
    rng = np.random.default_rng(7 + 2 * identical + zero)
    for _ in range(4):
        rows = [_random_rows(rng, len(grid), identical, zero), _random_rows(rng, len(grid), not identical, False)]
        feasible, infeasible, divisions = _compare_stages(rows, path, grid, rng, 1500)
        assert feasible > 50 and infeasible > 50 and divisions > 0  # NaN bounds: every row violated


def _given(a, b, c) -> _Rows:
    """Rows a u + b x + c <= 0 as they are (F the identity, g zero), per gridpoint."""
    return _Rows(a, b, c, np.eye(a.shape[1]), np.zeros(a.shape[1]))


def test_parallel_rows_cutting_the_line_away_by_a_little(kernels):
    """Opposite rows in u alone, then in x alone, apart by -2e-5 .. 2e-5 (infeasible by less or
    more than the solver's 1e-8 for parallel rows) and random rows beside them."""
    path = _path(6)
    grid = np.linspace(0.0, path.path_interval[1], 60)
    rng = np.random.default_rng(5)
    gaps = rng.choice([-2e-5, -1e-9, 0.0, 1e-9, 5e-9, 2e-8, 1e-6, 5e-6, 2e-5], size=len(grid))
    one, zero = np.ones(len(grid)), np.zeros(len(grid))
    in_u = _given(np.column_stack([one, -one]), np.column_stack([zero, zero]), np.column_stack([-one, one + gaps]))
    in_x = _given(np.column_stack([zero, zero]), np.column_stack([one, -one]), np.column_stack([-one, one + gaps]))
    for constraints in ([in_u], [in_x], [in_u, in_x], [_random_rows(rng, len(grid), True, False), in_x]):
        feasible, infeasible, divisions = _compare_stages(constraints, path, grid, rng, 1500)
        assert feasible > 100 and infeasible > 100


def test_rows_that_are_multiples_of_each_other(kernels):
    """Rows and their copies times 3 and 0.1 (equal bounds in the one-variable LPs: toppra keeps
    the first row found, and warm-starts from it)."""
    path = _path(8)
    grid = np.linspace(0.0, path.path_interval[1], 50)
    rng = np.random.default_rng(9)
    for _ in range(6):
        a, b, c = (rng.normal(size=(len(grid), 4)) for _ in range(3))
        copies = [np.column_stack([x, 3 * x, 0.1 * x[:, ::-1]]) for x in (a, b, c)]
        _compare_stages([_given(*copies)], path, grid, rng, 1500)


def test_unbounded_directions_and_no_rows(kernels):
    """No constraint at all (only toppra's +-1e8 box): the box answers; zero objectives."""
    path = _path(2)
    grid = np.linspace(0.0, path.path_interval[1], 20)
    feasible, *_ = _compare_stages([], path, grid, np.random.default_rng(3), 800)
    assert feasible > 400
    solver = Stagewise([], path, grid)
    assert solver.solve_stagewise_optim(3, None, np.array([-1.0, 0.0]), np.nan, np.nan, np.nan, np.nan) == [1e8, -1e8]
    # x bounds of two constraints, 0.0 and -0.0 alike: toppra keeps the second of equal bounds
    lows = np.where(np.arange(len(grid)) % 2, 0.0, -0.0)
    first, second = (
        _Rows(None, None, None, None, None, None, np.column_stack([x, np.full(len(grid), 2.0)])) for x in (lows, -lows)
    )
    _compare_stages([first, second], path, grid, np.random.default_rng(4), 800)
    x = Stagewise([first, second], path, grid).solve_stagewise_optim(2, None, np.array([0.0, 1.0]), *[np.nan] * 4)[1]
    assert x == 0.0 and not np.signbit(x)  # -(-0.0) at even gridpoints


def _both(path, constraints, grid, sd_start=0.0, sd_end=0.0):
    out = []
    for kind in (toppra.algorithm.TOPPRA, timing._TOPPRA):
        algorithm = kind(constraints, path, gridpoints=grid, solver_wrapper="seidel")
        found = algorithm.compute_parameterization(sd_start, sd_end, return_data=True)
        out.append(((*found, algorithm.problem_data.K), algorithm.problem_data.return_code, algorithm))
    assert type(out[1][2].solver_wrapper) is Stagewise  # the compiled passes ran
    return out


def _same(theirs, ours) -> None:
    assert theirs[1] == ours[1]
    for x, y in zip(theirs[0], ours[0]):
        if x is None or y is None:
            assert x is None and y is None
        else:
            np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("limited", [False, True])
def test_the_passes_are_toppras(kernels, seed, limited):
    path = _path(seed)
    grid = np.linspace(0.0, path.path_interval[1], 120 + 37 * seed)
    constraints = _limited(path, 0.2 + np.abs(np.linspace(-1, 1, 80))) if limited else timing._joint_limits(VMAX, AMAX)
    theirs, ours = _both(path, constraints, grid)
    assert theirs[1] == CODES.Ok
    _same(theirs, ours)
    moving = _both(path, constraints, grid, sd_start=0.05, sd_end=0.1)
    assert moving[0][1] == CODES.Ok
    _same(*moving)
    too_fast = _both(path, constraints, grid, sd_start=50.0)
    assert too_fast[0][1] == CODES.FailUncontrollable
    _same(*too_fast)


def test_an_uncontrollable_path_is_toppras(kernels):
    path = _path(5)
    grid = np.linspace(0.0, path.path_interval[1], 90)
    theirs, ours = _both(path, _limited(path, np.full(40, 1e-3)), grid, sd_end=2.0)
    assert theirs[1] == CODES.FailUncontrollable and np.isnan(theirs[0][3]).any()
    _same(theirs, ours)


@pytest.mark.parametrize(
    "cap, excess, tries", [(0.02, 1.62e-6, 6), (0.02, 1.8e-6, 11), (0.002, 1.6e-6, 7), (0.002, 1.8e-6, 11)]
)
def test_forward_passes_that_retry_and_give_up_are_toppras(kernels, cap, excess, tries):
    """A start speed above the controllable set by less than toppra's tolerance (1e-5 in x), a
    first stage 1e-7 long, the path's first eighth slower than `cap`: the first stage has no
    answer and toppra lowers x by max(1e-8, 0.1 %) a try (1e-8 at cap 0.02, x ~ 4e-4; 0.1 % at
    0.002, x ~ 4e-6), and Ok after the tries, or after 10 gives up (NaN onwards, ErrUnknown).
    At the slow start the forward pass keeps 0.9999 of the speed it reaches (not less 1e-8)."""
    path = _path(4)
    grid = np.concatenate([[0.0, 1e-7], np.linspace(0.0, path.path_interval[1], 100)[1:]])
    constraints = _limited(path, np.r_[np.full(5, cap), np.full(35, 1.0)])
    top = _both(path, constraints, grid)[0][0][3][0, 1]
    theirs, ours = _both(path, constraints, grid, sd_start=np.sqrt(top + excess))
    _same(theirs, ours)
    if tries <= 10:
        assert theirs[1] == CODES.Ok and theirs[0][1][0] ** 2 < top + excess - tries * min(1e-8, 1e-3 * top) / 2
    else:
        assert theirs[1] == CODES.ErrUnknown and np.isnan(theirs[0][1][1:]).all()


def test_a_path_toppra_cannot_time_fails_alike(kernels):
    """A path-speed limit below zero: no controllable set, the same HriplanError either way."""
    waypoints = np.cumsum(np.full((20, 6), 0.03), axis=0)
    messages = []
    for on in (True, False):
        use_kernels(on)
        with pytest.raises(HriplanError, match="TOPP-RA found no time parameterisation") as raised:
            timing.time_parameterize(waypoints, VMAX, AMAX, speed_scale=lambda q, dq: np.full(len(q), -1.0))
        messages.append(str(raised.value))
    assert messages[0] == messages[1] and "not controllable" in messages[0]


def test_time_parameterize_takes_the_compiled_passes_near_people(kernels, monkeypatch):
    """With a path-speed limit the timing drives `Stagewise` (joint limits alone take
    `retime_kernels`, tests/planner/test_retime_kernels.py)."""
    seen = []
    compiled = Stagewise.forward

    def forward(self, *args):
        seen.append(self)
        return compiled(self, *args)

    monkeypatch.setattr(Stagewise, "forward", forward)
    waypoints, slow = np.cumsum(np.full((20, 6), 0.03), axis=0), lambda q, dq: np.full(len(q), 2.0)
    on = timing.time_parameterize(waypoints, VMAX, AMAX, speed_scale=slow)
    assert seen
    use_kernels(False)
    off = timing.time_parameterize(waypoints, VMAX, AMAX, speed_scale=slow)
    assert on == off and len(seen) == 1
