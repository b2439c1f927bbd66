import logging

import numpy as np
import pytest
import toppra.algorithm
from scipy.spatial import cKDTree

from hriplan import HriplanError
from hriplan.planner.timing import TimedPath, time_parameterize
from hriplan.robots.kernel_switch import kernels_on, use_kernels

VMAX = np.array([1.0, 1.5, 2.0, 2.0, 3.0, 3.0])
AMAX = np.array([3.0, 4.0, 6.0, 6.0, 8.0, 8.0])


def _curved_path(m: int = 300) -> np.ndarray:
    """A dense polyline (steps ~0.02-0.04 rad) along a smooth 6-joint curve with a tight turn in it."""
    t = np.linspace(0.0, 1.0, m)[:, None]
    freq = np.array([0.5, 0.7, 0.9, 0.6, 0.8, 1.0])
    smooth = 1.5 * np.sin(2 * np.pi * freq * t + np.arange(6))
    turn = 0.4 * np.abs(t - 0.5)  # a V in every joint: a corner at the middle waypoint
    return smooth + turn


def _trapezoid_time(distance: float, vmax: float, amax: float) -> float:
    """Minimum time to move `distance` from rest to rest under |v| <= vmax, |a| <= amax."""
    if distance >= vmax**2 / amax:
        return distance / vmax + vmax / amax
    return 2.0 * np.sqrt(distance / amax)


def _arrays(result: TimedPath) -> tuple[np.ndarray, ...]:
    return tuple(np.array(v) for v in (result.times, result.positions, result.velocities, result.accelerations))


@pytest.mark.parametrize("scale", [1.0, 0.1])  # scale 0.1 on a 2-rad move: triangular profile
def test_straight_path_is_close_to_the_analytic_minimum_time(scale):
    start = np.array([0.2, -0.1, 0.3, 0.0, 1.0, -1.0])
    end = start + np.array([2.0, 0.5, -1.0, 0.3, 0.2, 0.6])  # joint 0 limits both v and a
    result = time_parameterize(np.stack([start, end]), VMAX, AMAX, velocity_scale=scale)
    times, positions, velocities, _ = _arrays(result)

    optimum = _trapezoid_time(2.0, VMAX[0] * scale, AMAX[0] * scale)
    assert optimum * (1 - 1e-3) <= times[-1] <= optimum * 1.05
    # It stays on the segment: every sample is start + lambda (end - start).
    lam = (positions - start) @ (end - start) / np.dot(end - start, end - start)
    np.testing.assert_allclose(positions, start + lam[:, None] * (end - start), atol=1e-9)
    assert np.all(np.diff(lam) >= -1e-12)
    assert result.path_deviation < 1e-9
    # Joint 0 reaches its (scaled) velocity limit only if the move is long enough for that.
    reaches = 2.0 >= (VMAX[0] * scale) ** 2 / (AMAX[0] * scale)
    assert (np.max(np.abs(velocities[:, 0])) > 0.99 * VMAX[0] * scale) == reaches


def test_dense_curved_path_respects_limits_endpoints_and_path():
    waypoints = _curved_path()
    assert 0.01 < np.max(np.abs(np.diff(waypoints, axis=0))) < 0.05
    result = time_parameterize(waypoints, VMAX, AMAX, max_deviation=0.01)
    times, positions, velocities, accelerations = _arrays(result)

    assert times[0] == 0.0
    steps = np.diff(times)
    assert np.all(steps > 0)
    np.testing.assert_allclose(steps[:-1], 0.01, atol=1e-9)
    assert steps[-1] <= 0.01 + 1e-9
    assert positions.shape == velocities.shape == accelerations.shape == (len(times), 6)

    np.testing.assert_allclose(positions[0], waypoints[0], atol=1e-6)
    np.testing.assert_allclose(positions[-1], waypoints[-1], atol=1e-6)
    np.testing.assert_allclose(velocities[[0, -1]], 0.0, atol=1e-9)

    assert np.all(np.abs(velocities) <= VMAX * (1 + 1e-3))
    assert np.all(np.abs(accelerations) <= AMAX * (1 + 5e-2))
    # Time-optimal: some joint is at a limit most of the time, so limits are not left unused.
    assert np.max(np.abs(velocities) / VMAX) > 0.99

    # Max-norm distance of every sample to the polyline (densely resampled, <= 1e-4 rad error).
    fractions = np.linspace(0.0, 1.0, 400, endpoint=False)[:, None, None]
    dense = (waypoints[:-1] + fractions * np.diff(waypoints, axis=0)).reshape(-1, 6)
    distance, _ = cKDTree(np.vstack([dense, waypoints[-1:]])).query(positions, p=np.inf)
    assert 1e-4 < result.path_deviation <= 0.01  # the spline cuts the corner, but only a little
    assert np.max(distance) <= result.path_deviation + 1e-4


def test_half_velocity_scale_is_about_twice_as_slow_when_velocity_limited():
    waypoints = _curved_path()
    amax = 10 * AMAX  # velocity, not acceleration, limits the motion (which scales as 1/scale)
    full = time_parameterize(waypoints, VMAX, amax)
    half = time_parameterize(waypoints, VMAX, amax, velocity_scale=0.5)
    assert half.times[-1] >= 1.9 * full.times[-1]
    _, _, velocities, accelerations = _arrays(half)
    assert np.all(np.abs(velocities) <= 0.5 * VMAX * (1 + 1e-3))
    assert np.all(np.abs(accelerations) <= 0.5 * amax * (1 + 5e-2))


def test_sparse_corner_path_is_densified_and_deviation_is_bounded():
    corner = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]])
    result = time_parameterize(corner, np.ones(2), np.ones(2))
    assert result.path_deviation < 0.01  # knots every <= 0.05 rad keep the spline near the corner
    with pytest.raises(HriplanError, match="max_deviation"):
        time_parameterize(corner, np.ones(2), np.ones(2), max_deviation=1e-4)


def test_duplicate_waypoints_are_dropped_and_sample_period_is_honoured():
    waypoints = np.array([[0.0, 0.0], [0.0, 0.0], [0.5, 0.2], [0.5, 0.2], [1.0, 0.0]])
    result = time_parameterize(waypoints, np.ones(2), np.ones(2), sample_dt=0.05)
    times, positions, _, _ = _arrays(result)
    np.testing.assert_allclose(np.diff(times)[:-1], 0.05, atol=1e-9)
    np.testing.assert_allclose(positions[[0, -1]], waypoints[[0, -1]], atol=1e-6)


def test_toppra_is_quiet(caplog):
    caplog.set_level(logging.DEBUG)
    time_parameterize(_curved_path(50), VMAX, AMAX)
    assert not [r for r in caplog.records if r.name.startswith("toppra")]


def test_toppra_failure_raises(monkeypatch):
    """On toppra's objects (the kernels off; the compiled route's failure: test_retime_kernels.py)."""
    monkeypatch.setattr(toppra.algorithm.TOPPRA, "compute_trajectory", lambda self, *args: None)
    before = kernels_on()
    use_kernels(False)
    try:
        with pytest.raises(HriplanError, match="TOPP-RA found no time parameterisation"):
            time_parameterize(_curved_path(50), VMAX, AMAX)
    finally:
        use_kernels(before)


GOOD = np.array([[0.0, 0.0], [1.0, 0.5]])


@pytest.mark.parametrize(
    ("waypoints", "vmax", "amax", "options", "message"),
    [
        (np.zeros(2), [1, 1], [1, 1], {}, "shape"),
        (GOOD[:1], [1, 1], [1, 1], {}, "m >= 2"),
        (np.zeros((2, 0)), [], [], {}, "shape"),
        (np.array([[0.0, np.nan], [1.0, 0.5]]), [1, 1], [1, 1], {}, "NaN"),
        (np.zeros((3, 2)), [1, 1], [1, 1], {}, "do not move"),
        (GOOD, [1, 1, 1], [1, 1], {}, "velocity_limits must have shape"),
        (GOOD, [1, 1], [[1, 1]], {}, "acceleration_limits must have shape"),
        (GOOD, [1, 0], [1, 1], {}, "velocity_limits must be finite and positive"),
        (GOOD, [1, 1], [-1, 1], {}, "acceleration_limits must be finite and positive"),
        (GOOD, [1, np.nan], [1, 1], {}, "velocity_limits must be finite and positive"),
        (GOOD, [1, 1], [1, np.inf], {}, "acceleration_limits must be finite and positive"),
        (GOOD, [1, 1], [1, 1], {"velocity_scale": 0.0}, "velocity_scale"),
        (GOOD, [1, 1], [1, 1], {"velocity_scale": 1.5}, "velocity_scale"),
        (GOOD, [1, 1], [1, 1], {"velocity_scale": np.nan}, "velocity_scale"),
        (GOOD, [1, 1], [1, 1], {"sample_dt": 0.0}, "sample_dt"),
        (GOOD, [1, 1], [1, 1], {"max_deviation": -1.0}, "max_deviation"),
    ],
)
def test_bad_input_raises_one_line_error(waypoints, vmax, amax, options, message):
    with pytest.raises(HriplanError, match=message) as error:
        time_parameterize(waypoints, np.array(vmax, dtype=float), np.array(amax, dtype=float), **options)
    assert "\n" not in str(error.value)


def test_the_path_speed_limit_gives_toppras_per_gridpoint_bounds():
    """The varying joint-velocity limit near people, computed for all gridpoints at once, gives
    the bounds of TOPP-RA's own per-gridpoint class fed the limit written point by point here:
    joint j within |q'_j(s)| times the smallest path-speed limit within 0.04 (arc length) of s,
    interpolated where no sample is that near, unlimited as 1e6, and within vmax_j."""
    from hriplan.planner.timing import _PathSpeedLimit

    knots = _curved_path(60)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(knots, axis=0), axis=1))])
    path = toppra.SplineInterpolator(s, knots, bc_type="natural")
    at = np.concatenate([np.linspace(0.0, s[-1] / 2, 40), np.linspace(s[-1] / 2 + 0.3, s[-1], 5)])  # a gap
    sd_max = np.abs(np.sin(7 * at)) + 0.05
    sd_max[::9] = np.inf  # no one near there

    def vlim(x: float) -> np.ndarray:
        near = [v for a, v in zip(at, sd_max) if abs(a - x) <= 0.04 + 1e-15]
        cap = min(near) if near else float(np.interp(x, at, sd_max))
        upper = np.minimum(VMAX, np.abs(path(x, 1)) * min(cap, 1e6) + 1e-9)
        return np.stack([-upper, upper], axis=1)

    grid = np.linspace(0.0, s[-1], 301)
    assert any(not any(abs(a - x) <= 0.04 for a in at) for x in grid)  # the gap is interpolated
    ours = _PathSpeedLimit(path, VMAX, at, sd_max).compute_constraint_params(path, grid)
    theirs = toppra.constraint.JointVelocityConstraintVarying(vlim).compute_constraint_params(path, grid)
    np.testing.assert_allclose(ours[-1], theirs[-1], rtol=1e-12, atol=0.0)
    assert all(a is None and b is None for a, b in zip(ours[:-1], theirs[:-1]))
    made = _PathSpeedLimit(path, VMAX, at, sd_max)  # set up without asking vlim: the same joints, the same vlim
    assert made.get_dof() == 6 and made.get_constraint_type() == toppra.constraint.ConstraintType.CanonicalLinear
    np.testing.assert_allclose(made.vlim_func(grid[7]), vlim(grid[7]), rtol=1e-12, atol=0.0)
    assert made.vlim_func(grid[7]).shape == (6, 2)


def test_joint_limit_constraints_are_made_once_per_limits():
    """The same limits give TOPP-RA the same constraint objects (a fresh list), other limits
    other constraints, holding those limits."""
    from hriplan.planner.timing import _joint_limits

    first, again = _joint_limits(VMAX, AMAX), _joint_limits(VMAX.copy(), AMAX.copy())
    assert first is not again and all(a is b for a, b in zip(first, again))
    other = _joint_limits(VMAX, 2 * AMAX)
    assert other[0] is not first[0]
    np.testing.assert_array_equal(other[0].vlim, np.stack([-VMAX, VMAX], axis=1))
    np.testing.assert_array_equal(other[1].alim, np.stack([-2 * AMAX, 2 * AMAX], axis=1))


def test_segments_are_subdivided_into_equal_parts():
    """Segment i of a polyline split into max(1, pieces[i]) equal parts, the last point kept: the
    parts' fractions k / p of each segment, as numbers (2/3 of a segment, not a rounding of it)."""
    from hriplan.planner.timing import _subdivided

    points = np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 6.0], [4.0, 6.0], [4.0, 8.0]])
    split = _subdivided(points, np.array([3.0, 0.0, 1.0, 2.0]))
    expected = [[0, 0], [1, 0], [2, 0], [3, 0], [4, 6], [4, 7], [4, 8]]
    np.testing.assert_array_equal(split[[0, 1, 2, 3, 5, 6, 7]], expected)
    np.testing.assert_array_equal(split[4], [3.0, 6.0])
    assert len(split) == 8
    fine = _subdivided(np.array([0.0, 1.0, 2.0]), np.array([7.0, 3.0]))  # 1-D points, uneven parts
    np.testing.assert_array_equal(fine, np.concatenate([np.arange(7) / 7, 1 + np.arange(3) / 3, [2.0]]))


def test_overshooting_intervals_are_those_whose_quarter_points_exceed_a_limit():
    """`_overshooting` against the motion it describes, point by point: in each grid interval,
    constant path acceleration u = (x1 - x0) / (2 ds) from x0 = sd0^2; at its quarter points the
    joint velocity q' sqrt(x) and acceleration q'' x + q' u over the limits, flagged past the grid
    tolerances. Speeds scaled so that some intervals overshoot and some do not, by either limit."""
    from hriplan.planner import timing
    from hriplan.planner.natural_spline import NaturalSpline

    knots = _curved_path(40)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(knots, axis=0), axis=1))])
    path = NaturalSpline(s, knots)
    rng = np.random.default_rng(3)
    grid = np.sort(np.concatenate([s[[0, -1]], rng.uniform(s[0], s[-1], 150)]))
    sd = rng.uniform(0.2, 1.2, len(grid))  # jumps: accelerations over
    sd[len(grid) // 2 :] = np.linspace(0.7, 1.0, len(grid) - len(grid) // 2)  # smooth and fast: velocities over
    vmax = VMAX / 3
    found = timing._overshooting(path, grid, sd, vmax, AMAX)
    expected, by = [], set()
    for i in range(len(grid) - 1):
        x0, ds = sd[i] ** 2, grid[i + 1] - grid[i]
        u = (sd[i + 1] ** 2 - x0) / (2 * ds)
        worst_v = worst_a = 0.0
        for f in (0.25, 0.5, 0.75):
            x = max(x0 + 2 * u * f * ds, 0.0)
            d1, d2 = path(grid[i] + f * ds, 1), path(grid[i] + f * ds, 2)
            worst_v = max(worst_v, float(np.max(np.abs(d1) * np.sqrt(x) / vmax)))
            worst_a = max(worst_a, float(np.max(np.abs(d2 * x + d1 * u) / AMAX)))
        over_v, over_a = worst_v > 1 + 5e-4 + 1e-9, worst_a > 1 + 5e-3 + 1e-9
        near = abs(worst_v - 1 - 5e-4) < 1e-9 or abs(worst_a - 1 - 5e-3) < 1e-9
        expected.append(None if near else over_v or over_a)
        by |= {"velocity"} if over_v and not over_a else {"acceleration"} if over_a and not over_v else set()
    assert [e for e in expected if e is not None] == [bool(f) for f, e in zip(found, expected) if e is not None]
    assert 0 < sum(found) < len(found) and by == {"velocity", "acceleration"}


@pytest.mark.parametrize("mirror", [1.0, -1.0])  # the largest gap on either side of the polyline
def test_the_deviation_is_the_largest_gap_at_sixteenths_of_every_knot_interval(mirror):
    """`_deviation` against the spline and the polyline compared point by point: at 1/16 .. 15/16
    of each knot interval (of a corner path, where the spline strays), the largest |difference|
    of any joint."""
    from hriplan.planner import timing
    from hriplan.planner.natural_spline import NaturalSpline

    knots = timing._densified(mirror * np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.2, 1.3]]))
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(knots, axis=0), axis=1))])
    path = NaturalSpline(s, knots)
    gaps = [
        path(s[i] + f * (s[i + 1] - s[i])) - (knots[i] + f * (knots[i + 1] - knots[i]))
        for i in range(len(s) - 1)
        for f in np.arange(1, 16) / 16
    ]
    largest = max(np.abs(gaps).ravel())
    assert largest > 1e-4 and timing._deviation(path, s, knots) == pytest.approx(largest, rel=1e-12, abs=0.0)
