"""The evaluator's two routes, margins alone (`margins`, `deadzone`) and margins with gradients
(`gradients`, `deadzone_jacobian`), against the margins of tests/independent.py (the URDF's own
kinematics, the specification's semantics) at random states, for every constraint kind: box,
sphere, cylinder, cone inside and outside, orientation with 0, 1 and 2 free axes and with a
tolerance gradient. The gradient rows are checked against finite differences of the independent
margins, so that no number here comes from the code under test."""

import numpy as np
import pinocchio as pin
import pytest

from hriplan.planner.constraints.binding import bind
from hriplan.planner.constraints.compiled import CompiledMargins
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
from independent import UrdfRobot, orientation_error, signed_distance

TOOL, GOAL = "right_tool", np.array([0.1, 0.6, 1.0])
X0 = np.array([0.3, -1.2, 1.4, -0.5, 0.6, 0.2])  # the constraints are placed about the tool here
STATES = 60
H = 1e-6  # central differences of the independent margins


def _specs(joints: list[str], frame: Pose, target: Pose) -> list:
    """Every kind, the tool at X0 inside each volume and near each orientation's target."""
    at = FrameRef(offset=frame)
    specs = [
        OrientationConstraint(id="o0", joints=joints, target_link=TOOL, target=target, frame=at, tolerance=0.3),
        OrientationConstraint(
            id="o1", joints=joints, target_link=TOOL, free_axes=["y"], target=target, frame=at, tolerance=0.3
        ),
        OrientationConstraint(
            id="o2", joints=joints, target_link=TOOL, free_axes=["x", "y"], target=target, frame=at, tolerance=0.3
        ),
        OrientationConstraint(
            id="o1_dynamic",
            joints=joints,
            target_link=TOOL,
            free_axes=["z"],
            target=target,
            frame=at,
            tolerance=0.1,
            tolerance_gradient=0.2,
        ),
    ]
    for region in ("inside", "outside"):
        kw = {"joints": joints, "target_link": TOOL, "frame": at, "region": region}
        specs += [
            BoxConstraint(id=f"box_{region}", size=(0.3, 0.4, 0.8), **kw),
            SphereConstraint(id=f"sphere_{region}", radius=0.5, **kw),
            CylinderConstraint(id=f"cylinder_{region}", radius=0.3, height=0.6, **kw),
            ConeConstraint(id=f"cone_{region}", radius=0.4, height=0.6, **kw),
        ]
    return specs


@pytest.fixture(scope="module")
def setup(madar):
    joints = madar.group_joints("right_arm")
    urdf = UrdfRobot("madar", {})
    urdf.configure(dict(zip(joints, X0)))
    tool0 = urdf.pose(TOOL)
    # the frame turned by (0.1, 0.2, 0.3) rpy, the tool 0.3 m up its z axis
    frame = pin.SE3(pin.rpy.rpyToMatrix(0.1, 0.2, 0.3), np.zeros(3))
    frame.translation = tool0.translation - frame.rotation @ np.array([0.0, 0.0, 0.3])
    target = frame.rotation.T @ tool0.rotation @ pin.rpy.rpyToMatrix(0.1, -0.1, 0.1)
    frame_pose = Pose(xyz=tuple(frame.translation), rpy=tuple(pin.rpy.matrixToRpy(frame.rotation)))
    specs = _specs(joints, frame_pose, Pose(rpy=tuple(pin.rpy.matrixToRpy(target))))
    bound = bind(specs, madar, CollisionChecker(madar, Scene()))
    bound[3].p_goal = GOAL  # the dynamic tolerance is measured from here
    evaluator = ConstraintEvaluator(madar, bound, "right_arm", madar.configuration({}))

    def independent(x: np.ndarray) -> np.ndarray:
        """Each constraint's margin at joint values x, by the URDF and the semantics alone."""
        urdf.configure(dict(zip(joints, x)))
        tool = urdf.pose(TOOL)
        out = []
        for spec in specs:
            if spec.type == "orientation":
                allowed = spec.tolerance + spec.tolerance_gradient * np.linalg.norm(tool.translation - GOAL)
                out.append(orientation_error(spec, frame.rotation.T @ tool.rotation) - allowed)
            else:
                d = float(signed_distance(spec, (frame.rotation.T @ (tool.translation - frame.translation))[None])[0])
                out.append(d if spec.region == "inside" else -d)
        return np.array(out)

    rng = np.random.default_rng(7)
    near = X0 + rng.normal(0.0, 0.2, (STATES // 2, len(joints)))
    xs = np.concatenate([near, rng.uniform(-3.0, 3.0, (STATES - len(near), len(joints)))])
    return evaluator, independent, xs, [independent(x) for x in xs]


def test_margins_and_deadzone_are_the_independent_margins(setup):
    evaluator, _, xs, expected = setup
    for x, want in zip(xs, expected):
        assert np.allclose(evaluator.margins(evaluator.full(x)), want, rtol=0.0, atol=1e-9), x
        assert np.allclose(evaluator.deadzone(x, 0.05), np.maximum(want + 0.05, 0.0), rtol=0.0, atol=1e-9), x


def test_the_gradient_pass_gives_the_same_margins_and_their_derivatives(setup):
    evaluator, independent, xs, expected = setup
    compared = total = 0
    for x, want in zip(xs, expected):
        margins, rows = evaluator.gradients(x)
        assert np.allclose(margins, want, rtol=0.0, atol=1e-9), x
        forward = np.column_stack([independent(x + H * e) for e in np.eye(len(x))])
        backward = np.column_stack([independent(x - H * e) for e in np.eye(len(x))])
        numeric = (forward - backward) / (2 * H)
        # rows at a kink (a box edge, a half turn) have one-sided slopes that differ: not compared
        smooth = np.abs((forward - want[:, None]) - (want[:, None] - backward)).max(axis=1) / H < 1e-3
        assert np.allclose(rows[smooth], numeric[smooth], rtol=0.0, atol=1e-5), (x, np.flatnonzero(smooth))
        dead = evaluator.deadzone_jacobian(x, 0.05)
        active = margins + 0.05 > 0.0
        assert np.array_equal(dead[active], rows[active]) and not dead[~active].any()
        compared, total = compared + smooth.sum(), total + len(smooth)
    assert compared >= 0.9 * total


def test_every_kind_is_met_on_both_sides(setup):
    """The random states reach both signs of every margin (no kind is checked on one side only)."""
    expected = np.array(setup[3])
    assert ((expected > 0.0).any(axis=0) & (expected < 0.0).any(axis=0)).all()


def test_many_states_at_once_are_the_independent_margins(setup, madar, either_route):
    """`margins_many`, with the kernels on compiled for every kind it covers (volumes; one free
    axis, with and without a tolerance gradient) and state by state for an evaluator holding no
    or two free axes; with them off state by state."""
    evaluator, _, xs, expected = setup
    qs, want = evaluator.full_many(xs), np.array(expected)
    covered = [k for k, c in enumerate(evaluator.constraints) if c.id not in ("o0", "o2")]
    compiled = ConstraintEvaluator(madar, [evaluator.constraints[k] for k in covered], "right_arm", evaluator.q)
    assert CompiledMargins.of(compiled) is not None and CompiledMargins.of(evaluator) is None
    assert np.allclose(compiled.margins_many(qs), want[:, covered], rtol=0.0, atol=1e-9)
    assert np.allclose(evaluator.margins_many(qs), want, rtol=0.0, atol=1e-9)
    # the two routes differ by the kinematics' rounding alone
    per_state = np.array([compiled.margins(q) for q in qs])
    assert np.abs(compiled.margins_many(qs) - per_state).max() < 1e-12
