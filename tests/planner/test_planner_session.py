"""Sessions end to end on MADAR: the whole configuration flows through every stage, a timing
failure is a failure, a dual-arm plan leaves the arm that need not move where it is, near people
a plan keeps ISO/TS 15066 speed limits unless turned off, and a session knows where the robot is."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from hriplan import HriplanError
from hriplan.cli.solve import solve_problem_file
from hriplan.planner.motion import JointTarget, plan_motion
from hriplan.planner.options import PlanOptions
from hriplan.planner.problem import load_problem
from hriplan.planner.replay import PlannedWorld
from hriplan.planner.session import PlanningSession
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.descriptions.registry import posture
from hriplan.robots.human import HumanSpec
from hriplan.robots.model import load_robot
from hriplan.robots.scene import Scene
from hriplan.safety.policy import default_policy
from independent import constraint_violations, trajectory_speed_margins

SCENARIOS = Path(__file__).parents[2] / "benchmarks" / "scenarios"


def session_for(problem):
    session = PlanningSession(problem.robot, problem.scene, problem.hands or None, problem.roles)
    session.set_constraints(problem.constraints)
    return session


@pytest.fixture(scope="module")
def handover():
    problem = load_problem(SCENARIOS / "b_madar_handover.json")
    return problem, session_for(problem)


@pytest.fixture(scope="module")
def left_arm():
    problem = load_problem(SCENARIOS / "g_madar_left_arm.json")
    return problem, session_for(problem)


def test_trajectory_file_start_is_the_problems_start_for_every_joint(handover, tmp_path):
    problem, _ = handover
    assert problem.start["left_shoulder_lift_joint"] == -2.2  # the arm that does not move is folded, not at 0
    out = tmp_path / "b.json"
    assert solve_problem_file(SCENARIOS / "b_madar_handover.json", out, 1, False) == 0
    written = json.loads(out.read_text())["start"]
    robot = load_robot(problem.robot, problem.hands)
    assert sorted(written) == sorted(robot.joint_names)
    assert written == pytest.approx(problem.start, abs=1e-12)


def test_left_arm_alone_plans_times_and_replays_with_the_right_arm_folded(left_arm):
    problem, session = left_arm
    result = session.plan(problem.start, problem.goal, problem.options.model_copy(update={"seed": 1}), problem.group)
    assert result.status == "solved", result.message
    trajectory = result.trajectory
    assert trajectory.joint_names == [j for j in session.robot.joint_names if j.startswith("left_")]
    assert trajectory.start == pytest.approx(problem.start, abs=1e-12)
    # Independently composed configurations (the problem's start + the timed left-arm values),
    # checked by a collision model built afresh from the problem's scene.
    robot = load_robot(problem.robot, problem.hands)
    fresh = CollisionChecker(robot, problem.scene)
    for point in trajectory.points:
        q = robot.configuration({**problem.start, **dict(zip(trajectory.joint_names, point.positions))})
        assert q[robot.group_indices("right_arm")] == pytest.approx(
            [problem.start[j] for j in robot.group_joints("right_arm")]
        )
        assert not fresh.in_collision(q)
    world = PlannedWorld.load(trajectory)  # what the viewer, the plots and `hriplan validate` rebuild
    assert world.joint_values(world.positions[3])["right_elbow_joint"] == pytest.approx(1.2)
    assert world.validate().valid
    assert constraint_violations(trajectory) == []


def test_time_is_a_public_stage_after_planning(handover):
    problem, session = handover
    options = problem.options.model_copy(update={"seed": 3})
    motion = plan_motion(
        session.robot,
        session.checker,
        list(session.constraints.values()),
        problem.start,
        problem.goal,
        options,
        problem.group,
    )
    assert motion.solved and motion.start == pytest.approx(problem.start, abs=1e-12)
    timed = session.time(motion, options)
    assert timed.status == "solved" and timed.trajectory.points[-1].positions == pytest.approx(
        motion.path[-1], abs=1e-6
    )
    with pytest.raises(HriplanError, match="does not give every joint"):
        session.time(motion.model_copy(update={"start": {}}), options)


def test_a_timing_failure_is_a_failure_with_exit_1_and_one_line(handover, monkeypatch, capsys, tmp_path):
    problem, session = handover

    def fail(*args, **kwargs):
        raise HriplanError("TOPP-RA found no time parameterisation within the joint limits")

    monkeypatch.setattr("hriplan.planner.session.time_parameterize", fail)
    result = session.plan(problem.start, problem.goal, problem.options.model_copy(update={"seed": 1}), problem.group)
    assert result.motion.solved and not result.solved and result.status == "timing_failed" and result.trajectory is None
    out = tmp_path / "b.json"
    assert solve_problem_file(SCENARIOS / "b_madar_handover.json", out, 1, False) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("planning failed (timing_failed): TOPP-RA found no time parameterisation") and "\n" not in err
    assert not out.exists()


def test_an_arm_whose_goal_is_its_start_holds_its_pose():
    problem = load_problem(SCENARIOS / "i_madar_one_arm_holds.json")
    session = session_for(problem)
    robot = session.robot
    left = [robot.group_joints("both_arms").index(j) for j in robot.group_joints("left_arm")]
    assert [problem.goal.values[j] for j in robot.group_joints("left_arm")] == [
        problem.start[j] for j in robot.group_joints("left_arm")
    ]
    for seed in (0, 1):
        result = session.plan(
            problem.start, problem.goal, problem.options.model_copy(update={"seed": seed}), problem.group
        )
        assert result.solved, result.message
        positions = np.array([p.positions for p in result.trajectory.points])
        assert np.abs(positions[:, left] - positions[0, left]).max() < 1e-6
        report = result.trajectory.report
        assert report.straight_length == pytest.approx(np.linalg.norm(positions[-1] - positions[0]), abs=1e-6)
        assert report.path_length < 8 * report.straight_length


def test_hriplan_plan_reports_a_timing_failure_as_a_failed_step(monkeypatch, capsys, tmp_path):
    import typer

    from hriplan.cli.tasks import plan

    def fail(*args, **kwargs):
        raise HriplanError("TOPP-RA found no time parameterisation within the joint limits")

    monkeypatch.setattr("hriplan.planner.session.time_parameterize", fail)
    with pytest.raises(typer.Exit) as exit_:
        plan(Path(__file__).parents[2] / "examples" / "handover_empty_can.yaml", output=tmp_path / "t.json", quiet=True)
    assert exit_.value.exit_code == 1
    err = capsys.readouterr().err.strip()
    assert (
        err.startswith("planning failed at step")
        and "(timing_failed): TOPP-RA found no time" in err
        and "\n" not in err
    )
    assert not list(tmp_path.iterdir())


def test_a_path_that_cannot_be_timed_is_planned_again(handover, monkeypatch):
    import hriplan.planner.session as session_module

    problem, session = handover
    calls = []
    real = session_module.time_parameterize

    def first_fails(*args, **kwargs):
        calls.append(1)
        if len(calls) <= len(session_module.TIMING_STEPS):  # every knot spacing of the first path
            raise HriplanError("TOPP-RA found no time parameterisation within the joint limits")
        return real(*args, **kwargs)

    monkeypatch.setattr(session_module, "time_parameterize", first_fails)
    result = session.plan(problem.start, problem.goal, problem.options.model_copy(update={"seed": 1}), problem.group)
    assert result.status == "solved" and len(calls) == len(session_module.TIMING_STEPS) + 1


def test_a_worker_reuses_its_session_and_another_robot_or_hand_gets_its_own(monkeypatch):
    from hriplan.planner import session as session_module

    monkeypatch.setattr(session_module, "_WORKER_SESSIONS", {})
    ur5 = session_module.worker_session("ur5")
    assert session_module.worker_session("ur5") is ur5 and session_module.worker_session("ur5", {}) is ur5
    madar = session_module.worker_session("madar")
    power = session_module.worker_session("madar", {"right": "power"})
    assert len({id(ur5), id(madar), id(power)}) == 3
    assert (ur5.robot.name, madar.robot.name, power.robot.name) == ("ur5", "madar", "madar")
    assert (madar.robot.hand_postures["right"], power.robot.hand_postures["right"]) == ("open", "power")
    assert session_module.worker_session("madar", {"right": "power"}) is power


def test_session_plan_near_a_person_keeps_the_speed_limit_unless_turned_off():
    """Was: `plan` timed at full speed unless given a policy. The right arm swings out towards a
    supervisor: by default slowed to the allowed speed with hriplan's margin (checked with the
    formulas of tests/independent.py, the padding 0.05 m and speed factor 0.95 written here), with
    `safety=None` faster and over it."""
    sam = HumanSpec(name="sam", position=(1.45, 0.65), yaw=math.pi)
    session = PlanningSession("madar", Scene(humans=[sam]), hands={"right": "open"}, roles={"sam": "Supervisor"})
    start = posture("madar", "ready")
    x0 = session.robot.group_values(session.robot.configuration(start), "right_arm")
    goal = JointTarget(values=(x0 + np.array([0.8, -0.4, 0.4, 0.0, 0.0, 0.0])).tolist())
    policy = session.policy()
    assert policy == default_policy("madar", [sam], {"sam": "Supervisor"})
    safe = session.plan(start, goal, PlanOptions(seed=1), group="right_arm")
    fast = session.plan(start, goal, PlanOptions(seed=1), group="right_arm", safety=None)
    assert safe.solved and fast.solved
    assert [s.person for s in safe.trajectory.report.separation] == ["sam"] and fast.trajectory.report.separation == []
    speed, gap = trajectory_speed_margins(safe.trajectory, policy, 0.05, 0.95)
    assert speed >= -0.02 and gap > 0.0
    assert trajectory_speed_margins(fast.trajectory, policy, 0.05, 0.95)[0] < -0.05  # the limit is what slowed it
    assert safe.trajectory.report.duration > 1.1 * fast.trajectory.report.duration
    # With nobody in the scene there is no policy to keep.
    assert PlanningSession("madar", hands={"right": "open"}).policy() is None


def test_a_session_knows_where_the_robot_is():
    """A solved plan ends where the session's configuration is; perception sets it, checked."""
    session = PlanningSession("madar", hands={"right": "open"})
    assert session.configuration is None
    start = posture("madar", "ready")
    session.set_configuration(start)
    assert session.configuration == dict(zip(session.robot.joint_names, session.robot.configuration(start).tolist()))
    goal = JointTarget(values={"right_elbow_joint": start["right_elbow_joint"] + 0.3})
    result = session.plan(start, goal, PlanOptions(seed=1), group="right_arm")
    assert result.solved and session.configuration["right_elbow_joint"] == pytest.approx(
        start["right_elbow_joint"] + 0.3, abs=1e-9
    )
    with pytest.raises(HriplanError, match="^robot 'madar' has no arm joint 'wrist'$"):
        session.set_configuration({"wrist": 0.1})
