"""Planning and dense validation hold still what a motion of one group cannot move
(`CollisionChecker.moving`, robots/still_pairs.py): every state the planner asks is asked within a
motion of the planned group from its start; plans and trajectories are those of the full check,
bit for bit; a collision of the still parts fails the start and a path's first state, named."""

from __future__ import annotations

import contextlib
from pathlib import Path

import numpy as np
import pytest

from hriplan.planner.constraints.evaluator import ConstraintEvaluator
from hriplan.planner.motion import JointTarget, plan_motion
from hriplan.planner.options import PlanOptions
from hriplan.planner.problem import load_problem
from hriplan.planner.session import PlanningSession
from hriplan.planner.validate import validate_path
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.scene import Box, Obstacle
from hriplan.robots.spatial import Pose

HANDOVER = Path(__file__).parents[2] / "benchmarks" / "scenarios" / "b_madar_handover.json"


@pytest.fixture(scope="module")
def handover():
    problem = load_problem(HANDOVER)
    session = PlanningSession(problem.robot, problem.scene, problem.hands or None)
    session.set_constraints(problem.constraints)
    return problem, session


def _plan(problem, session, seed: int):
    options = problem.options.model_copy(update={"seed": seed})
    return session.plan(problem.start, problem.goal, options, problem.group, safety=None)


def test_every_state_a_plan_its_timing_and_leave_check_ask_is_asked_within_a_motion_of_its_group(
    handover, monkeypatch, either_route
):
    problem, session = handover
    asked: list[tuple[frozenset[int] | None, bytes | None]] = []
    for name in ("in_collision", "first_collision", "compiled_verdict"):
        original = getattr(CollisionChecker, name)

        def spy(self, q, original=original):
            motion = self._motion
            asked.append((None, None) if motion is None else (motion.moved, motion.base.tobytes()))
            return original(self, q)

        monkeypatch.setattr(CollisionChecker, name, spy)
    motion = plan_motion(
        session.robot,
        session.checker,
        list(session.constraints.values()),
        problem.start,
        problem.goal,
        problem.options,
        "right_arm",
    )
    assert motion.solved, motion.message
    start = session.robot.configuration(problem.start).tobytes()
    moved = session.robot.moved_joints("right_arm")
    # (the compiled walk asks for the certifier once a walk, and the checker about states it cannot clear)
    assert len(asked) > (2 if either_route else 10) and set(asked) == {(moved, start)}
    asked.clear()
    timed = session.time(motion, problem.options, safety=None)  # dense validation of the timed path
    assert timed.solved and len(asked) >= 1 and set(asked) == {(moved, start)}
    asked.clear()
    assert session.leave(problem.start, problem.options, "right_arm", safety=None) is None  # the start asked
    assert len(asked) >= 1 and set(asked) == {(moved, start)}
    assert session.checker._motion is None


def test_plans_and_trajectories_are_the_full_checks(handover, monkeypatch, either_route):
    """The handover, three seeds: the same paths and timed positions as with every pair asked at
    every state (the block made a no-op)."""
    problem, session = handover
    held = [_plan(problem, session, seed) for seed in range(3)]
    monkeypatch.setattr(CollisionChecker, "moving", lambda self, joints, q: contextlib.nullcontext())
    full = [_plan(problem, session, seed) for seed in range(3)]
    for a, b in zip(held, full):
        assert a.solved and b.solved
        assert np.array_equal(a.motion.path, b.motion.path)
        untimed = {"report": {"planning_time"}}  # the one field a clock gives
        assert a.trajectory.model_dump(exclude=untimed) == b.trajectory.model_dump(exclude=untimed)
        assert a.motion.validation == b.motion.validation


def test_the_other_arm_in_a_box_fails_the_start_and_the_first_state(handover, either_route):
    problem, session = handover
    robot = session.robot
    q0 = robot.configuration(problem.start)
    hand = robot.frame_pose(robot.tool_frame("left"), q0)[:3, 3]
    crate = Obstacle(name="crate", shape=Box(size=(0.1, 0.1, 0.1)), pose=Pose(xyz=tuple(hand)))
    checker = CollisionChecker(robot, problem.scene.model_copy(update={"obstacles": [*problem.scene.obstacles, crate]}))
    evaluator = ConstraintEvaluator(robot, [], "right_arm", q0)
    x0 = robot.group_values(q0, "right_arm")
    found = validate_path(evaluator, checker, [x0, x0 + 0.2], 0.01)
    contacts = checker.contacts(q0)
    assert found.collision == f"{contacts[0].a} - {contacts[0].b} at dense state 0 of {found.states_checked}"
    assert any("crate" in c.a + c.b and "left" in c.a + c.b for c in contacts)
    goal = JointTarget(values=(x0 + 0.2).tolist())
    motion = plan_motion(robot, checker, [], problem.start, goal, PlanOptions(seed=0), "right_arm")
    assert motion.status == "invalid_start" and "crate" in motion.message
