"""Timing never gives up on a valid path: where the timed spline rounds a corner off the validated
path, the motion comes to rest at that corner; a motion whose start is its goal is one point.

The geometry is checked here with the URDF's own kinematics (tests/independent.py), apart from
the planner's evaluator."""

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from typer.testing import CliRunner

import hriplan.planner.session as session_module
import hriplan.planner.timing as timing
from hriplan.cli.main import app
from hriplan.planner.constraints.spec import BoxConstraint
from hriplan.planner.motion import JointTarget, MotionResult, plan_motion
from hriplan.planner.options import PlanOptions
from hriplan.planner.session import PlanningSession
from hriplan.planner.trajectory import load_trajectory
from hriplan.planner.validate import PathValidation
from hriplan.robots.model import arms_of
from hriplan.robots.spatial import Pose
from independent import UrdfRobot

DATA = Path(__file__).parents[1] / "data" / "whole_tasks"
# An L in joint space: the pan turns to 0.6, then the shoulder lifts. A wall stands where the tool
# is at the corner, facing the way the pan turned: the polyline only touches it there.
A = np.array([0.0, -1.2, 1.2, -1.5, -1.57, 0.0])
B = A + np.array([0.6, 0, 0, 0, 0, 0])
C = B + np.array([0, 0.4, 0, 0, 0, 0])
GAP = 2e-4  # the wall this far beyond the corner: within it the polyline, not a natural spline


@pytest.fixture(scope="module")
def ur5():
    session = PlanningSession("ur5")
    arm = next(iter(arms_of("ur5")))
    return session, session.robot.arm_group(arm), session.robot.tool_frame(arm)


def _tool(urdf: UrdfRobot, names: list[str], x: np.ndarray, tool: str) -> np.ndarray:
    urdf.configure(dict(zip(names, x)))
    return urdf.pose(tool).translation.copy()


def test_a_corner_the_spline_rounds_into_a_wall_is_timed_with_a_rest_there(ur5):
    session, group, tool = ur5
    names = session.robot.group_joints(group)
    urdf = UrdfRobot("ur5", {})
    corner = _tool(urdf, names, B, tool)
    ahead = _tool(urdf, names, B + np.array([1e-4, 0, 0, 0, 0, 0]), tool) - corner
    normal = ahead / np.linalg.norm(ahead)  # the way the pan moves the tool at the corner
    along = [float((_tool(urdf, names, x, tool) - corner) @ normal) for x in np.linspace(A, C, 50)]
    legs = [
        float((_tool(urdf, names, x, tool) - corner) @ normal)
        for t in np.linspace(0, 1, 40)
        for x in (A + t * (B - A), B + t * (C - B))
    ]
    assert max(legs) < 1e-9 and max(along) < 0.0  # the validated path keeps to this side of the wall
    wall = BoxConstraint(
        id="wall",
        joints=names,
        target_link=tool,
        size=(2.0, 2.0, 2.0),
        frame={
            "entity": "world",
            "offset": Pose(
                xyz=tuple(corner + (GAP - 1.0) * normal), rpy=(0.0, 0.0, float(np.arctan2(normal[1], normal[0])))
            ),
        },
    )
    session.set_constraints([wall])
    start = dict(zip(session.robot.joint_names, session.robot.configuration(A, group).tolist()))
    motion = MotionResult(
        status="solved", group=group, joint_names=names, start=start, path=[A.tolist(), B.tolist(), C.tolist()]
    )
    result = session.time(motion, PlanOptions())
    assert result.solved, result.message  # before: timing_failed, "the timed trajectory left the validated path"
    trajectory = result.trajectory
    assert trajectory.report.rests == 1
    positions = np.array([p.positions for p in trajectory.points])
    velocities = np.array([p.velocities for p in trajectory.points])
    at_corner = np.flatnonzero(np.abs(positions - B).max(axis=1) < 1e-9)
    assert len(at_corner) == 1 and np.abs(velocities[at_corner[0]]).max() < 1e-9  # it stops at the corner
    beyond = max(float((_tool(urdf, names, x, tool) - corner) @ normal) for x in positions)
    assert beyond <= GAP + 1e-9  # every written point on the near side of the wall, by the URDF
    # Every point lies on one of the two legs of the validated path.
    on_leg = [
        min(
            np.abs(x - (a + np.clip((x - a) @ (b - a) / ((b - a) @ (b - a)), 0, 1) * (b - a))).max()
            for a, b in ((A, B), (B, C))
        )
        for x in positions
    ]
    assert max(on_leg) < 1e-9


def test_a_path_that_leaves_even_with_a_rest_at_every_corner_fails_with_the_reason(ur5, monkeypatch):
    session, group, tool = ur5
    names = session.robot.group_joints(group)
    session.set_constraints([])
    start = dict(zip(session.robot.joint_names, session.robot.configuration(A, group).tolist()))
    motion = MotionResult(
        status="solved", group=group, joint_names=names, start=start, path=[A.tolist(), B.tolist(), C.tolist()]
    )
    real = session_module.validate_path
    planned = PathValidation(valid=True, states_checked=3, constraints=[])  # as the planner validated it
    motion = motion.model_copy(update={"validation": planned})
    calls = []

    def never_valid(*args, **kwargs):
        calls.append(1)
        check = real(*args, **kwargs)
        return check.model_copy(update={"valid": False, "message": "made up", "failed_state": list(B)})

    monkeypatch.setattr(session_module, "validate_path", never_valid)
    result = session.time(motion, PlanOptions())
    assert result.status == "timing_failed" and "even at rest at 1 of its waypoints: made up" in result.message
    assert len(calls) == len(session_module.TIMING_STEPS) + 1  # the one corner was the only rest to try


def test_start_equal_to_goal_is_solved_with_a_motion_of_one_point(ur5):
    session, group, _ = ur5
    session.set_constraints([])
    start = dict(zip(session.robot.joint_names, session.robot.configuration(A, group).tolist()))
    result = session.plan(start, JointTarget(values=A.tolist()), PlanOptions(seed=1), group)
    assert result.solved and result.message == session_module.ALREADY_THERE  # before: TOPP-RA's shape error
    (point,) = result.trajectory.points
    assert point.positions == pytest.approx(A.tolist()) and point.time_from_start == 0.0
    assert point.velocities == [0.0] * 6 and point.accelerations == [0.0] * 6
    assert result.trajectory.report.duration == 0.0 and result.trajectory.report.path_length == 0.0


def test_a_task_step_that_stays_put_is_solved_and_validates(tmp_path):
    task = tmp_path / "stay.yaml"
    task.write_text(
        "name: stay\nrobot: madar\nhands: {right: power}\nstart: {posture: ready}\n"
        "steps:\n  - {name: stay, goal: {posture: ready}}\nplanning: {seed: 1}\n"
    )
    runner = CliRunner()
    planned = runner.invoke(app, ["plan", str(task), "-o", str(tmp_path / "stay.json"), "-q"])
    assert planned.exit_code == 0, planned.output
    assert "step stay (Transport, right arm): solved: already there: the start is the goal" in planned.output
    trajectory = load_trajectory(tmp_path / "stay.json")
    assert len(trajectory.points) == 1
    checked = runner.invoke(app, ["validate", str(tmp_path / "stay.json")])
    assert checked.exit_code == 0 and "checked 1 states" in checked.output


def test_a_path_made_outside_the_planner_that_breaks_a_constraint_names_it(ur5):
    """A lift or a retreat is a straight line made outside the planner: it is validated before it
    is timed, and a constraint it breaks is named (not 'the timed trajectory left the path')."""
    session, group, tool = ur5
    names = session.robot.group_joints(group)
    urdf = UrdfRobot("ur5", {})
    low = min(_tool(urdf, names, x, tool)[2] for x in np.linspace(A, C, 20))
    ceiling = BoxConstraint(  # the tool stays below a ceiling the path rises through
        id="below_shelf",
        joints=names,
        target_link=tool,
        size=(4.0, 4.0, 1.0),
        frame={"offset": {"xyz": [0, 0, low - 0.49]}},
    )
    session.set_constraints([ceiling])
    start = dict(zip(session.robot.joint_names, session.robot.configuration(A, group).tolist()))
    motion = MotionResult(status="solved", group=group, joint_names=names, start=start, path=[A.tolist(), C.tolist()])
    result = session.time(motion, PlanOptions())
    assert result.status == "invalid_path" and result.message == "the path breaks constraint below_shelf violated"


def test_a_search_that_times_out_says_which_constraint_the_direct_motion_breaks(ur5):
    """A keep-out slab through the robot's axis between the tool's start and goal: no path
    exists, and the timeout names the constraint in the way (a preparatory turn's message quotes it)."""
    session, group, tool = ur5
    names = session.robot.group_joints(group)
    urdf = UrdfRobot("ur5", {})
    goal = A + np.array([1.2, 0, 0, 0, 0, 0])
    azimuths = [np.arctan2(*_tool(urdf, names, x, tool)[1::-1]) for x in (A, goal)]
    between = float(np.mean(azimuths))  # a vertical plane through z at this azimuth parts the two
    wall = BoxConstraint(
        id="glass_wall",
        joints=names,
        target_link=tool,
        region="outside",
        size=(8.0, 0.3, 8.0),
        frame={"offset": {"rpy": [0.0, 0.0, between]}},
    )
    session.set_constraints([wall])
    start = dict(zip(session.robot.joint_names, session.robot.configuration(A, group).tolist()))
    result = plan_motion(
        session.robot,
        session.checker,
        [wall],
        start,
        JointTarget(values=goal.tolist()),
        PlanOptions(time_limit=0.5, seed=1),
        group,
    )
    assert result.status == "timeout"
    assert "; the straight joint line to the goal leaves glass_wall (by 0.15)" in result.message  # half its thickness


@pytest.mark.parametrize("row", [0, 1, 2, None])  # positions, velocities, accelerations; the duration
def test_a_timed_sample_that_is_not_finite_fails_the_timing(ur5, monkeypatch, row):
    """A file's points are built around the timing's own lists unchecked, and no limit check
    reads a NaN (its comparisons are false): a NaN or an infinity in its samples fails the timing,
    so no file is returned and the result says why in one line; the same motion timed as it is
    gives the planned file."""
    session, group, _ = ur5
    session.set_constraints([])
    start = dict(zip(session.robot.joint_names, session.robot.configuration(A, group).tolist()))
    planned = session.plan(start, JointTarget(values=B.tolist()), PlanOptions(seed=1), group, safety=None)
    retimed = timing._retimed
    for bad in (float("nan"), float("inf"), -float("inf")):

        def spoiled(*args, bad=bad, **kwargs):
            made = retimed(*args, **kwargs)
            samples = made.samples

            def spoiled_samples(times):
                rows = [values.copy() for values in samples(times)]
                rows[row][len(rows[row]) // 2, 3] = bad
                return tuple(rows)

            if row is None:  # a trajectory that ends at no number
                return SimpleNamespace(path_interval=np.array([0.0, bad]), samples=samples)
            made.samples = spoiled_samples
            return made

        monkeypatch.setattr(timing, "_retimed", spoiled)
        result = session.time(planned.motion, PlanOptions(seed=1), safety=None)
        assert not result.solved and result.trajectory is None
        assert result.message.endswith("the timed motion holds a number that is not finite (NaN or infinite)")
        assert "\n" not in result.message
    monkeypatch.setattr(timing, "_retimed", retimed)
    again = session.time(planned.motion, PlanOptions(seed=1), safety=None).trajectory
    assert [p.model_dump() for p in again.points] == [p.model_dump() for p in planned.trajectory.points]
    assert type(again.points[0]).__name__ == "TrajectoryPoint" and again.points[1].time_from_start > 0.0
