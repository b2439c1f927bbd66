"""The retiming's compiled calls (`planner/retime_kernels.py`) give toppra's and timing.py's
answers, bit for bit: the solver's rows and bounds against `toppra_kernels.Stagewise` set up
from toppra's constraint objects (signed zeros included: joints that do not move, float32 path
speeds), the passes and their verdict against toppra's own TOPPRA (its Cython seidel solver),
failures included, the check between gridpoints against `timing._overshooting` (NaN speeds
too), and whole timings against the route with the kernels off."""

import numpy as np
import pytest

pytest.importorskip("numba")

import toppra
import toppra.algorithm
import toppra.constraint

from hriplan import HriplanError
from hriplan.planner import retime_kernels, timing
from hriplan.planner.natural_spline import NaturalSpline
from hriplan.planner.toppra_kernels import Stagewise
from hriplan.robots.kernel_switch import use_kernels

CODES = toppra.algorithm.ParameterizationReturnCode


def _path(seed: int, waypoints: int = 30, still: int = 0) -> tuple[NaturalSpline, np.ndarray, np.ndarray]:
    """A random 6-joint spline by arc length, its first `still` joints not moving (q' = +0 or
    -0 there), and random limits."""
    rng = np.random.default_rng(seed)
    knots = np.cumsum(rng.normal(0.0, 0.08, (waypoints, 6)), axis=0)
    knots[:, :still] = rng.normal(size=still)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(knots, axis=0), axis=1))])
    return NaturalSpline(s, knots), rng.uniform(0.3, 3.0, 6), rng.uniform(1.0, 8.0, 6)


def _grid(path: NaturalSpline, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    inner = np.sort(rng.uniform(path.s[0], path.s[-1], 60 + 50 * (seed % 4)))
    return np.concatenate([[path.s[0]], inner, [path.s[-1]]])


def _stagewise(path: NaturalSpline, grid: np.ndarray, vmax: np.ndarray, amax: np.ndarray) -> Stagewise:
    """The solver set up from toppra's constraint objects (its numpy products)."""
    constraints = [
        toppra.constraint.JointVelocityConstraint(vmax),
        toppra.constraint.JointAccelerationConstraint(amax, toppra.constraint.DiscretizationType.Interpolation),
    ]
    return Stagewise(constraints, path, grid)


def _rows(path: NaturalSpline, grid: np.ndarray, vmax: np.ndarray, amax: np.ndarray) -> list[np.ndarray]:
    points, dof = len(grid), path.dof
    a, b, c = (np.zeros((points, 2 + 4 * dof)) for _ in range(3))
    low, high = np.zeros((points, 2)), np.zeros((points, 2))
    retime_kernels.joint_limit_rows(path(grid, 1), path(grid, 2), np.diff(grid), vmax, amax, a, b, c, low, high)
    return [a, b, c, low, high]


def _identical(found: np.ndarray, expected: np.ndarray) -> None:
    np.testing.assert_array_equal(found, expected)
    assert np.array_equal(np.signbit(found), np.signbit(expected))  # -0.0 as -0.0


@pytest.mark.parametrize("seed", range(8))
def test_the_rows_are_toppras(kernels, seed):
    path, vmax, amax = _path(seed, still=seed % 3)
    grid = _grid(path, seed)
    reference = _stagewise(path, grid, vmax, amax)
    for found, expected in zip(_rows(path, grid, vmax, amax), reference._coefficients()):
        _identical(found, expected)


def test_the_rows_sign_zeros_as_toppras_product(kernels):
    """A path along one joint: the other joints' q' and q'' are +0 or -0 at the gridpoints, and
    toppra's matrix products sum the signed zeros of F = [I; -I] with them."""
    rng = np.random.default_rng(9)
    knots = np.zeros((12, 6))
    knots[:, 2] = np.cumsum(rng.uniform(0.01, 0.1, 12))
    knots[:, 4] = -0.0
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(knots, axis=0), axis=1))])
    path = NaturalSpline(s, knots)
    grid = np.linspace(s[0], s[-1], 40)
    d1 = path(grid, 1)
    d1[::3, 0], d1[1::3, 1] = -0.0, -0.0  # zeros of both signs, with every other joint negative in some rows
    d1[::5] = -np.abs(d1[::5]) - 0.0
    d1[::5, 3] = -0.0
    d2 = path(grid, 2)

    class Given:
        dof, path_interval = 6, path.path_interval

        def __call__(self, at, order=0):
            return {1: d1, 2: d2}[order].copy()

    vmax, amax = np.full(6, 1.5), np.full(6, 4.0)
    a, b, c = (np.zeros((40, 26)) for _ in range(3))
    low, high = np.zeros((40, 2)), np.zeros((40, 2))
    retime_kernels.joint_limit_rows(d1, d2, np.diff(grid), vmax, amax, a, b, c, low, high)
    for found, expected in zip([a, b, c, low, high], _stagewise(Given(), grid, vmax, amax)._coefficients()):
        _identical(found, expected)


def _toppra(path: NaturalSpline, grid: np.ndarray, vmax: np.ndarray, amax: np.ndarray):
    """toppra's TOPPRA with its own Cython seidel solver: (return code, sd_vec)."""
    constraints = [
        toppra.constraint.JointVelocityConstraint(vmax),
        toppra.constraint.JointAccelerationConstraint(amax, toppra.constraint.DiscretizationType.Interpolation),
    ]
    algorithm = toppra.algorithm.TOPPRA(constraints, path, gridpoints=grid, solver_wrapper="seidel")
    _, sd, _ = algorithm.compute_parameterization(0.0, 0.0)
    return algorithm.problem_data.return_code, sd


def _passes(path: NaturalSpline, grid: np.ndarray, vmax: np.ndarray, amax: np.ndarray) -> tuple[int, np.ndarray]:
    xs = np.full(len(grid), 7.0)
    verdict = retime_kernels.passes(path.s, path.horner(1), path.horner(2), grid, vmax, amax, xs)
    return verdict, xs


@pytest.mark.parametrize("seed", range(8))
def test_the_passes_are_toppras(kernels, seed):
    path, vmax, amax = _path(seed, still=seed % 3)
    grid = _grid(path, seed)
    code, sd = _toppra(path, grid, vmax, amax)
    verdict, xs = _passes(path, grid, vmax, amax)
    assert code == CODES.Ok and verdict == retime_kernels.OK
    _identical(np.sqrt(xs), sd)


def test_a_path_that_cannot_be_timed_is_toppras_failure(kernels):
    """Negative acceleration limits: even rest violates them, no controllable set (toppra: not
    controllable), and time_parameterize's error is the one of the route with the kernels off."""
    path, vmax, amax = _path(3)
    grid = _grid(path, 3)
    code, _ = _toppra(path, grid, vmax, -amax)
    verdict, _ = _passes(path, grid, vmax, -amax)
    assert code == CODES.FailUncontrollable and verdict == retime_kernels.UNCONTROLLABLE
    messages = []
    for on in (True, False):
        use_kernels(on)
        with pytest.raises(HriplanError, match="TOPP-RA found no time parameterisation") as raised:
            timing._retimed(path, path.s, vmax, -amax, None)
        messages.append(str(raised.value))
    assert messages[0] == messages[1] and "not controllable" in messages[0]


@pytest.mark.parametrize("seed", range(6))
def test_the_check_between_gridpoints_is_timings(kernels, seed):
    path, vmax, amax = _path(seed, still=seed % 2)
    grid = _grid(path, seed)
    _, sd = _toppra(path, grid, vmax, amax)
    rng = np.random.default_rng(seed)
    for scale in (1.0, 1.01, 1.2, 0.9):  # under, near and over the limits
        speeds = sd * scale * rng.uniform(0.98, 1.02, len(sd))
        speeds[rng.random(len(sd)) < 0.03] = np.nan
        found = np.empty(len(grid) - 1, dtype=np.bool_)
        retime_kernels.overshooting(
            path.s, path.horner(1), path.horner(2), grid, speeds, vmax, amax,
            timing._GRID_VELOCITY_TOL, timing._GRID_ACCELERATION_TOL, found,
        )  # fmt: skip
        expected = timing._overshooting(path, grid, speeds, vmax, amax)
        np.testing.assert_array_equal(found, expected)
        assert 0 < expected.sum() < len(expected) or scale == 1.0


@pytest.mark.parametrize("seed", range(6))
def test_time_parameterize_is_the_same_either_way(kernels, seed, monkeypatch):
    rng = np.random.default_rng(seed)
    waypoints = np.cumsum(rng.normal(0.0, 0.1, (8 + 10 * seed, 6)), axis=0)
    vmax, amax = rng.uniform(0.5, 3.0, 6), rng.uniform(2.0, 8.0, 6)
    seen = []
    compiled = retime_kernels.passes

    def passes(*args):
        seen.append(len(args[3]))
        return compiled(*args)

    monkeypatch.setattr(retime_kernels, "passes", passes)
    on = timing.time_parameterize(waypoints, vmax, amax, velocity_scale=0.7)
    use_kernels(False)
    off = timing.time_parameterize(waypoints, vmax, amax, velocity_scale=0.7)
    assert on == off and seen


@pytest.mark.parametrize("seed", range(4))
def test_the_trajectorys_set_up_is_toppras(kernels, seed):
    path, vmax, amax = _path(seed)
    grid = _grid(path, seed)
    xs = np.sqrt(np.abs(np.sin(np.linspace(0.0, np.pi, len(grid))))) * (seed + 0.5)
    xs[0] = xs[-1] = 0.0
    sd, ts, us = np.empty(len(grid)), np.empty(len(grid)), np.empty(len(grid) - 1)
    retime_kernels.constant_acceleration(grid, xs, sd, ts, us)
    theirs = toppra.parametrizer.ParametrizeConstAccel(path, grid, np.sqrt(xs))
    _identical(sd, np.sqrt(xs))
    _identical(ts, theirs._ts)
    _identical(us, theirs._us)
    made = timing._ConstantAcceleration.made(path, grid, sd, ts, us)
    times = np.linspace(0.0, theirs.path_interval[1], 50)
    for order in (0, 1, 2):
        _identical(made(times, order), theirs(times, order))


def test_the_largest_ratio_and_where_are_numpys(kernels):
    rng = np.random.default_rng(5)
    limits = rng.uniform(0.5, 2.0, 6)
    for case in range(40):
        values = rng.normal(size=(30, 6)) * rng.choice([0.1, 1.0])
        if case % 4 == 1:  # ties: the first one counts
            values[[3, 17], 2] = 9.0 * limits[2]
        if case % 4 == 2:
            values[rng.integers(30), rng.integers(6)] = np.nan
        ratio = np.abs(values) / limits
        sample, joint = np.unravel_index(np.argmax(ratio), ratio.shape)
        found = retime_kernels.worst(values, limits)
        assert found[1:] == (sample, joint)
        assert found[0] == ratio[sample, joint] or np.isnan(found[0]) and np.isnan(ratio[sample, joint])


def test_a_limit_exceeded_reads_the_same_either_way(kernels):
    values = np.array([[0.5, -1.2, 0.3], [0.2, 1.3, -1.3]])
    limits = np.array([1.0, 1.0, 1.0])
    messages = []
    for on in (True, False):
        use_kernels(on)
        with pytest.raises(HriplanError, match="exceeds the velocity limit of joint 1 by 30.00% at sample 1") as raised:
            timing._check_limits(values, limits, 1.001, "velocity")
        timing._check_limits(values, limits, 1.5, "velocity")  # within the slack
        messages.append(str(raised.value))
    assert messages[0] == messages[1]
