"""Planning inside the tolerance bands and volumes (CBiRRT), checked by FK written here."""

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from pydantic import ValidationError

from hriplan import HriplanError
from hriplan.planner.constraints import evaluator as evaluator_module
from hriplan.planner.constraints.binding import bind
from hriplan.planner.constraints.evaluator import ConstraintEvaluator
from hriplan.planner.constraints.slack import SlackRows
from hriplan.planner.constraints.spec import FrameRef, SphereConstraint
from hriplan.planner.motion import plan_motion
from hriplan.planner.options import PlanOptions
from hriplan.planner.problem import load_problem
from hriplan.planner.search.cbirrt import BandProblem, _min_norm_step, _Search
from hriplan.planner.search.result import Counters
from hriplan.planner.session import PlanningSession
from hriplan.planner.validate import densify
from hriplan.robots.ik import solve_ik
from hriplan.robots.spatial import Pose

SCENARIOS = Path(__file__).parents[2] / "benchmarks" / "scenarios"


def _session(name):
    problem = load_problem(SCENARIOS / f"{name}.json")
    session = PlanningSession(problem.robot, problem.scene, problem.hands or None, problem.roles)
    session.set_constraints(problem.constraints)
    return problem, session


@pytest.fixture(scope="module")
def post():
    return _session("d_ur5_tilt_past_post_static")


def tool_pose(robot, q, frame="tool"):
    """Independent FK: a fresh pinocchio data, the frame's world pose."""
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    return data.oMf[robot.model.getFrameId(frame)]


def tilt(robot, q):
    """Angle between the UR5 tool z axis and world -z (the upright target)."""
    return float(np.arccos(np.clip(-tool_pose(robot, q).rotation[2, 2], -1.0, 1.0)))


def on_rail(robot, q):
    """Inside scenario (d)'s rail: a 1 cm x 0.8 m x 0.3 m box centred at (0.455, 0, 0.2)."""
    p = tool_pose(robot, q).translation - np.array([0.455, 0.0, 0.2])
    return bool(np.all(np.abs(p) <= np.array([0.005, 0.4, 0.15]) + 1e-4))


def test_upright_the_tool_cannot_pass_the_post(post):
    """What makes (d) need the band: beside the post no upright tool pose on the rail is free."""
    problem, session = post
    robot, checker = session.robot, session.checker
    down = Pose(rpy=(np.pi, 0.0, 0.0)).rotation()
    for x in (0.4505, 0.455, 0.4595):
        for z in (0.06, 0.15, 0.25, 0.34):
            target = np.eye(4)
            target[:3, :3], target[:3, 3] = down, (x, 0.0, z)
            ik = solve_ik(
                robot,
                "arm",
                target,
                free_axes=["z"],
                base_q=robot.configuration(problem.start),
                is_valid=lambda q: not checker.in_collision(q),
            )
            assert not ik.success, (x, z)


def test_hybrid_with_exact_orientation_does_not_pass_the_post(post):
    problem, session = post
    result = session.plan(
        problem.start,
        problem.goal,
        PlanOptions(planner="RRTConnect", space="atlas", formulation="hybrid", seed=3, time_limit=1.5),
    )
    assert not result.solved


@pytest.mark.parametrize("name", ["d_ur5_tilt_past_post_static", "d_ur5_tilt_past_post_dynamic"])
def test_the_default_planner_tilts_within_the_band_to_pass_the_post(name):
    problem, session = _session(name)
    result = session.plan(problem.start, problem.goal, PlanOptions(seed=2, time_limit=20.0))
    assert result.solved, result.message
    robot = session.robot
    upright = next(c for c in problem.constraints.constraints if c.id == "upright")
    q_goal = robot.configuration(problem.goal.values)
    p_goal = tool_pose(robot, q_goal).translation
    tilts = []
    assert result.trajectory.joint_names == robot.joint_names  # the UR5's one group: positions are full configurations
    points = np.array([p.positions for p in result.trajectory.points])  # the timed trajectory, as written
    for x in densify(list(points), 0.01):
        q = robot.configuration(x)
        allowed = upright.tolerance + upright.tolerance_gradient * float(
            np.linalg.norm(tool_pose(robot, q).translation - p_goal)
        )
        tilts.append(tilt(robot, q))
        assert tilts[-1] <= allowed + 1e-4
        assert on_rail(robot, q)
        assert not session.checker.in_collision(q)
    assert max(tilts) > 0.1  # it did tilt: upright it cannot pass (test above)
    assert tilts[-1] <= upright.tolerance + 1e-4


def test_volumes_only_plan_by_projection_not_rejection():
    problem, session = _session("f_madar_volumes_only")
    result = session.plan(problem.start, problem.goal, PlanOptions(seed=1, time_limit=10.0), problem.group)
    assert result.solved, result.message
    assert result.motion.space == "projected" and result.motion.calls["validity"] < 2000  # rejection: ~10^5
    robot, frames = session.robot, {c.spec.id: c for c in result.trajectory.constraints}
    cone, box = frames["approach_cone"], frames["shared_workspace"]
    base = robot.configuration(result.trajectory.start)
    for point in result.trajectory.points:
        q = robot.configuration(dict(zip(result.trajectory.joint_names, point.positions)), base=base)
        p = tool_pose(robot, q, "right_tool").translation
        in_cone = cone.frame_in_world.se3().actInv(p)
        rho, z = float(np.hypot(in_cone[0], in_cone[1])), float(in_cone[2])
        assert -1e-4 <= z <= cone.spec.height + 1e-4 and rho <= cone.spec.radius * z / cone.spec.height + 1e-4
        assert np.all(np.abs(box.frame_in_world.se3().actInv(p)) <= np.array(box.spec.size) / 2 + 1e-4)


def _band_search(session, problem):
    robot = session.robot
    bound = bind(list(session.constraints.values()), robot, session.checker)
    evaluator = ConstraintEvaluator(robot, bound, "arm", robot.configuration(problem.start))
    band = BandProblem(
        lambda x: evaluator.margins(evaluator.full(x)),
        evaluator.gradients,
        lambda x: True,
        robot.limits("arm"),
        0.004,
        0.002,
        0.05,
    )
    return _Search(band, Counters()), evaluator


def _tilted_on_rail(session, problem, angle):
    robot = session.robot
    target = np.eye(4)
    target[:3, :3] = pin.utils.rpyToMatrix(0.0, -angle, 0.0) @ Pose(rpy=(np.pi, 0.0, 0.0)).rotation()
    target[:3, 3] = (0.455, -0.3, 0.15)
    ik = solve_ik(
        robot,
        "arm",
        target,
        base_q=robot.configuration(problem.start),
        is_valid=lambda q: not session.checker.in_collision(q),
    )
    assert ik.success and on_rail(robot, robot.configuration(ik.q))
    return np.array(ik.q)


def test_projection_moves_only_states_outside_a_band(post):
    problem, session = post
    search, evaluator = _band_search(session, problem)
    inside = _tilted_on_rail(session, problem, 0.2)  # tilted 0.2 rad: inside the 0.5 band...
    assert evaluator.margins(evaluator.full(inside))[0] == pytest.approx(-0.3, abs=1e-6)
    kept = search.project(inside.copy())
    assert kept is not None and np.array_equal(kept, inside) and search.counters.jacobian == 0  # ...so not projected
    outside = _tilted_on_rail(session, problem, 0.7)  # beyond the band
    moved = search.project(outside.copy())
    assert moved is not None and search.counters.jacobian > 0
    q = session.robot.configuration(moved)
    assert 0.5 - 0.0045 <= tilt(session.robot, q) <= 0.5 - 0.002 and on_rail(
        session.robot, q
    )  # to the band's edge, just inside


def test_kinematics_are_computed_once_per_state(post, monkeypatch, python_route):
    problem, session = post
    _, evaluator = _band_search(session, problem)
    counts = {"fk": 0, "jac": 0}
    fk, jac = pin.forwardKinematics, pin.computeJointJacobians

    def count(name, fn):
        def wrapped(*args):
            counts[name] += 1
            return fn(*args)

        return wrapped

    monkeypatch.setattr(evaluator_module.pin, "forwardKinematics", count("fk", fk))
    monkeypatch.setattr(evaluator_module.pin, "computeJointJacobians", count("jac", jac))
    x = np.array([problem.start[j] for j in session.robot.group_joints()])
    first = evaluator.margins(evaluator.full(x))
    evaluator.deadzone(x)
    evaluator.gradients(x)
    evaluator.deadzone_jacobian(x)
    evaluator.margins(evaluator.full(x))
    assert counts == {"fk": 1, "jac": 1}
    other = x + 0.1
    evaluator.margins(evaluator.full(other))
    assert counts["fk"] == 2
    assert np.array_equal(evaluator.margins(evaluator.full(x)), first)  # back at x: recomputed, same values


COMBINATIONS = [
    (planner, space, formulation)
    for planner in ("CBiRRT", "RRTConnect")
    for space in ("atlas", "tangent_bundle", "projected", "rejection")
    for formulation in ("hybrid", "deadzone", "slack")
]
ACCEPTED = {
    ("CBiRRT", "projected", "deadzone"),
    *(("RRTConnect", s, f) for s in ("atlas", "tangent_bundle") for f in ("hybrid", "slack")),
    ("RRTConnect", "projected", "hybrid"),
    ("RRTConnect", "projected", "deadzone"),
    *(("RRTConnect", "rejection", f) for f in ("hybrid", "deadzone", "slack")),
}


@pytest.fixture(scope="module")
def box_only():
    problem, session = _session("f_madar_volumes_only")
    session.update_constraint("approach_cone", enabled=False)
    return problem, session


@pytest.mark.parametrize("planner, space, formulation", COMBINATIONS)
def test_every_method_plans_or_is_refused_in_one_line(planner, space, formulation, box_only):
    """The empty-can handover (f) without its cone: each combination plans, or is refused before planning."""
    problem, session = box_only
    specs = list(session.constraints.values())
    if (planner, space, formulation) not in ACCEPTED:  # refused when the options are made, or (a copy) when planning
        with pytest.raises(ValidationError) as refused:
            PlanOptions(planner=planner, space=space, formulation=formulation, seed=1, time_limit=20.0)
        message = refused.value.errors()[0]["msg"]
        assert "\n" not in message and formulation in message + planner
        copied = PlanOptions(planner="RRTConnect").model_copy(
            update={"planner": planner, "space": space, "formulation": formulation}
        )
        with pytest.raises(HriplanError, match="^options: "):
            plan_motion(session.robot, session.checker, specs, problem.start, problem.goal, copied, problem.group)
        return
    # OMPL's RRTConnect on the projected space takes ~20 s here since the receiver stands on the
    # floor (0.6 s when she floated 6.6 cm higher): the limit leaves it room; the others take < 2 s.
    options = PlanOptions(planner=planner, space=space, formulation=formulation, seed=1, time_limit=60.0)
    result = plan_motion(session.robot, session.checker, specs, problem.start, problem.goal, options, problem.group)
    assert result.solved, result.message


@pytest.mark.parametrize("rows", [1, 2, 3])
def test_newton_step_is_the_minimum_norm_solution(rows, rng):
    jac, values = rng.normal(size=(rows, 6)), rng.normal(size=rows)
    assert np.allclose(_min_norm_step(jac, values), np.linalg.pinv(jac) @ values, atol=1e-6)


def test_the_tool_slides_around_a_sphere_it_must_stay_out_of():
    """An `outside` volume across the straight line: projection pushes the steps around it."""
    problem, session = _session("a_ur5_upright_box")
    robot = session.robot
    session.move_obstacle("block", Pose(xyz=(2.0, 2.0, 0.0)))
    start, goal = robot.configuration(problem.start), robot.configuration(problem.goal.values)
    middle = tool_pose(robot, (start + goal) / 2).translation
    joints = robot.group_joints()
    session.set_constraints(
        [
            SphereConstraint(
                id="keep_out",
                joints=joints,
                target_link="tool",
                region="outside",
                radius=0.12,
                frame=FrameRef(offset=Pose(xyz=tuple(middle))),
            )
        ]
    )
    result = session.plan(problem.start, problem.goal, PlanOptions(seed=3, time_limit=20.0))
    assert result.solved, result.message
    assert result.motion.calls["jacobian"] > 0  # steps were projected out of the sphere, not rejected
    distances = [
        float(np.linalg.norm(tool_pose(robot, robot.configuration(p.positions)).translation - middle))
        for p in result.trajectory.points
    ]
    assert min(distances) >= 0.12 - 1e-4


def test_slack_rows_vanish_on_lifted_states_and_have_the_right_jacobian(rng):
    problem, session = _session("b_madar_handover")
    robot = session.robot
    bound = bind(list(session.constraints.values()), robot, session.checker)
    evaluator = ConstraintEvaluator(robot, bound, "right_arm", robot.configuration(problem.start))
    slack = SlackRows(evaluator)
    assert slack.k == 2 + 3 + 3  # upright rows, box position, cone position
    x0 = np.array(robot.group_values(robot.configuration(problem.start), "right_arm"))
    lifted = slack.lift(x0)
    assert np.abs(slack.function(lifted)).max() < 1e-12
    low, high = slack.bounds(robot.limits("right_arm"))
    assert np.all(lifted >= low) and np.all(lifted <= high)  # the start is inside every band
    for _ in range(5):
        xs = lifted + rng.normal(0.0, 0.05, len(lifted))
        numeric = np.column_stack(
            [(slack.function(xs + 1e-6 * e) - slack.function(xs - 1e-6 * e)) / 2e-6 for e in np.eye(len(xs))]
        )
        assert np.allclose(slack.jacobian(xs), numeric, atol=1e-5)
