"""Speed and separation (ISO/TS 15066): formulas, ontology parameters, timing near people.

The trajectory checks below do not use the code under test (safety/separation.py, approach.py,
planner/timing.py): they recompute separations with coal on the robot's and the people's capsules,
robot point speeds by finite differences of pinocchio's forward kinematics, and the allowed
speed from the formulas written out here.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from meshcat.commands import SetObject
from PIL import Image

from hriplan import HriplanError
from hriplan.cli.summary import separation_phrase
from hriplan.ontology.vocabulary import ontology_source
from hriplan.planner.motion import JointTarget
from hriplan.planner.replay import PlannedWorld
from hriplan.planner.session import PlanningSession
from hriplan.planner.timing import time_parameterize
from hriplan.robots.descriptions.registry import posture
from hriplan.robots.human import HumanSpec
from hriplan.robots.scene import Scene
from hriplan.safety.approach import ApproachMonitor
from hriplan.safety.policy import default_policy
from hriplan.safety.separation import (
    NO_MARGIN,
    ContactRegion,
    PersonSeparation,
    RobotStopping,
    SafetyMargin,
    allowed_speed,
    minimum_separation,
    pfl_speed_limit,
    protective_separation,
    ssm_speed_limit,
)
from hriplan.tasks.load import load_task
from hriplan.tasks.pipeline import TaskRunner
from hriplan.viewer.plots import write_plots
from hriplan.viewer.scene import build_drawing
from independent import speed_margins, trajectory_speed_margins

EXAMPLES = Path(__file__).parents[2] / "examples"
ROBOT = RobotStopping(reaction_time=0.1, stopping_time=0.2, position_uncertainty=0.02, moving_mass=10.0)
HAND = ContactRegion(
    region="HandFingerRegion",
    capsules=["right_hand"],
    spring_constant=75_000.0,
    effective_mass=0.6,
    transient_force=280.0,
)
WALKER = PersonSeparation(name="p", approach_speed=1.6, intrusion=0.1, sensor_uncertainty=0.05)


# -- formulas against hand-computed numbers ----------------------------------------------------
def test_minimum_and_protective_separation_by_hand():
    # S_0 = 1.6 (0.1 + 0.2) + 0.1 + 0.05 + 0.02 = 0.65 m
    assert minimum_separation(ROBOT, WALKER) == pytest.approx(0.65)
    # S_p(0.5 m/s) = 0.65 + 0.5 * 0.1 + 0.5 * 0.2 / 2 = 0.75 m
    assert protective_separation(ROBOT, WALKER, 0.5) == pytest.approx(0.75)
    # Inverse: (1.0 - 0.65) / (0.1 + 0.1) = 1.75 m/s; 0 at and inside S_0.
    assert ssm_speed_limit(ROBOT, WALKER, 1.0) == pytest.approx(1.75)
    assert ssm_speed_limit(ROBOT, WALKER, 0.65) == 0.0 and ssm_speed_limit(ROBOT, WALKER, 0.3) == 0.0
    for speed in (0.1, 0.8, 2.5):
        assert ssm_speed_limit(ROBOT, WALKER, protective_separation(ROBOT, WALKER, speed)) == pytest.approx(speed)


def test_pfl_transient_cap_for_a_hand_by_hand():
    # mu = (1/0.6 + 1/10)^-1 = 0.566038 kg; 280 / sqrt(0.566038 * 75000) = 1.35896 m/s
    assert pfl_speed_limit(ROBOT, HAND) == pytest.approx(1.35896, rel=1e-5)
    giver = PersonSeparation(name="g", approach_speed=0.5, intrusion=0.0, sensor_uncertainty=0.05, contact=[HAND])
    # Near the hand the cap holds even inside S_0 (= 0.5 * 0.3 + 0.07 = 0.22 m), less the hand's own 0.5 m/s;
    # elsewhere on the body it is SSM: 0 inside S_0.
    assert allowed_speed(ROBOT, giver, 0.01, "right_hand") == pytest.approx(1.35896 - 0.5, rel=1e-5)
    assert allowed_speed(ROBOT, giver, 0.01, "middle_thorax") == 0.0
    assert allowed_speed(ROBOT, giver, 1.22, "right_hand") == pytest.approx((1.22 - 0.22) / 0.2)


def test_parameters_come_from_the_ontology_per_role():
    people = [HumanSpec(name="ann", reach={"left": (0.2, 0.9, 1.0)}), HumanSpec(name="ben")]
    policy = default_policy("madar", people, {"ann": "Giver"})
    assert policy.robot == ROBOT
    ann, ben = policy.person("ann"), policy.person("ben")
    assert (ann.role, ann.approach_speed, ann.sensor_uncertainty) == ("Giver", 0.5, 0.05)
    assert {c.region: c.capsules for c in ann.contact} == {
        "HandFingerRegion": ["left_hand"],
        "LowerArmRegion": ["left_lowerarm"],
    }
    hand = next(c for c in ann.contact if c.region == "HandFingerRegion")
    assert (hand.spring_constant, hand.effective_mass, hand.transient_force) == (75_000.0, 0.6, 280.0)
    assert (ben.role, ben.approach_speed, ben.contact) == ("Bystander", 1.6, [])


def test_every_roles_parameters_are_the_ontology_triples():
    """`default_policy` reads the ontology's told facts from its schema (cached on disk); here the
    same numbers straight from the Turtle by SPARQL, for every role with SeparationParameters and
    both built-in robots, each person handing with their left hand."""
    import rdflib

    source = ontology_source()
    graph = rdflib.Graph()
    graph.parse(source.path, format="turtle")
    graph.parse(data=source.robots, format="turtle")
    prefix = "PREFIX hp: <https://hriplan.org/ontology#>\n"
    roles = graph.query(
        prefix + "SELECT ?p ?role ?v ?d ?u WHERE { ?p a hp:SeparationParameters ; hp:appliesToRole ?role ;"
        " hp:hasApproachSpeed ?v ; hp:hasIntrusionDistance ?d ; hp:hasSensorUncertainty ?u }"
    )
    roles = {str(r.role).rsplit("#", 1)[-1]: r for r in roles}
    assert {"Bystander", "Giver", "Receiver", "Supervisor"} <= set(roles)
    for robot in ("madar", "ur5"):
        [stopping] = graph.query(
            prefix + "SELECT ?tr ?ts ?z ?m WHERE { ?r hp:hasUrdfName ?name ; hp:hasReactionTime ?tr ;"
            " hp:hasStoppingTime ?ts ; hp:hasPositionUncertainty ?z ; hp:hasMovingMass ?m }",
            initBindings={"name": rdflib.Literal(robot)},
        )
        people = [HumanSpec(name=role.lower(), reach={"left": (0.2, 0.9, 1.0)}) for role in roles]
        policy = default_policy(robot, people, {p.name: role for p, role in zip(people, roles)})
        robot_values = (policy.robot.reaction_time, policy.robot.stopping_time)
        assert robot_values + (policy.robot.position_uncertainty, policy.robot.moving_mass) == tuple(
            float(v.toPython()) for v in stopping
        )
        for role, row in roles.items():
            person = policy.person(role.lower())
            assert (person.approach_speed, person.intrusion, person.sensor_uncertainty) == (
                float(row.v.toPython()),
                float(row.d.toPython()),
                float(row.u.toPython()),
            )
            regions = graph.query(
                prefix + "SELECT ?r ?seg ?k ?m ?f ?t WHERE { ?p hp:offersContactWith ?r . ?r hp:coversSegment ?seg ;"
                " hp:hasSpringConstant ?k ; hp:hasEffectiveMass ?m ; hp:hasQuasiStaticForce ?f ;"
                " hp:hasTransientFactor ?t }",
                initBindings={"p": row.p},
            )
            expected = sorted(
                (
                    str(r.r).rsplit("#", 1)[-1],
                    f"left_{str(r.seg).rsplit('#', 1)[-1]}",
                    float(r.k.toPython()),
                    float(r.m.toPython()),
                    float(r.f.toPython()) * float(r.t.toPython()),
                )
                for r in regions
            )
            got = [
                (c.region, *c.capsules, c.spring_constant, c.effective_mass, c.transient_force) for c in person.contact
            ]
            assert got == expected, role  # sorted by region: the same policy whatever order the triples come in


def test_person_distances_are_to_the_bare_body_and_follow_the_person():
    session = PlanningSession(
        "madar", Scene(humans=[HumanSpec(name="kim", position=(1.2, 0.6), margin=0.2)]), hands={"right": "open"}
    )
    q = session.robot.configuration(posture("madar", "ready"))
    near = session.checker.person_pairs(q, "kim").distance.min()
    # The collision distance is to the capsules grown by the 0.2 m margin; separation is to the body.
    assert near == pytest.approx(session.checker.human_distances([q])[0][0] + 0.2, abs=1e-6)
    session.pose_human(HumanSpec(name="kim", position=(2.2, 0.6), margin=0.2))
    far = session.checker.person_pairs(q, "kim").distance.min()
    assert 0.9 < far - near < 1.0 + 1e-6


def test_bad_roles_are_clear_errors():
    with pytest.raises(HriplanError, match="roles name zoe, who is not in the scene"):
        default_policy("madar", [HumanSpec(name="ann")], {"zoe": "Giver"})
    with pytest.raises(HriplanError, match="no SeparationParameters for role 'Pilot' \\(person ann\\)"):
        default_policy("madar", [HumanSpec(name="ann")], {"ann": "Pilot"})


@pytest.fixture(scope="module")
def demo():
    task = load_task(EXAMPLES / "handover_full_can.yaml")
    return TaskRunner(task, EXAMPLES).run()


def test_the_demo_keeps_the_speed_limit_near_the_giver_at_every_sample(demo):
    assert demo.solved
    slowed = []
    for step in demo.steps:
        traj, policy = step.trajectory, step.derivation.separation
        assert policy is not None and policy.person("alice").role == "Giver"
        worst_speed, worst_gap = trajectory_speed_margins(traj, policy)
        assert worst_speed >= -0.02, f"{step.name}: {worst_speed:.4f} m/s over the allowed speed"
        assert worst_gap > 0.0, f"{step.name}: a moving part is {-worst_gap:.3f} m inside the minimum separation"
        trace = traj.report.separation[0]
        assert trace.person == "alice" and trace.iso_worst_margin == pytest.approx(worst_speed, abs=0.02)
        assert trace.worst_margin < trace.iso_worst_margin  # the margin is kept below the standard's limit
        assert len(trace.allowed_speed) == len(traj.points)
        slowed.append(max(a / b for a, b in zip(trace.approach_speed, trace.allowed_speed) if a is not None and b))
    # Leaving the giver's hand is held to 0.95 of the contact cap (1.239 - 0.5 m/s at her lower arm) ...
    assert slowed[1] == pytest.approx(1.0, abs=0.02)
    assert demo.steps[1].trajectory.report.separation[0].slowest_allowed == pytest.approx(0.95 * 0.7394, abs=1e-3)
    # ... and `hriplan plan` says so; taking the can never came near a limit.
    assert separation_phrase(demo.steps[1].trajectory.report.separation[0]).startswith("slowed to 0.70 m/s within 0.")
    assert separation_phrase(demo.steps[0].trajectory.report.separation[0]).startswith("not slowed near alice")


def test_the_viewer_marks_where_the_limit_held_the_robot(demo):
    def slowed_paths(trajectory):
        drawing = build_drawing(PlannedWorld.load(trajectory))
        return [
            c.path.lower()
            for c in drawing.commands
            if isinstance(c, SetObject) and "slowed_near_people" in c.path.lower()
        ]

    assert slowed_paths(demo.steps[1].trajectory) and not slowed_paths(demo.steps[0].trajectory)


def test_the_separation_figure_is_drawn_per_person(demo, tmp_path):
    paths = write_plots(demo.steps[1].trajectory, tmp_path)
    figure = next(p for p in paths if p.name == "separation.png")
    pixels = np.asarray(Image.open(figure).convert("RGB"))
    assert min(pixels.shape[:2]) > 300 and len(np.unique(pixels.reshape(-1, 3), axis=0)) > 20


@pytest.mark.parametrize(
    "example", ["handover_full_can_receiver", "handover_scissors", "transport_cup_bystander", "peg_in_hole_supervised"]
)
def test_examples_keep_the_speed_limit_at_every_sample(example):
    outcome = TaskRunner(load_task(EXAMPLES / f"{example}.yaml"), EXAMPLES).run()
    assert outcome.solved, [s.message for s in outcome.steps]
    for step in outcome.steps:
        traj = step.trajectory
        worst_speed, worst_gap = trajectory_speed_margins(traj, step.derivation.separation)
        assert worst_speed >= -0.02 and worst_gap > 0.0, (step.name, worst_speed, worst_gap)


def test_with_the_compiled_kernels_a_handover_keeps_the_speed_limit_at_every_sample(compiled_route):
    """A service's workers and a motion manager time with the monitor's compiled route
    (`safety/approach_kernels.py`): the demo's trajectories checked by the formulas of
    tests/independent.py with hriplan's margin (padding 0.05 m, speed factor 0.95), and the
    leave from the giver's hand held by the limit, as with the kernels off (above)."""
    outcome = TaskRunner(load_task(EXAMPLES / "handover_full_can.yaml"), EXAMPLES).run()
    assert outcome.solved, [s.message for s in outcome.steps]
    for step in outcome.steps:
        worst_speed, worst_gap = trajectory_speed_margins(step.trajectory, step.derivation.separation, 0.05, 0.95)
        assert worst_speed >= -0.01 and worst_gap > 0.0, (step.name, worst_speed, worst_gap)
    assert outcome.steps[1].trajectory.report.separation[0].slowest_allowed == pytest.approx(0.95 * 0.7394, abs=1e-3)


# -- timing near and far from people ---------------------------------------------------------
def _right_arm_path(robot):
    """The right tool from (0.25, 0.6, 1.0) out to (0.73, 0.61, 1.24), MADAR facing +y."""
    q0 = robot.configuration(posture("madar", "ready"))
    x0 = robot.group_values(q0, "right_arm")
    return q0, np.linspace(x0, x0 + np.array([0.8, -0.4, 0.4, 0.0, 0.0, 0.0]), 40)


def _timed(person: HumanSpec, role: str, margin: SafetyMargin | None = None):
    session = PlanningSession("madar", Scene(humans=[person]), hands={"right": "open"})
    robot = session.robot
    q0, path = _right_arm_path(robot)
    policy = default_policy("madar", [person], {person.name: role})
    policy = policy if margin is None else policy.model_copy(update={"margin": margin})
    monitor = ApproachMonitor(robot, session.checker, policy, "right_arm", q0)
    vmax, amax = robot.velocity_limit("right_arm"), np.full(6, 3.14159)
    free = time_parameterize(path, vmax, amax)
    limited = time_parameterize(path, vmax, amax, speed_scale=monitor.speed_scale)
    return robot, q0, policy, free, limited


def test_a_motion_far_from_people_runs_at_full_speed():
    _, _, _, free, limited = _timed(HumanSpec(name="far", position=(3.5, 3.0)), "Bystander")
    assert limited.times[-1] == pytest.approx(free.times[-1], rel=1e-6)


def test_a_motion_near_a_person_is_slower_and_keeps_the_limit():
    # The standard's own limit (no margin): the path passes just outside S_0, inside the padding.
    person = HumanSpec(name="sam", position=(1.39, 0.65), yaw=math.pi)
    robot, q0, policy, free, limited = _timed(person, "Supervisor", NO_MARGIN)
    assert limited.times[-1] > 1.2 * free.times[-1]
    start = dict(zip(robot.joint_names, q0))
    scene = Scene(humans=[person])
    names = robot.group_joints("right_arm")
    worst_free, _ = speed_margins(
        "madar", {"right": "open"}, scene, start, names, np.array(free.positions), np.array(free.velocities), policy
    )
    worst, gap = speed_margins(
        "madar",
        {"right": "open"},
        scene,
        start,
        names,
        np.array(limited.positions),
        np.array(limited.velocities),
        policy,
    )
    assert worst_free < -0.1  # unconstrained, the arm would come at the supervisor too fast
    assert worst >= -0.02 and gap > 0.0


def test_a_start_trapped_inside_the_minimum_separation_fails_with_the_reason():
    # the wrist is 9 cm from her pelvis, the hand between her legs: every way out comes closer to her
    bystander = HumanSpec(name="dana", position=(0.8, 0.6), yaw=math.pi)
    session = PlanningSession("madar", Scene(humans=[bystander]), hands={"right": "open"})
    q0, path = _right_arm_path(session.robot)
    goal = JointTarget(values=dict(zip(session.robot.group_joints("right_arm"), path[5])))
    start = dict(zip(session.robot.joint_names, q0))
    assert session.plan(start, goal, group="right_arm", safety=None).solved  # without the policy it plans and runs
    result = session.plan(start, goal, group="right_arm")  # by default the ontology's policy: dana a bystander
    assert session.policy() == default_policy("madar", [bystander])
    # no leave phase exists (planner/leave.py): the start is refused before any search, in one line
    assert result.status == "invalid_start" and result.leave is None and "\n" not in result.message
    assert result.message == (
        "the start is inside a person's minimum separation of ISO/TS 15066 (0.600 m): right_wrist_2_link - "
        "dana/middle_pelvis 0.089 m apart, and no motion of right_arm moves away without coming closer"
    )  # S_0 + padding


def test_a_task_passing_too_close_to_a_collaborator_fails_in_one_line(tmp_path):
    text = (EXAMPLES / "transport_cup_bystander.yaml").read_text()
    near = "{name: dana, role: Collaborator, position: [0.95, 0.8], yaw: 3.1416}"
    task = tmp_path / "close.yaml"
    task.write_text(text.replace("{name: dana, role: Bystander, position: [1.5, 0.4], yaw: 3.1416}", near))
    assert near in task.read_text()
    result = subprocess.run(
        [sys.executable, "-m", "hriplan.cli", "plan", str(task), "-o", str(tmp_path / "t.json")],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert result.returncode == 1 and "Traceback" not in result.stderr
    failure = result.stderr.strip().splitlines()[-1]
    # she stands within S_0 of the arm's start: the arm first leaves (carry_leave, before: refused
    # there), but the place is inside her S_0 and the padding: refused before planning
    assert failure.startswith("planning failed at step carry (unreachable_goal): ") and " - dana/" in failure
    assert "dana/middle_pelvis (minimum separation 0.365 m)" in failure  # S_0 + padding (+ 5 mm slack)
    assert sorted(p.name for p in tmp_path.glob("t*.json")) == ["t.carry_leave.json", "t.carry_prepare.json"]
