"""A plan's outcome: one Status with the values files always carried, decided where the reason is known."""

import json

import numpy as np
import pytest

from hriplan.planner import motion as motion_module
from hriplan.planner.motion import plan_motion
from hriplan.planner.options import PlanOptions
from hriplan.planner.outcome import Status
from hriplan.planner.search.result import SearchResult
from hriplan.planner.session import PlanningSession


@pytest.fixture(scope="module")
def session(problem):
    s = PlanningSession(problem.robot, problem.scene)
    s.set_constraints(problem.constraints)
    return s


def test_the_values_are_the_strings_of_the_file_formats():
    assert [s.value for s in Status] == [
        "solved",
        "derived",
        "invalid_start",
        "invalid_goal",
        "unreachable_goal",
        "timeout",
        "invalid_path",
        "planner_error",
        "timing_failed",
        "error",
        "worker_died",
    ]
    assert json.dumps({"status": Status.TIMING_FAILED}) == '{"status": "timing_failed"}'
    assert f"planning failed ({Status.TIMEOUT})" == "planning failed (timeout)" and Status("solved") is Status.SOLVED


def _scripted(monkeypatch, run: SearchResult) -> list[int]:
    """Every search answers `run`; the list counts the searches."""
    calls = []

    def solve(problem, options, ends, is_valid, rows, attempt):
        calls.append(attempt)
        return run

    monkeypatch.setattr(motion_module, "_solve", solve)
    return calls


def _plan(problem, session, time_limit=0.3):
    return plan_motion(
        session.robot,
        session.checker,
        list(session.constraints.values()),
        problem.start,
        problem.goal,
        PlanOptions(time_limit=time_limit),
    )


def test_a_planner_error_is_reported_as_the_search_says_whatever_its_words(problem, session, monkeypatch):
    """The search's status, not its message's prefix: one attempt, then planner_error."""
    calls = _scripted(monkeypatch, SearchResult(Status.PLANNER_ERROR, [], "projected", "the chart could not anchor"))
    result = _plan(problem, session)
    assert (result.status, result.message, calls) == (Status.PLANNER_ERROR, "the chart could not anchor", [0])


def test_a_timeout_is_a_timeout_even_if_its_message_names_dense_validation(problem, session, monkeypatch):
    calls = _scripted(monkeypatch, SearchResult(Status.TIMEOUT, [], "projected", "no path before dense validation"))
    result = _plan(problem, session)
    assert result.status == Status.TIMEOUT and len(calls) > 1
    assert result.message.startswith("no path before dense validation; the straight joint line to the goal ")


def test_a_found_path_that_fails_dense_validation_is_invalid_path(problem, session, monkeypatch):
    """A path through a tipped cup (wrist turned by pi) breaks the upright constraint between its states."""
    x = np.array([problem.start[j] for j in session.robot.group_joints()])
    tipped = x.copy()
    tipped[session.robot.group_joints().index("wrist_2_joint")] += np.pi
    _scripted(monkeypatch, SearchResult(Status.SOLVED, [tipped], "projected"))
    result = _plan(problem, session)
    assert result.status == Status.INVALID_PATH and "dense validation" in result.message and not result.path
