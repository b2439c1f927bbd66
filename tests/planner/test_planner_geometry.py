"""Constraint geometry and the evaluator's analytic Jacobians against finite differences."""

import functools

import numpy as np
import pinocchio as pin
import pytest

from hriplan.planner.constraints import geometry as G
from hriplan.planner.constraints.binding import bind
from hriplan.planner.constraints.evaluator import ConstraintEvaluator
from hriplan.planner.constraints.spec import (
    BoxConstraint,
    ConeConstraint,
    CylinderConstraint,
    FrameRef,
    OrientationConstraint,
    SphereConstraint,
)
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.scene import Scene
from hriplan.robots.spatial import Pose

EPS = 1e-6
EPS_JAC = 1e-7  # central differences of the evaluator rows
SHAPES = {
    "box": lambda p: G.box_sd(p, (0.4, 0.3, 0.2)),
    "sphere": lambda p: G.sphere_sd(p, 0.3),
    "cylinder": lambda p: G.cylinder_sd(p, 0.2, 0.5),
    "cone": lambda p: G.cone_sd(p, 0.2, 0.4),
}


@pytest.mark.parametrize("name", SHAPES)
def test_signed_distance_gradients(name, rng):
    sd = SHAPES[name]
    for p in rng.uniform(-0.6, 0.6, (300, 3)):
        value, grad = sd(p)
        numeric = np.array([(sd(p + EPS * e)[0] - sd(p - EPS * e)[0]) / (2 * EPS) for e in np.eye(3)])
        assert np.allclose(numeric, grad, atol=1e-6), (name, p)


def test_signed_distance_values_follow_the_semantics():
    assert G.box_sd(np.array([0.3, 0.0, 0.0]), (0.4, 0.3, 0.2))[0] == pytest.approx(0.1)
    assert G.box_sd(np.zeros(3), (0.4, 0.3, 0.2))[0] == pytest.approx(-0.1)  # half the height
    # cylinder: base at z = 0, top at z = h
    assert G.cylinder_sd(np.array([0.0, 0.0, -0.1]), 0.2, 0.5)[0] == pytest.approx(0.1)
    assert G.cylinder_sd(np.array([0.0, 0.0, 0.45]), 0.2, 0.5)[0] == pytest.approx(-0.05)
    # cone: apex at the origin, radius r z / h
    assert G.cone_sd(np.array([0.05, 0.0, 0.2]), 0.2, 0.4)[0] < 0.0 < G.cone_sd(np.array([0.15, 0.0, 0.2]), 0.2, 0.4)[0]
    assert G.cone_sd(np.array([0.0, 0.0, -0.1]), 0.2, 0.4)[0] == pytest.approx(0.1)


def test_orientation_errors_and_their_gradients(rng):
    axis = np.array([0.0, 0.0, 1.0])
    assert G.twist_angle(pin.exp3(np.array([0.4, 0.0, 0.0])) @ pin.exp3(np.array([0.0, 0.0, 0.3])), axis)[
        0
    ] == pytest.approx(0.3)
    for _ in range(100):
        r = pin.exp3(rng.normal(size=3))
        for func in (G.rotation_angle, lambda m: G.twist_angle(m, axis)):
            grad = func(r)[1]
            numeric = [
                (func(r @ pin.exp3(EPS * e))[0] - func(r @ pin.exp3(-EPS * e))[0]) / (2 * EPS) for e in np.eye(3)
            ]
            if func(r)[0] < 3.0:  # log3 is ill-conditioned near pi
                assert np.allclose(numeric, grad, atol=1e-5)
        u = r[:, 0]
        grad = G.axis_angle(u, axis)[1]
        numeric = [
            (G.axis_angle(pin.exp3(EPS * e) @ u, axis)[0] - G.axis_angle(pin.exp3(-EPS * e) @ u, axis)[0]) / (2 * EPS)
            for e in np.eye(3)
        ]
        assert np.allclose(numeric, grad, atol=1e-6)


def test_evaluator_jacobians_match_finite_differences(madar, rng):
    joints = madar.group_joints("right_arm")
    frame = FrameRef(offset=Pose(xyz=(0.2, 0.5, 1.0), rpy=(0.1, 0.2, 0.3)))
    specs = [
        OrientationConstraint(
            id="spin_y",
            joints=joints,
            target_link="right_tool",
            free_axes=["y"],
            target=Pose(rpy=(0.3, 0.2, 0.1)),
            tolerance=0.1,
            tolerance_gradient=0.2,
        ),
        OrientationConstraint(
            id="full", joints=joints, target_link="right_tool", target=Pose(rpy=(0.3, 0.2, 0.1)), frame=frame
        ),
        OrientationConstraint(id="twist", joints=joints, target_link="right_tool", free_axes=["x", "y"]),
        BoxConstraint(id="box", joints=joints, target_link="right_tool", size=(0.3, 0.4, 0.5), frame=frame),
        SphereConstraint(id="sphere", joints=joints, target_link="right_tool", radius=0.3, region="outside"),
        CylinderConstraint(
            id="cylinder", joints=joints, target_link="right_tool", radius=0.3, height=0.5, region="outside"
        ),
        ConeConstraint(id="cone", joints=joints, target_link="right_tool", radius=0.2, height=0.4, frame=frame),
    ]
    bound = bind(specs, madar, CollisionChecker(madar, Scene()))
    bound[0].p_goal = np.array([0.1, 0.6, 1.0])
    evaluator = ConstraintEvaluator(madar, bound, "right_arm", np.zeros(12))
    assert evaluator.n_equality == 2 + 3 + 1
    checked = total = 0
    for x in rng.uniform(-3, 3, (30, 6)):
        for rows, jac, offset in (
            (evaluator.deadzone, evaluator.deadzone_jacobian, 10.0),
            (evaluator.equality, evaluator.equality_jacobian, None),
        ):
            f = functools.partial(rows, offset=offset) if offset is not None else rows
            analytic = jac(x, offset) if offset is not None else jac(x)
            smooth = _smooth_rows(f, x)
            numeric = np.column_stack([(f(x + EPS_JAC * e) - f(x - EPS_JAC * e)) / (2 * EPS_JAC) for e in np.eye(6)])
            wrong = np.abs(numeric - analytic).max(axis=1) >= 1e-5
            assert not (wrong & smooth).any(), (x, np.flatnonzero(wrong & smooth))
            checked, total = checked + smooth.sum(), total + len(smooth)
    assert checked >= 0.9 * total  # kinks are rare: nearly every row of every sample is compared


def _smooth_rows(f, x: np.ndarray, h: float = 1e-5) -> np.ndarray:
    """Rows whose one-sided differences agree at x: away from a kink (log3 near pi, a box edge,
    |twist| at 0), found from the values alone, not from the analytic Jacobian under test."""
    forward = np.column_stack([(f(x + h * e) - f(x)) / h for e in np.eye(len(x))])
    backward = np.column_stack([(f(x) - f(x - h * e)) / h for e in np.eye(len(x))])
    return np.abs(forward - backward).max(axis=1) < 1e-3


@pytest.mark.parametrize("group", ["left_arm", "right_arm", None])
def test_an_evaluators_velocity_entries_are_its_groups_joints(madar, group):
    """Jacobian columns are taken at the group's joints' velocity entries (pinocchio's idx_v)."""
    evaluator = ConstraintEvaluator(madar, [], group or madar.default_group, madar.q_neutral)
    model = madar.model
    assert evaluator.vidx.tolist() == [model.joints[model.getJointId(j)].idx_v for j in madar.group_joints(group)]
