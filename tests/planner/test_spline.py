"""The spline a joint trajectory controller follows between written points (planner/spline.py),
checked against scipy's own cubic Hermite spline (code hriplan's spline does not share)."""

import numpy as np
import pytest
from scipy.interpolate import CubicHermiteSpline

from hriplan.planner.spline import CHORD_TOLERANCE, Spline


@pytest.fixture
def written(rng):
    times = np.cumsum(np.r_[0.0, rng.uniform(0.05, 0.4, 7)])
    positions = rng.uniform(-1.0, 1.0, (8, 3))
    velocities = rng.uniform(-2.0, 2.0, (8, 3))  # disagreeing with the positions: the spline bulges
    return times, positions, velocities


def test_peak_speeds_are_the_spline_speeds_found_by_dense_sampling(written):
    times, positions, velocities = written
    reference = CubicHermiteSpline(times, positions, velocities).derivative()
    dense = [np.abs(reference(np.linspace(a, b, 20001))).max(axis=0) for a, b in zip(times, times[1:])]
    assert np.allclose(Spline(times, positions, velocities).peak_speeds(), dense, atol=1e-6)


def test_accelerations_are_the_spline_accelerations_found_by_dense_sampling(written):
    times, positions, velocities = written
    reference = CubicHermiteSpline(times, positions, velocities).derivative(2)
    # inside each segment: at a point the second derivative jumps (scipy evaluates either side)
    dense = [np.abs(reference(np.linspace(a, b, 20001)[1:-1])).max(axis=0) for a, b in zip(times, times[1:])]
    assert np.allclose(Spline(times, positions, velocities).accelerations(), dense, rtol=1e-3)


def test_mean_speed_is_displacement_over_time_and_never_above_the_peak(written):
    times, positions, velocities = written
    spline = Spline(times, positions, velocities)
    assert np.allclose(spline.mean_speeds(), np.abs(positions[1:] - positions[:-1]) / (times[1:] - times[:-1])[:, None])
    assert (spline.mean_speeds() <= spline.peak_speeds() + 1e-12).all()


def test_executed_states_lie_on_the_spline_and_straight_lines_between_them_stay_near_it(written):
    times, positions, velocities = written
    reference = CubicHermiteSpline(times, positions, velocities)
    t, p, v = Spline(times, positions, velocities).executed_states()
    assert np.allclose(p, reference(t), atol=1e-12) and np.allclose(v, reference.derivative()(t), atol=1e-9)
    assert set(times) <= set(t) and len(t) > len(times)  # the written points kept, samples added
    fine = np.linspace(0.0, times[-1], 40001)
    chords = np.column_stack([np.interp(fine, t, column) for column in p.T])
    assert np.abs(chords - reference(fine)).max() <= CHORD_TOLERANCE


def test_consistent_dense_points_gain_no_samples():
    # Points on one smooth motion, 10 ms apart, with its exact velocities: what hriplan writes.
    times = np.arange(0.0, 1.0, 0.01)
    positions = np.column_stack([np.sin(2 * times), 0.5 * times**2])
    velocities = np.column_stack([2 * np.cos(2 * times), times])
    spline = Spline(times, positions, velocities)
    assert spline.bulges().max() < CHORD_TOLERANCE / 10
    assert len(spline.executed_states()[0]) == len(times)


def test_a_jump_between_points_at_rest_peaks_at_one_and_a_half_times_its_mean_speed():
    # 0.05 rad in 10 ms, at rest at both ends: a controller's cubic peaks at 1.5 x 5 rad/s mid-way.
    spline = Spline(np.array([0.0, 0.01]), np.array([[0.0], [0.05]]), np.zeros((2, 1)))
    assert spline.mean_speeds()[0, 0] == pytest.approx(5.0)
    assert spline.peak_speeds()[0, 0] == pytest.approx(7.5)
