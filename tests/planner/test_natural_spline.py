"""The path TOPP-RA retimes (planner/natural_spline.py) against scipy's natural cubic spline, code
it does not share, and against the properties that define a natural spline."""

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from hriplan.planner.natural_spline import NaturalSpline


def _path(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """n knots of a random 6-joint walk, parameterised by arc length (as timing does)."""
    knots = np.cumsum(np.random.default_rng(seed).normal(size=(n, 6)) * 0.03, axis=0)
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(knots, axis=0), axis=1))]), knots


@pytest.mark.parametrize("n", [2, 3, 4, 5, 40, 700])
def test_it_is_scipys_natural_cubic_spline(n):
    s, knots = _path(n, seed=n)
    ours, scipys = NaturalSpline(s, knots), CubicSpline(s, knots, bc_type="natural")
    at = np.concatenate([np.linspace(s[0] - 0.05, s[-1] + 0.05, 3001), s])  # beyond both ends, and at the knots
    for order in (0, 1, 2):
        reference = scipys(at, order)
        assert np.max(np.abs(ours(at, order) - reference)) <= 1e-12 * max(1.0, np.max(np.abs(reference)))
    assert ours.dof == 6 and list(ours.path_interval) == [s[0], s[-1]]


def test_it_interpolates_with_zero_curvature_at_the_ends_and_is_twice_differentiable():
    s, knots = _path(30, seed=1)
    spline = NaturalSpline(s, knots)
    assert np.max(np.abs(spline(s) - knots)) < 1e-14
    np.testing.assert_array_equal(spline(s[:-1]), knots[:-1])  # a knot starts its interval: exactly its knot
    assert np.max(np.abs(spline(s[[0, -1]], 2))) < 1e-12
    inner, eps = s[1:-1], 1e-9
    for order in (0, 1, 2):  # continuous across every inner knot
        assert np.max(np.abs(spline(inner + eps, order) - spline(inner - eps, order))) < 1e-5  # |q'''| 2 eps
    mid, h = (s[:-1] + s[1:]) / 2, 1e-6  # and each derivative is the one of the order below
    for order in (1, 2):
        numeric = (spline(mid + h, order - 1) - spline(mid - h, order - 1)) / (2 * h)
        assert np.max(np.abs(numeric - spline(mid, order))) < 1e-6 * max(1.0, np.max(np.abs(numeric)))


def test_shapes_follow_the_input():
    s, knots = _path(5, seed=2)
    spline = NaturalSpline(s, knots)
    assert spline(0.1).shape == (6,) and spline(np.array([0.1, 0.2])).shape == (2, 6)
    assert spline(np.zeros((3, 4)), 1).shape == (3, 4, 6)


def test_values_asked_again_are_the_same_and_the_callers_own():
    """The values at the positions last asked about are kept, by order: asked again (as TOPP-RA's
    constraints ask), each order's values are the same bits, in an array the caller may change
    without changing the next answer; other positions, or the same numbers in another shape,
    are evaluated anew."""
    s, knots = _path(40, seed=3)
    spline, fresh = NaturalSpline(s, knots), NaturalSpline(s, knots)
    at, other = np.linspace(s[0], s[-1], 101), np.linspace(s[0], s[-1], 77)
    first = {order: spline(at, order) for order in (1, 2, 0)}
    for order, values in first.items():
        again = spline(at, order)
        assert np.array_equal(again, values) and again is not values
        again[:] = 7.0
        assert np.array_equal(spline(at, order), fresh(at, order))
    assert np.array_equal(spline(other, 1), fresh(other, 1))
    assert np.array_equal(spline(at, 1), fresh(at, 1))
    square = at[:100].reshape(10, 10)
    assert spline(at[:100], 1).shape == (100, 6) and spline(square, 1).shape == (10, 10, 6)


@pytest.mark.parametrize(
    ("s", "knots", "message"),
    [
        ([0.0], [[0.0]], "n >= 2"),
        ([0.0, 1.0], [[0.0], [1.0], [2.0]], "n >= 2"),
        ([0.0, 1.0, 1.0], [[0.0], [1.0], [2.0]], "increase strictly"),
    ],
)
def test_bad_input_is_refused(s, knots, message):
    with pytest.raises(ValueError, match=message):
        NaturalSpline(np.array(s), np.array(knots))
    if message == "n >= 2":
        return
    with pytest.raises(ValueError, match="order"):
        NaturalSpline(np.array([0.0, 1.0]), np.array([[0.0], [1.0]]))(0.5, 3)


def _horner(spline: NaturalSpline, at: np.ndarray, order: int) -> np.ndarray:
    """The spline's value by its coefficients of (s - s_i)^k, each point on its own: the interval
    found by a scan, the derivatives' factors applied to that interval's coefficients."""
    out = []
    for p in at.tolist():
        i = min(max(int(np.sum(spline.s[1:-1] <= p)), 0), len(spline.s) - 2)
        t = p - spline.s[i]
        c0, c1, c2, c3 = spline._coefficients[:, i]
        if order == 0:
            out.append(c0 + t * (c1 + t * (c2 + t * c3)))
        elif order == 1:
            out.append(c1 + t * (2.0 * c2 + t * (3.0 * c3)))
        else:
            out.append(2.0 * c2 + t * (6.0 * c3))
    return np.array(out)


def test_every_order_is_its_horner_form_bit_for_bit_whatever_was_asked_before():
    """Orders asked in any sequence, at positions that change between the calls (each point's
    interval and offset are kept for the positions last asked: new positions must not reuse them),
    are the point-by-point Horner form of the coefficients, to the bit."""
    s, knots = _path(25, seed=5)
    spline = NaturalSpline(s, knots)
    rng = np.random.default_rng(5)
    places = [np.sort(rng.uniform(s[0] - 0.02, s[-1] + 0.02, k)) for k in (40, 40, 17)] + [s]
    for at, orders in zip(places, [(2, 1, 0), (0, 2), (1, 1, 2), (2, 0, 1)]):
        for order in orders:
            np.testing.assert_array_equal(spline(at, order), _horner(spline, at, order))


@pytest.mark.parametrize("n", [2, 3, 4, 5, 40, 300])
def test_the_compiled_route_gives_the_same_bits(n):
    """With the kernels on the solve and the evaluation are compiled (`spline_kernels.py`): the
    same coefficients and values as the Python and numpy route, to the bit, at positions inside,
    at the knots and beyond both ends, as a number and in any shape."""
    pytest.importorskip("numba")
    from hriplan.robots.kernel_switch import kernels_on, use_kernels

    s, knots = _path(n, seed=10 + n)
    rng = np.random.default_rng(n)
    places = [rng.uniform(s[0] - 0.05, s[-1] + 0.05, 333), s, np.sort(rng.uniform(s[0], s[-1], 24)).reshape(4, 6)]
    before = kernels_on()
    try:
        found = {}
        for on in (False, True):
            use_kernels(on)
            spline = NaturalSpline(s, knots)
            found[on] = [spline._coefficients] + [spline(at, order) for at in places for order in (0, 1, 2)]
            found[on] += [spline(float(s[-1]) / 3, order) for order in (2, 0)]
    finally:
        use_kernels(before)
    assert len(found[True]) == len(found[False]) == 12
    for compiled, numpy_route in zip(found[True], found[False]):
        assert compiled.shape == numpy_route.shape and compiled.tobytes() == numpy_route.tobytes()  # -0.0 too
    assert (n == 2) == np.all(found[True][0][2] == 0.0)  # curved but for two knots: the solve answered
