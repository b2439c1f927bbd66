"""The retreat after a release (planner/lift.py retreat_path) asks each distance what is cheapest
first and shares the IK of lines that begin alike; the retreat it chooses must still be the first
direction and distance that passes every check. Checked against the rule written out here: every
line solved afresh, every check asked of every distance in the order the rule states, on checkers
built here (the bench's re-planned handover: the 6 and 9 cm retreats end with the closed hand in
the can, the 12 cm one is taken)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hriplan.planner.lift import RETREATS, SIDEWAYS, WAYPOINT, retreat_path
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.ik import solve_ik
from hriplan.tasks import pipeline
from hriplan.tasks.load import load_task
from hriplan.tasks.pipeline import TaskRunner
from independent import UrdfRobot, densified

EXAMPLE = Path(__file__).parents[2] / "examples" / "handover_full_can_receiver.yaml"


@pytest.fixture(scope="module")
def released():
    """The arguments the task runner gave retreat_path for the example's handover."""
    calls = []
    original = pipeline.retreat_path
    pipeline.retreat_path = lambda *a: calls.append(a) or original(*a)
    try:
        outcome = TaskRunner(load_task(EXAMPLE), EXAMPLE.parent).run()
    finally:
        pipeline.retreat_path = original
    assert [s.status for s in outcome.steps] == ["solved", "solved"]
    (call,) = calls
    return call


def _line(robot, checker, arm, q0, move):
    """IK every WAYPOINT along `move`, each nearest the one before: the waypoints, or None."""
    group = robot.arm_group(arm)
    tool = robot.frame_pose(robot.tool_frame(arm), q0)
    n = max(1, int(np.ceil(np.linalg.norm(move) / WAYPOINT)))
    waypoints = [robot.group_values(q0, group)]
    for k in range(1, n + 1):
        target = tool.copy()
        target[:3, 3] += move * k / n
        ik = solve_ik(
            robot,
            arm,
            target,
            base_q=robot.configuration(waypoints[-1], group, base=q0),
            reference=waypoints[-1],
            is_valid=lambda q: not checker.in_collision(q),
        )
        if not ik.success:
            return None
        waypoints.append(np.array(ik.q))
    return waypoints


def _rule(hands, closed, arm, arrival, obj, touching, free):
    """The first hand, direction and distance that passes every check, with why each before failed."""
    q0, refused = arrival[-1], []
    next_start = CollisionChecker(closed, free)
    for hand in hands:
        checker, untouched = CollisionChecker(hand, touching), CollisionChecker(hand, free)
        if checker.in_collision(q0):
            refused.append("collides at the release")
            continue
        tool = [hand.frame_pose(hand.tool_frame(arm), q)[:3] for q in arrival]
        came = [t[:, 3] - tool[-1][:, 3] for t in tool if np.linalg.norm(t[:, 3] - tool[-1][:, 3]) >= WAYPOINT]
        ways = [-tool[-1][:, 2], *([came[-1] / np.linalg.norm(came[-1])] if came else []), np.array([0.0, 0, 1])]
        group = hand.arm_group(arm)
        for direction in ways:
            for distance in RETREATS:
                waypoints = _line(hand, checker, arm, q0, direction * distance)
                if waypoints is None:
                    refused.append((distance, "no line"))
                    continue
                states = [hand.configuration(x, group, base=q0) for x in densified(np.array(waypoints), 0.01)]
                tips = np.array([hand.frame_pose(hand.tool_frame(arm), q)[:3, 3] for q in states]) - tool[-1][:, 3]
                along = tips @ direction
                off = np.linalg.norm(tips - np.outer(along, direction), axis=1).max()
                touches = [untouched.touches(q, obj) for q in states]
                first_clear = touches.index(False) if False in touches else len(touches)
                why = (
                    "not straight"
                    if np.diff(along).min() < -1e-6 or off > SIDEWAYS
                    else "collides"
                    if any(checker.in_collision(q) for q in states)
                    else "touches"
                    if any(touches[first_clear:]) or touches[-1]
                    else "next start collides"
                    if next_start.in_collision(states[-1])
                    else ""
                )
                if not why:
                    return hand, waypoints, distance, refused
                refused.append((distance, why))
    return None, None, None, refused


def test_the_retreat_is_the_first_that_passes_every_check_asked_in_full(released):
    hands, closed, arm, arrival, obj, touching, free = released
    hand, path, why = retreat_path(*released)
    expected, waypoints, distance, refused = _rule(*released)
    assert why == "" and hand is expected is hands[0]  # the hand opened
    assert refused == [(0.06, "next start collides"), (0.09, "next start collides")] and distance == 0.12
    assert len(path) == len(waypoints) and max(np.abs(a - b).max() for a, b in zip(path, waypoints)) < 1e-12
    # The tool backs 12 cm away from the palm, by the URDF's own kinematics.
    urdf, group = UrdfRobot("madar", dict(hand.hand_postures)), hand.arm_group(arm)
    tips = []
    for x in (path[0], path[-1]):
        q = hand.configuration(x, group, base=arrival[-1])
        urdf.configure(dict(zip(hand.joint_names, q.tolist())))
        tips.append((urdf.pose(f"{arm}_tool").translation.copy(), urdf.pose(f"{arm}_tool").rotation[:, 2].copy()))
    (start, palm), (end, _) = tips
    assert np.allclose(end - start, -0.12 * palm, atol=2e-3)
