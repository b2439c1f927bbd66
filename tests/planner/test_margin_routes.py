"""The evaluator's two routes, margins alone (`margins`, `deadzone`) and margins with gradients
(`gradients`, `deadzone_jacobian`), against the margins of tests/independent.py (the URDF's own
kinematics, the specification's semantics) at random states, for every constraint kind: box,
sphere, cylinder, cone inside and outside, orientation with 0, 1 and 2 free axes and with a
tolerance gradient. The gradient rows are checked against finite differences of the independent
margins, so that no number here comes from the code under test."""

from pathlib import Path

import example_robot_data
import numpy as np
import pinocchio as pin
import pytest
from typer.testing import CliRunner

from hriplan.cli.main import app
from hriplan.planner.constraints.binding import bind
from hriplan.planner.constraints.compiled import CompiledTerms
from hriplan.planner.constraints.evaluator import ConstraintEvaluator
from hriplan.planner.constraints.spec import (
    BoxConstraint,
    ConeConstraint,
    CylinderConstraint,
    FrameRef,
    OrientationConstraint,
    SphereConstraint,
)
from hriplan.robots import kernel_switch
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.descriptions.registry import load_robot_file
from hriplan.robots.model import load_robot
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


@pytest.fixture(scope="module")
def evaluators(setup, madar):
    """(evaluator, the columns of the independent margins it has): every kind, and every kind
    the compiled route covers (all but no and two free axes), which it takes with the kernels on."""
    evaluator = setup[0]
    covered = [k for k, c in enumerate(evaluator.constraints) if c.id not in ("o0", "o2")]
    compiled = ConstraintEvaluator(madar, [evaluator.constraints[k] for k in covered], "right_arm", evaluator.q)
    assert CompiledTerms.of(compiled) is not None and CompiledTerms.of(evaluator) is None
    return [(evaluator, list(range(len(evaluator.constraints)))), (compiled, covered)]


def test_margins_and_deadzone_are_the_independent_margins(setup, evaluators, either_route):
    _, _, xs, expected = setup
    for evaluator, columns in evaluators:
        for x, want in zip(xs, np.array(expected)[:, columns]):
            assert np.allclose(evaluator.margins(evaluator.full(x)), want, rtol=0.0, atol=1e-9), x
            assert np.allclose(evaluator.deadzone(x, 0.05), np.maximum(want + 0.05, 0.0), rtol=0.0, atol=1e-9), x


def test_the_gradient_pass_gives_the_same_margins_and_their_derivatives(setup, evaluators, either_route):
    _, independent, xs, expected = setup
    compared = total = 0
    for evaluator, columns in evaluators:
        for x, want in zip(xs, np.array(expected)[:, columns]):
            margins, rows = evaluator.gradients(x)
            assert np.allclose(margins, want, rtol=0.0, atol=1e-9), x
            forward = np.column_stack([independent(x + H * e)[columns] for e in np.eye(len(x))])
            backward = np.column_stack([independent(x - H * e)[columns] for e in np.eye(len(x))])
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


def test_many_states_at_once_are_the_independent_margins(setup, evaluators, either_route):
    """`margins_many`: with the kernels on one compiled call where the route covers every term,
    else state by state."""
    _, _, xs, expected = setup
    for evaluator, columns in evaluators:
        qs = evaluator.full_many(xs)
        assert np.allclose(evaluator.margins_many(qs), np.array(expected)[:, columns], rtol=0.0, atol=1e-9)
        # a batch is its states one by one, to the rounding of the kinematics
        assert np.abs(evaluator.margins_many(qs) - [evaluator.margins(q) for q in qs]).max() < 1e-12


def _both_routes(evaluator: ConstraintEvaluator, xs: np.ndarray) -> tuple[list, list]:
    """`gradients` (margins and rows) at every row of xs with the kernels on, then off."""
    before = kernel_switch.kernels_on()
    try:
        kernel_switch.use_kernels(True)
        compiled = [evaluator.gradients(x) for x in xs]
        kernel_switch.use_kernels(False)
        return compiled, [evaluator.gradients(x) for x in xs]
    finally:
        kernel_switch.use_kernels(before)


def test_the_compiled_route_is_the_python_route_to_rounding(evaluators, setup):
    """Margins and gradient rows of the covered kinds, compiled against Python, at every state."""
    compiled, python = _both_routes(evaluators[1][0], setup[2])
    assert max(np.abs(a[0] - b[0]).max() for a, b in zip(compiled, python)) < 1e-12
    assert max(np.abs(a[1] - b[1]).max() for a, b in zip(compiled, python)) < 1e-9


def test_the_compiled_gradients_of_a_sliding_joint_and_of_a_joint_off_the_chain(madar, tmp_path, robot_registry):
    """The branches MADAR's arm does not take, compiled against Python: TIAGo's torso lift slides
    (its column moves the tool along the joint's axis), and with both of MADAR's arms planned
    under constraints on the right tool the left arm's joints do not move it (zero columns)."""
    robots = Path(example_robot_data.getModelPath("tiago_description/robots/tiago.urdf"))
    urdf = robots / "tiago_description" / "robots" / "tiago.urdf"
    out = tmp_path / "tiago.yaml"
    assert CliRunner().invoke(app, ["robot", "init", "--urdf", str(urdf), "-o", str(out)]).exit_code == 0
    tiago = load_robot(load_robot_file(out).name)
    cases = [(tiago, "arm", "arm", tiago.tool_frame("arm")), (madar, "both_arms", "right_arm", TOOL)]
    for robot, group, chain, tool in cases:
        joints = robot.group_joints(chain)
        specs = [
            OrientationConstraint(id="up", joints=joints, target_link=tool, free_axes=["z"], tolerance=0.2),
            BoxConstraint(
                id="box",
                joints=joints,
                target_link=tool,
                size=(0.4, 0.5, 0.6),
                frame=FrameRef(offset=Pose(xyz=(0.3, 0.2, 0.9))),
            ),
        ]
        evaluator = ConstraintEvaluator(
            robot, bind(specs, robot, CollisionChecker(robot, Scene())), group, robot.configuration({})
        )
        low, high = robot.limits(group)
        xs = np.random.default_rng(5).uniform(low, high, (40, len(low)))
        assert CompiledTerms.of(evaluator) is not None
        compiled, python = _both_routes(evaluator, xs)
        for (m, rows), (want_m, want_rows) in zip(compiled, python):
            assert np.abs(m - want_m).max() < 1e-12 and np.abs(rows - want_rows).max() < 1e-9
        carrier = robot.model.supports[robot.model.frames[robot.frame_id(tool)].parentJoint]
        moved = np.array([robot.model.getJointId(j) in carrier for j in robot.group_joints(group)])
        assert (~moved).any() == (group == "both_arms") and all(not rows[:, ~moved].any() for _, rows in compiled)


def test_the_active_rows_gradients_are_the_gradient_pass_rows_to_the_bit(evaluators, setup):
    """`rows_gradients` (a Newton step's rows near their band) writes those rows of
    `term_gradients`, bit for bit, and leaves the others as they were."""
    from hriplan.planner.constraints.compiled import rows_gradients, term_gradients

    terms = CompiledTerms.of(evaluators[1][0])
    (joint_rows, joint_ints, rotation, origin), (ints, floats, columns, axes, carries) = terms.kernel_arguments()
    rng = np.random.default_rng(3)
    for x in setup[2]:
        q = evaluators[1][0].full(x)
        terms._place(q)
        margins, full = np.empty(terms.count), np.empty((terms.count, len(columns)))
        term_gradients(rotation[0], origin[0], ints, floats, columns, axes, carries, margins, full)
        rows = rng.permutation(terms.count)
        count = int(rng.integers(0, terms.count + 1))
        out = np.full_like(full, np.nan)
        rows_gradients(rotation[0], origin[0], ints, floats, columns, axes, carries, rows, count, out)
        assert out[rows[:count]].tobytes() == full[rows[:count]].tobytes()
        assert np.isnan(out[rows[count:]]).all()
