"""The path's preparation compiled (`planner/path_kernels.py`) gives timing.py's numpy answers,
bit for bit: numpy's row norms (pairwise sums, any joint count) and np.interp, the knots and
their arc lengths, the spline's deviation and the initial gridpoints (corners marked or not),
on random paths of 1 to 17 joints; the samples of a timing (`retime_kernels.samples`); and
validate.py's densified path (NaN, infinities and steps far below the changes included)."""

import numpy as np
import pytest

pytest.importorskip("numba")

from hriplan.planner import path_kernels, retime_kernels, timing, validate
from hriplan.planner.natural_spline import NaturalSpline
from hriplan.robots.kernel_switch import kernels_on, use_kernels


def _numpy(function, *args):
    """`function` on timing's numpy route (the kernels off)."""
    before = kernels_on()
    use_kernels(False)
    try:
        return function(*args)
    finally:
        use_kernels(before)


def _waypoints(seed: int, dof: int, count: int = 25) -> np.ndarray:
    rng = np.random.default_rng(seed)
    steps = rng.normal(0.0, 0.1, (count, dof)) * rng.choice([0.1, 1.0, 3.0], size=(count, 1))
    return np.cumsum(steps, axis=0)


def _identical(found: np.ndarray, expected: np.ndarray) -> None:
    np.testing.assert_array_equal(found, expected)
    assert found.shape == expected.shape


@pytest.mark.parametrize("n", [1, 2, 6, 7, 8, 9, 15, 16, 17, 130, 300])
def test_a_rows_norm_is_numpys(kernels, n):
    rows = np.random.default_rng(n).normal(size=(400, n)) * np.logspace(-3, 3, 400)[:, None]
    squares = np.empty(n)
    _identical(np.array([path_kernels._norm(row, squares) for row in rows]), np.linalg.norm(rows, axis=1))


def test_interpolation_is_numpys(kernels):
    rng = np.random.default_rng(1)
    xp = np.cumsum(rng.uniform(0.01, 1.0, 50))
    fp = rng.normal(size=50)
    x = np.concatenate([rng.uniform(xp[0] - 1, xp[-1] + 1, 3000), xp, [np.nan]])
    _identical(np.array([path_kernels._interp(v, xp, fp) for v in x]), np.interp(x, xp, fp))


@pytest.mark.parametrize("dof", [1, 2, 6, 7, 9, 17])
@pytest.mark.parametrize("seed", range(3))
def test_the_knots_and_their_arc_lengths_are_timings(kernels, dof, seed):
    q = _waypoints(seed, dof)
    knots, s = path_kernels.knots(q, timing._MAX_KNOT_SPACING)
    expected_knots, expected_s = _numpy(timing._knots, q)
    _identical(knots, expected_knots)
    _identical(s, expected_s)
    assert len(knots) > len(q)  # segments were split


@pytest.mark.parametrize("dof", [2, 6, 7, 9])
@pytest.mark.parametrize("seed", range(4))
def test_the_deviation_and_the_gridpoints_are_timings(kernels, dof, seed):
    q = _waypoints(seed, dof, count=10 + 15 * seed)
    knots, s = _numpy(timing._knots, q)
    path = NaturalSpline(s, knots)
    rng = np.random.default_rng(seed)
    vmax, amax = rng.uniform(0.5, 3.0, dof), rng.uniform(1.0, 8.0, dof)
    assert timing._deviation(path, s, knots) == _numpy(timing._deviation, path, s, knots)
    grid = timing._gridpoints(path, s, vmax, amax)
    _identical(grid, _numpy(timing._gridpoints, path, s, vmax, amax))
    assert grid[0] == s[0] and grid[-1] == s[-1] and np.all(np.diff(grid) > 0)


def test_gridpoints_at_sharp_corners_and_on_short_paths_are_timings(kernels):
    """Corners marked as gridpoints (the kink test), a path of two knots (no corner to test),
    and a long one capped at the most gridpoints."""
    corner = np.array([[0.0, 0.0], [0.5, 0.0], [0.5, 0.5], [1.0, 0.5], [1.0, 1.0]])
    vmax, amax = np.ones(2), np.array([2.0, 3.0])
    grids = []
    for q in (corner, corner[:2], np.array([[0.0, 0.0], [800.0, 600.0]])):
        knots, s = _numpy(timing._knots, q)
        path = NaturalSpline(s, knots)
        grids.append((timing._gridpoints(path, s, vmax, amax), s))
        _identical(grids[-1][0], _numpy(timing._gridpoints, path, s, vmax, amax))
    (cornered, s), _, (capped, _) = grids
    assert np.isin(s[1:-1], cornered).any()  # corners' knots are gridpoints
    assert len(capped) == 20_001


@pytest.mark.parametrize("seed", range(4))
def test_the_samples_are_timings(kernels, seed):
    q = _waypoints(seed, 6)
    rng = np.random.default_rng(seed)
    knots, s = timing._knots(q)
    path = NaturalSpline(s, knots)
    grid = np.linspace(s[0], s[-1], 200)
    sd = np.sqrt(np.abs(np.sin(np.linspace(0.0, np.pi, 200)))) * rng.uniform(0.5, 2.0)
    trajectory = timing._ConstantAcceleration(path, grid, sd)
    duration = trajectory.path_interval[1]
    times = np.concatenate([np.linspace(0.0, duration, 333), [duration * 1.5, -0.1]])  # past the end, before 0
    found = trajectory.samples(times)
    expected = _numpy(trajectory.samples, times)
    for ours, theirs in zip(found, expected):
        _identical(ours, theirs)
    positions = np.empty((len(times), 6))
    velocities, accelerations = np.empty_like(positions), np.empty_like(positions)
    horner = (path.horner(0), path.horner(1), path.horner(2))
    args = (trajectory._ts, trajectory._us, trajectory._velocities, trajectory._ss, path.s, horner)
    retime_kernels.samples(*args, times, positions, velocities, accelerations)
    _identical(accelerations, expected[2])


@pytest.mark.parametrize("dof", [2, 7, 9])
def test_time_parameterize_is_the_same_either_way(kernels, dof):
    q = _waypoints(dof, dof, count=20)
    vmax, amax = np.full(dof, 1.5), np.full(dof, 4.0)
    assert timing.time_parameterize(q, vmax, amax) == _numpy(timing.time_parameterize, q, vmax, amax)


@pytest.mark.parametrize("dof", [1, 2, 6, 7, 17])
@pytest.mark.parametrize("step", [0.01, 0.05, 1e-300, 3.0, 0.0])
def test_the_densified_path_is_validates(kernels, dof, step):
    q = _waypoints(dof, dof, 12)
    q[3] = q[2]  # a segment that does not move
    if step == 1e-300:
        q = q[:4]  # pieces beyond int64: one each
    # (a path not finite is refused before either route: test_validate_path.py)
    with np.errstate(invalid="ignore", divide="ignore"):  # numpy's cast of inf, / 0 (step 0: numpy's)
        found = validate.densify(q, step)
        _identical(found, _numpy(validate.densify, q, step))
    assert len(found) > len(q) or step != 0.01  # segments were split
    _identical(validate.densify(list(q[:1]), step), q[:1])  # one row: itself
