"""hriplan's lean TOPP-RA passes (`timing._TOPPRA`) give toppra's own answers, bit for bit: the
same controllable sets, path speeds, accelerations and return codes, on joint limits, on the
varying path-speed limit near people, from and to non-zero speeds, when the start is not
controllable, and when the forward pass has to retry (toppra lowers the speed and tries again);
and its trajectory (`timing._ConstantAcceleration`) is toppra's ParametrizeConstAccel's."""

import numpy as np
import pytest
import toppra
import toppra.algorithm

from hriplan.planner.timing import _TOPPRA, _ConstantAcceleration, _joint_limits, _PathSpeedLimit

VMAX = np.array([1.0, 1.5, 2.0, 2.0, 3.0, 3.0])
AMAX = np.array([3.0, 4.0, 6.0, 6.0, 8.0, 8.0])


def _path(seed: int) -> toppra.SplineInterpolator:
    """A smooth random 6-joint path by arc length (30 waypoints)."""
    rng = np.random.default_rng(seed)
    knots = np.cumsum(rng.normal(0.0, 0.08, (30, 6)), axis=0)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(knots, axis=0), axis=1))])
    return toppra.SplineInterpolator(s, knots, bc_type="natural")


def _constraints(path: toppra.SplineInterpolator, limited: bool) -> list:
    constraints = _joint_limits(VMAX, AMAX)
    if limited:  # slow near the middle of the path, as near a person
        at = np.linspace(0.0, path.path_interval[1], 80)
        constraints.append(_PathSpeedLimit(path, VMAX, at, 0.2 + np.abs(at - at.mean())))
    return constraints


class _Failing:
    """toppra's solver, but its forward-pass answer at stage `stage` is NaN the first `times`
    times it is asked (the numerical failure toppra retries at a slightly lower speed)."""

    def __init__(self, solver, stage: int, times: int) -> None:
        self._solver, self._stage, self._left = solver, stage, times

    def __getattr__(self, name: str):
        return getattr(self._solver, name)

    def solve_stagewise_optim(self, i, H, g, x_min, x_max, x_next_min, x_next_max):
        if i == self._stage and not np.isnan(x_min) and self._left > 0:
            self._left -= 1
            return np.full(2, np.nan)
        return self._solver.solve_stagewise_optim(i, H, g, x_min, x_max, x_next_min, x_next_max)


def _both(path, constraints, grid, sd_start=0.0, sd_end=0.0, failing=None):
    """(toppra's, ours): (sdd, sd, v, K, the K it keeps) and the return code of each."""
    out = []
    for kind in (toppra.algorithm.TOPPRA, _TOPPRA):
        algorithm = kind(constraints, path, gridpoints=grid, solver_wrapper="seidel")
        if failing is not None:
            algorithm.solver_wrapper = _Failing(algorithm.solver_wrapper, *failing)
        found = algorithm.compute_parameterization(sd_start, sd_end, return_data=True)
        out.append(((*found, algorithm.problem_data.K), algorithm.problem_data.return_code))
    return out


def _same(a, b) -> None:
    (found_a, code_a), (found_b, code_b) = a, b
    assert code_a == code_b
    for x, y in zip(found_a, found_b):
        if x is None or y is None:
            assert x is None and y is None
        else:
            np.testing.assert_array_equal(x, y)  # bit for bit (NaN where NaN)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("limited", [False, True])
def test_the_same_bits_as_toppra(seed, limited):
    path = _path(seed)
    grid = np.linspace(0.0, path.path_interval[1], 120 + 37 * seed)
    theirs, ours = _both(path, _constraints(path, limited), grid)
    assert theirs[1] == toppra.algorithm.ParameterizationReturnCode.Ok
    assert np.all(theirs[0][1] >= 0.0) and theirs[0][1][0] == 0.0 and theirs[0][1][-1] == 0.0
    _same(theirs, ours)


def test_the_same_from_and_to_a_speed_and_when_the_start_is_too_fast():
    path = _path(7)
    grid = np.linspace(0.0, path.path_interval[1], 150)
    moving = _both(path, _constraints(path, False), grid, sd_start=0.05, sd_end=0.1)
    assert moving[0][1] == toppra.algorithm.ParameterizationReturnCode.Ok and moving[0][0][1][0] == pytest.approx(0.05)
    _same(*moving)
    too_fast = _both(path, _constraints(path, False), grid, sd_start=50.0)
    assert too_fast[0][1] == toppra.algorithm.ParameterizationReturnCode.FailUncontrollable
    _same(*too_fast)
    # Ending fast on a short line, the start must be fast too: toppra lets a start 1e-5 (squared
    # speed) slower than that pass its check, then its forward pass fails.
    assert moving[0][0][3][0, 0] == 0.0
    line = toppra.SplineInterpolator([0.0, 0.05], np.outer([0.0, 0.05], np.full(6, 1 / np.sqrt(6))))
    short = np.linspace(0.0, 0.05, 50)
    slowest = _both(line, _constraints(line, False), short, sd_end=1.0)[0][0][3][0, 0]
    assert slowest > 0.1
    barely = _both(line, _constraints(line, False), short, sd_start=np.sqrt(slowest - 0.5e-5), sd_end=1.0)
    assert barely[0][1] == toppra.algorithm.ParameterizationReturnCode.ErrUnknown
    _same(*barely)


@pytest.mark.parametrize("times", [1, 3, 11])  # 11: more than toppra's 10 tries, it gives up
@pytest.mark.parametrize("stage", [1, 40])  # 1: a squared speed below 1e-5, lowered by 0.1 %, not by 1e-8
def test_the_same_when_the_forward_pass_retries(times, stage):
    path = _path(3)
    grid = np.concatenate([[0.0, 1e-7], np.linspace(0.0, path.path_interval[1], 100)[1:]])
    theirs, ours = _both(path, _constraints(path, True), grid, failing=(stage, times))
    expected = toppra.algorithm.ParameterizationReturnCode
    assert theirs[1] == (expected.ErrUnknown if times > 10 else expected.Ok)
    _same(theirs, ours)
    clean = _both(path, _constraints(path, True), grid)[0]
    assert not np.array_equal(clean[0][1], theirs[0][1], equal_nan=True)  # the retry changed the speeds


def test_an_uncontrollable_path_fails_as_toppra_does():
    """A path speed limit of 0 at the end's neighbourhood but an end speed above it: no
    controllable set (toppra finds NaN on the way back)."""
    path = _path(5)
    grid = np.linspace(0.0, path.path_interval[1], 90)
    at = np.linspace(0.0, path.path_interval[1], 40)
    constraints = [*_joint_limits(VMAX, AMAX), _PathSpeedLimit(path, VMAX, at, np.full(40, 1e-3))]
    theirs, ours = _both(path, constraints, grid, sd_end=2.0)
    assert theirs[1] == toppra.algorithm.ParameterizationReturnCode.FailUncontrollable
    _same(theirs, ours)


@pytest.mark.parametrize("seed", range(4))
def test_the_trajectory_is_toppras_bit_for_bit(seed):
    """Times before the start, at every gridpoint's time, between them, at the end and past it."""
    path = _path(seed)
    grid = np.linspace(0.0, path.path_interval[1], 90 + 20 * seed)
    algorithm = toppra.algorithm.TOPPRA(
        _constraints(path, seed % 2 == 1), path, gridpoints=grid, solver_wrapper="seidel"
    )
    speeds = algorithm.compute_parameterization(0.0, 0.0)[1]
    theirs = toppra.parametrizer.ParametrizeConstAccel(path, grid, speeds)
    ours = _ConstantAcceleration(path, grid, speeds)
    np.testing.assert_array_equal(ours.path_interval, theirs.path_interval)
    end = float(theirs.path_interval[1])
    rng = np.random.default_rng(seed)
    times = np.concatenate([[-0.01, 0.0], theirs._ts, rng.uniform(0.0, end, 300), [end, end + 0.02]])
    for order in (0, 1, 2):
        np.testing.assert_array_equal(ours(times, order), theirs(times, order))
    for a, b in zip(ours._eval_params(times), theirs._eval_params(times)):
        np.testing.assert_array_equal(a, b)
    for order, samples in enumerate(_ConstantAcceleration(path, grid, speeds).samples(times)):  # all at once
        np.testing.assert_array_equal(samples, theirs(times, order))


def test_gridpoints_toppra_refuses_are_refused_alike():
    """The set-up's check of the gridpoints (in one comparison, not toppra's loop): a repeated or
    decreasing gridpoint, or ends that are not the path's, raise toppra's errors."""
    path = _path(0)
    end = path.path_interval[1]
    grid = np.linspace(0.0, end, 50)
    for bad, message in (
        (np.concatenate([grid[:10], grid[9:]]), "Bad input gridpoints"),  # a gridpoint twice
        (grid[[0, 2, 1, *range(3, 50)]], "Bad input gridpoints"),
        (grid[:-1], "Invalid manually supplied gridpoints"),
        (grid + 1e-3, "Invalid manually supplied gridpoints"),
    ):
        for algorithm in (_TOPPRA, toppra.algorithm.TOPPRA):
            with pytest.raises(ValueError, match=message):
                algorithm(_joint_limits(VMAX, AMAX), path, gridpoints=bad, solver_wrapper="seidel")
    made = _TOPPRA(_joint_limits(VMAX, AMAX), path, gridpoints=grid)
    assert made._N == 49 and np.array_equal(made.problem_data.gridpoints, grid) and made.gridpoints is not grid


def test_time_parameterize_takes_the_lean_passes_and_trajectory(monkeypatch):
    """The timing uses both (else the tests above would prove nothing about hriplan's motions),
    with the kernels off as the CLI runs (on, joint limits alone take `retime_kernels`)."""
    from hriplan.planner import timing
    from hriplan.robots import kernel_switch

    monkeypatch.setattr(kernel_switch, "_on", False)

    made = []

    class Seen(_TOPPRA):
        def __init__(self, *args, **kwargs) -> None:
            super().__init__(*args, **kwargs)
            made.append(self)

    monkeypatch.setattr(timing, "_TOPPRA", Seen)
    timing.time_parameterize(np.cumsum(np.full((20, 6), 0.03), axis=0), VMAX, AMAX)
    assert made and all(a.parametrizer is _ConstantAcceleration for a in made)
