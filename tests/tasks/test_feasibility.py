"""`feasible`: a task planner's question about one step, answered by a planned, validated motion
in the session's world (the ok answers re-checked here with the tests' own geometry), with the
reason when not, and kept per session until the world it was asked in changes."""

from __future__ import annotations

import time
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
import pytest

from hriplan import HriplanError
from hriplan.api import HumanSpec, PlanningSession, Step, feasible, load_task
from hriplan.planner.outcome import Status
from hriplan.tasks import feasibility
from independent import clearance, constraint_violations

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
WORLD = load_task(EXAMPLES / "task_planner" / "deliver_cup.yaml")
BOB_BESIDE_ALICE = HumanSpec(name="bob", position=(-0.25, 1.4), yaw=1.5708)
HAND_OVER = Step(name="give", goal={"hand_over": "cup", "to": "alice"})


@pytest.fixture(scope="module")
def session():
    return PlanningSession(WORLD.robot, hands=dict(WORLD.hands))


@pytest.fixture(scope="module")
def handed(session):
    """The handover asked with nobody else about, then again (kept), timed."""
    first = feasible(session, WORLD, HAND_OVER, EXAMPLES)
    started = time.perf_counter()
    again = feasible(session, WORLD, HAND_OVER, EXAMPLES)
    return first, again, time.perf_counter() - started


def test_a_feasible_handover_is_a_validated_timed_motion_and_its_cost_is_its_duration(handed):
    answer, _, _ = handed
    assert answer.ok and answer.status == Status.SOLVED and answer.reason == ""
    assert answer.motions == ["give", "give_release"] == [t.step for t in answer.trajectories]
    for trajectory in answer.trajectories:
        assert constraint_violations(trajectory) == []  # re-checked point by point, hriplan's code not used
        times = np.array([p.time_from_start for p in trajectory.points])
        assert times[0] == 0.0 and np.all(np.diff(times) > 0)
    durations = [t.points[-1].time_from_start for t in answer.trajectories]
    assert answer.cost == pytest.approx(sum(durations)) and 0.5 < answer.cost < 10.0
    # The motions follow each other: the retreat starts where the handover ends.
    give, back = answer.trajectories
    assert np.allclose(give.points[-1].positions, back.points[0].positions, atol=1e-9)
    kinds = {c.spec.id: c.kind for c in answer.constraints}
    assert kinds == {
        "approach_cone_alice": "ApproachCone",
        "exclusion_box_alice": "ReceiverExclusionBox",
        "shared_workspace_alice": "SharedWorkspaceBox",
        "upright_cup": "UprightFull",
    }
    upright = next(c for c in answer.constraints if c.spec.id == "upright_cup")
    assert upright.anchor == "cup" and upright.arm == "right" and upright.rules and "spill" in upright.reason


def test_an_answer_is_kept_per_session_and_state_and_asking_changes_nothing(session, handed):
    first, again, seconds = handed
    assert again is first and seconds < 0.1  # a look-up (about 1 ms), not a plan (about 1 s)
    assert session.checker.scene.humans == [] and session.constraints == {}


def test_a_person_beside_the_receivers_hand_makes_the_handover_infeasible_with_the_reason(session, handed):
    scene = session.checker.scene
    session.set_scene(scene.model_copy(update={"humans": [BOB_BESIDE_ALICE]}))
    try:
        answer = feasible(session, WORLD, HAND_OVER, EXAMPLES)
    finally:
        session.set_scene(scene)
    assert not answer.ok and answer.cost is None and answer.trajectories == []
    assert answer.status == Status.UNREACHABLE_GOAL
    assert (
        answer.reason.startswith("no valid IK solution for the goal pose") and "keep-out:keep_out_bob" in answer.reason
    )
    keep_out = next(c for c in answer.constraints if c.spec.id == "keep_out_bob")  # bob: a bystander the rules protect
    assert keep_out.kind == "KeepOutBystander" and keep_out.spec.keep_out_all_links
    # The handover planned without bob ends inside that cylinder standing at him (the tests' own
    # distance from the URDF meshes to it).
    spec = keep_out.spec
    around_bob = pin.SE3(np.eye(3), np.array([*BOB_BESIDE_ALICE.position, spec.height / 2]))
    reached, _ = clearance(handed[0].trajectories[0], coal.Cylinder(spec.radius, spec.height), around_bob)
    assert reached < -0.05


def test_the_robot_starts_where_the_session_has_it(session):
    ready = feasible(session, WORLD, "place_cup", EXAMPLES)
    q = dict(ready.trajectories[0].start)
    moved = {"right_shoulder_pan_joint": q["right_shoulder_pan_joint"] + 0.1}
    session.set_configuration(q | moved)
    try:
        answer = feasible(session, WORLD, "place_cup", EXAMPLES)
    finally:
        session.configuration = None
    assert answer.ok and answer is not ready
    first = answer.trajectories[0]
    assert first.start["right_shoulder_pan_joint"] == pytest.approx(moved["right_shoulder_pan_joint"])
    assert answer.constraints == ready.constraints and {c.kind for c in answer.constraints} == {
        "KeepOutWaitingPartner",
        "UprightFull",
    }


def test_a_session_keeps_only_its_latest_answers(session, handed, monkeypatch):
    monkeypatch.setattr(feasibility, "KEPT_ANSWERS", 1)
    assert feasible(session, WORLD, HAND_OVER, EXAMPLES) is handed[0]  # still kept
    place = feasible(session, WORLD, "place_cup", EXAMPLES, time_limit=0.9)  # a new question (its budget)
    assert list(feasibility._ANSWERS[session].values()) == [place]


def test_a_step_the_state_does_not_have_or_cannot_take_is_a_one_line_error(session):
    with pytest.raises(HriplanError, match=r"^task 'deliver_cup' has no step 'fly'; steps: hand_over_cup, place_cup$"):
        feasible(session, WORLD, "fly", EXAMPLES)
    with pytest.raises(HriplanError, match=r"^step in task 'deliver_cup': steps\.0: hand_over 'mug' is not among"):
        feasible(session, WORLD, Step(goal={"hand_over": "mug", "to": "alice"}), EXAMPLES)
