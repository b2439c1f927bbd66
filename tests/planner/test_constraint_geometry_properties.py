"""Invariants of the constraint geometry (hypothesis): each signed distance is negative exactly
inside its solid (membership computed here, not by the module), zero on its surface, 1-Lipschitz,
with a unit gradient along which it grows at rate 1; orientation errors against their formulas and
their gradients against finite differences."""

from __future__ import annotations

import math
import os

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import Phase, assume, given, settings
from hypothesis import strategies as st

from hriplan.planner.constraints import geometry as G

# Reproducible and short; `make mutation` runs each property on fewer examples (many mutants).
settings.register_profile("ci", max_examples=200, deadline=None, derandomize=True)
settings.register_profile(
    "mutation", max_examples=25, deadline=None, derandomize=True, phases=[Phase.explicit, Phase.generate]
)
settings.load_profile(os.environ.get("HRIPLAN_HYPOTHESIS_PROFILE", "ci"))

coord = st.floats(-2.0, 2.0, allow_nan=False)
points = st.tuples(coord, coord, coord).map(np.array)
lengths = st.floats(0.05, 1.5)


def _inside(shape: str, p: np.ndarray, a: float, b: float, c: float, tol: float = 0.0) -> bool:
    x, y, z = p
    rho = math.hypot(x, y)
    if shape == "box":
        return abs(x) <= a / 2 + tol and abs(y) <= b / 2 + tol and abs(z) <= c / 2 + tol
    if shape == "sphere":
        return math.sqrt(float(p @ p)) <= a + tol
    if shape == "cylinder":
        return rho <= a + tol and -tol <= z <= b + tol
    return -tol <= z <= b + tol and rho * b <= a * z + tol  # cone: apex at the origin, radius a at z = b


def _sd(shape: str, a: float, b: float, c: float):
    """The shape's signed distance, its gradient as an array (geometry gives a tuple of floats)."""
    sd = {
        "box": lambda p: G.box_sd(p, (a, b, c)),
        "sphere": lambda p: G.sphere_sd(p, a),
        "cylinder": lambda p: G.cylinder_sd(p, a, b),
        "cone": lambda p: G.cone_sd(p, a, b),
    }[shape]

    def with_array(p: np.ndarray) -> tuple[float, np.ndarray]:
        d, grad = sd(p)
        return d, np.asarray(grad)

    return with_array


SHAPES = ["box", "sphere", "cylinder", "cone"]


@pytest.mark.parametrize("shape", SHAPES)
@given(p=points, a=lengths, b=lengths, c=lengths)
def test_the_signed_distance_is_negative_exactly_inside(shape: str, p: np.ndarray, a: float, b: float, c: float):
    d, _ = _sd(shape, a, b, c)(p)
    assume(abs(d) > 1e-9)  # on the surface membership is a matter of rounding
    assert (d < 0.0) == _inside(shape, p, a, b, c)


@pytest.mark.parametrize("shape", SHAPES)
@given(p=points, q=points, a=lengths, b=lengths, c=lengths)
def test_the_signed_distance_is_1_lipschitz(shape: str, p: np.ndarray, q: np.ndarray, a: float, b: float, c: float):
    sd = _sd(shape, a, b, c)
    assert abs(sd(p)[0] - sd(q)[0]) <= np.linalg.norm(p - q) + 1e-9


@pytest.mark.parametrize("shape", SHAPES)
@given(p=points, a=lengths, b=lengths, c=lengths)
def test_the_gradient_is_a_unit_vector_to_the_nearest_surface_point(
    shape: str, p: np.ndarray, a: float, b: float, c: float
):
    """p - d grad is on the surface (distance 0), and d grows at rate 1 along grad (convex solids)."""
    sd = _sd(shape, a, b, c)
    assume(math.hypot(p[0], p[1]) > 1e-3)  # the axis of a round solid has no radial direction
    d, grad = sd(p)
    assert np.linalg.norm(grad) == pytest.approx(1.0)
    assert sd(p - d * grad)[0] == pytest.approx(0.0, abs=1e-9)
    h = 1e-7
    assume(abs(d) > 10 * h)
    assert (sd(p + h * grad)[0] - d) / h == pytest.approx(1.0, abs=1e-3)


def _surface_point(shape: str, a: float, b: float, c: float, u: float, w: float, face: int) -> np.ndarray:
    """A point on the solid's surface, from two parameters in [0, 1] and a face number."""
    angle = 2.0 * math.pi * u
    if shape == "box":
        p = np.array([(u - 0.5) * a, (w - 0.5) * b, (w - 0.5) * c])
        axis, sign = face % 3, (1.0 if face < 3 else -1.0)
        p[axis] = sign * (a, b, c)[axis] / 2
        return p
    if shape == "sphere":
        polar = math.pi * w
        return a * np.array([math.sin(polar) * math.cos(angle), math.sin(polar) * math.sin(angle), math.cos(polar)])
    if shape == "cylinder":
        rho, z = (a, w * b) if face % 2 == 0 else (w * a, b * (face % 4 == 1))
        return np.array([rho * math.cos(angle), rho * math.sin(angle), z])
    z = w * b
    rho = a * z / b if face % 2 == 0 else w * a  # the slant or the top
    return np.array([rho * math.cos(angle), rho * math.sin(angle), z if face % 2 == 0 else b])


surface = {"u": st.floats(0.0, 1.0), "w": st.floats(0.0, 1.0), "face": st.integers(0, 5)}


@pytest.mark.parametrize("shape", SHAPES)
@given(a=lengths, b=lengths, c=lengths, **surface)
def test_the_signed_distance_is_zero_on_the_surface(
    shape: str, a: float, b: float, c: float, u: float, w: float, face: int
):
    d, grad = _sd(shape, a, b, c)(_surface_point(shape, a, b, c, u, w, face))
    assert d == pytest.approx(0.0, abs=1e-12)
    assert np.linalg.norm(grad) == pytest.approx(1.0)


@pytest.mark.parametrize("shape", SHAPES)
@given(p=points, a=lengths, b=lengths, c=lengths, **surface)
def test_the_distance_is_to_the_nearest_point_of_the_solid(
    shape: str, p: np.ndarray, a: float, b: float, c: float, u: float, w: float, face: int
):
    """|d| is at most the distance to any surface point, and p - d grad is a point of the solid."""
    d, grad = _sd(shape, a, b, c)(p)
    assert abs(d) <= np.linalg.norm(p - _surface_point(shape, a, b, c, u, w, face)) + 1e-9
    assert _inside(shape, p - d * grad, a, b, c, tol=1e-9)


def test_on_the_cone_surface_the_gradient_is_the_outward_normal():
    slant = math.hypot(0.5, 1.0)
    d, grad = G.cone_sd(np.array([0.25, 0.0, 0.5]), 0.5, 1.0)
    assert d == 0.0 and grad == pytest.approx([1.0 / slant, 0.0, -0.5 / slant])
    d, grad = G.cone_sd(np.array([0.0, 0.25, 1.0]), 0.5, 1.0)
    assert d == 0.0 and grad == pytest.approx([0.0, 0.0, 1.0])


unit = st.tuples(coord, coord, coord).map(np.array).filter(lambda v: np.linalg.norm(v) > 0.1)


def test_at_the_centre_of_a_sphere_the_gradient_is_up():
    assert G.sphere_sd(np.zeros(3), 0.5) == (-0.5, pytest.approx([0.0, 0.0, 1.0]))


def test_a_half_turn_twists_by_plus_pi_and_a_half_turn_swing_has_no_twist_gradient():
    """q = (0, z): w = 0 is not flipped, so the twist stays in (-pi, pi]; a half-turn about x has
    s = c = 0 (no twist defined) and gives a zero gradient, not NaN."""
    z = np.array([0.0, 0.0, 1.0])
    assert G.twist_angle(np.diag([-1.0, -1.0, 1.0]), z)[0] == pytest.approx(math.pi)
    angle, grad = G.twist_angle(np.diag([1.0, -1.0, -1.0]), z)
    assert angle == 0.0 and np.array_equal(grad, np.zeros(3))


def test_orientation_errors_at_zero_have_a_zero_gradient():
    """No rotation (or u = v) has no direction to turn back along: the gradient is 0, not NaN."""
    for angle, grad in (
        G.rotation_angle(np.eye(3)),
        G.axis_angle(np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, 1.0])),
    ):
        assert angle == 0.0 and np.array_equal(grad, np.zeros(3))
    assert G.axis_angle(np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, -1.0]))[0] == pytest.approx(math.pi)


@given(u=unit, v=unit, w=unit)
def test_axis_angle_is_the_angle_between_the_axes_and_its_gradient_moves_u(u: np.ndarray, v: np.ndarray, w: np.ndarray):
    u, v = u / np.linalg.norm(u), v / np.linalg.norm(v)
    angle, grad = G.axis_angle(u, v)
    assert angle == pytest.approx(math.acos(np.clip(u @ v, -1.0, 1.0)), abs=1e-6)
    assume(0.01 < angle < math.pi - 0.01)
    h = 1e-7
    moved = pin.exp3(h * w) @ u  # du = w x u
    assert (G.axis_angle(moved, v)[0] - angle) / h == pytest.approx(float(grad @ w), abs=1e-4)


rotations = st.tuples(coord, coord, coord).map(lambda v: pin.exp3(np.array(v)))


@given(r=rotations, w=unit)
def test_rotation_angle_is_the_log_norm_and_its_gradient_is_a_local_velocity(r: np.ndarray, w: np.ndarray):
    angle, grad = G.rotation_angle(r)
    assert angle == pytest.approx(math.acos(np.clip((np.trace(r) - 1.0) / 2.0, -1.0, 1.0)), abs=1e-6)
    assume(0.01 < angle < math.pi - 0.01)
    h = 1e-7
    assert (G.rotation_angle(r @ pin.exp3(h * w))[0] - angle) / h == pytest.approx(float(grad @ w), abs=1e-4)


@given(theta=st.floats(-math.pi + 1e-3, math.pi - 1e-3), axis=unit, swing=coord, w=unit)
def test_twist_angle_is_the_rotation_about_the_axis_and_its_gradient_a_local_velocity(
    theta: float, axis: np.ndarray, swing: float, w: np.ndarray
):
    axis = axis / np.linalg.norm(axis)
    r_twist = pin.exp3(theta * axis)
    assert G.twist_angle(r_twist, axis)[0] == pytest.approx(theta, abs=1e-9)
    # a swing about an axis perpendicular to `axis`, applied after the twist, leaves the twist
    perpendicular = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    perpendicular /= np.linalg.norm(perpendicular)
    r = pin.exp3(0.5 * swing * perpendicular) @ r_twist
    angle, grad = G.twist_angle(r, axis)
    assert angle == pytest.approx(theta, abs=1e-9)
    assume(abs(angle) < math.pi - 0.01)
    h = 1e-7
    assert (G.twist_angle(r @ pin.exp3(h * w), axis)[0] - angle) / h == pytest.approx(float(grad @ w), abs=1e-4)


@given(a=unit, b=unit)
def test_cross_is_the_cross_product(a: np.ndarray, b: np.ndarray):
    assert G.cross(a, b) == pytest.approx(np.cross(a, b))
