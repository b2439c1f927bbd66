"""Models the planner builds without validating them again (`model_construct`, where the values
are made by the code itself): each must equal the validated model of the same values, field types
and JSON alike, on a real re-plan's outputs (the example handover)."""

import copy
from pathlib import Path

import pytest

from hriplan.planner import session as session_module
from hriplan.planner.session import PlanningSession, PlanResult
from hriplan.planner.timing import TimedPath
from hriplan.planner.trajectory import TrajectoryFile
from hriplan.tasks.load import load_task
from hriplan.tasks.pipeline import TaskRunner

EXAMPLE = Path(__file__).parents[2] / "examples" / "handover_full_can_receiver.yaml"


@pytest.fixture(scope="module")
def handover() -> tuple[list[TimedPath], list[PlanResult]]:
    """Every TimedPath the example's handover timed (each part, then the parts joined) and every
    result `PlanningSession.time` gave."""
    made, results = [], []
    originals = session_module.time_parameterize, session_module.joined, PlanningSession.time
    session_module.time_parameterize = lambda *a, **k: made.append(originals[0](*a, **k)) or made[-1]
    session_module.joined = lambda parts: made.append(originals[1](parts)) or made[-1]
    PlanningSession.time = lambda *a, **k: results.append(originals[2](*a, **k)) or results[-1]
    try:
        outcome = TaskRunner(load_task(EXAMPLE), EXAMPLE.parent).run()
    finally:
        session_module.time_parameterize, session_module.joined, PlanningSession.time = originals
    assert [s.status for s in outcome.steps] == ["solved", "solved"]
    return made, results


@pytest.fixture(scope="module")
def timed_paths(handover) -> list[TimedPath]:
    return handover[0]


def _types(value: object) -> object:
    """The type of every leaf of `value` (lists walked): what validation would have coerced."""
    return [_types(v) for v in value] if isinstance(value, list) else type(value)


def test_a_built_timed_path_is_the_validated_one(timed_paths):
    assert len(timed_paths) >= 4  # two motions, each a part and the parts joined
    for built in timed_paths:
        validated = TimedPath(**{name: getattr(built, name) for name in TimedPath.model_fields})
        assert built == validated
        assert built.model_dump_json() == validated.model_dump_json()
        for name in TimedPath.model_fields:
            assert _types(getattr(built, name)) == _types(getattr(validated, name)), name


def test_a_solved_result_is_the_validated_one(handover):
    solved = [r for r in handover[1] if r.solved]
    assert len(solved) >= 2  # the two motions
    for built in solved:
        validated = PlanResult(**{name: getattr(built, name) for name in built.model_fields_set})
        assert built.model_fields_set == validated.model_fields_set
        assert built == validated
        assert built.model_dump_json() == validated.model_dump_json()


def test_a_solved_results_trajectory_file_is_the_validated_one(handover):
    """The file is built around the session's models and the timed samples (`_file`): the one
    validation makes of the same values, its invariants (times from 0 increasing, a value per
    joint) checked there, its text and every leaf's type the same."""
    solved = [r for r in handover[1] if r.solved]
    given = {"robot", "robot_file", "hands", "joint_names", "start", "scene", "points", "constraints", "report"}
    for result in solved:
        built = result.trajectory
        assert built.model_fields_set == given  # none left to its default
        validated = TrajectoryFile(**{name: getattr(built, name) for name in built.model_fields_set})
        assert built.model_fields_set == validated.model_fields_set
        assert built == validated
        assert built.text() == validated.text()
        for name in TrajectoryFile.model_fields:
            assert _types(getattr(built, name)) == _types(getattr(validated, name)), name


def test_a_timed_path_not_finite_is_refused_and_a_file_naming_fewer_joints_is_validated(handover):
    """A file's points are built around a TimedPath's lists unchecked, so a TimedPath holds only
    finite numbers: validation refuses a NaN or an infinity, naming the field; a file of a motion
    naming fewer joints than its path has is validated, and refused with the point and field, as a
    file read from disk would be; a file built holds its own lists."""
    import numpy as np
    from pydantic import ValidationError

    from hriplan.planner.motion import MotionResult
    from hriplan.planner.problem import PlanOptions
    from hriplan.planner.validate import PathValidation

    session = PlanningSession("ur5")
    names = session.robot.joint_names
    rows = {
        "times": [0.0, 0.5, 1.0],
        "positions": [[0.0] * 6, [0.1] * 6, [0.2] * 6],
        "velocities": [[0.0] * 6, [0.1] * 6, [0.0] * 6],
        "accelerations": [[0.0] * 6] * 3,
    }
    for field, row, column in (("times", 1, None), ("positions", 1, 0), ("velocities", 1, 5), ("accelerations", 2, 3)):
        for bad in (float("nan"), float("inf"), -float("inf")):
            spoiled = copy.deepcopy(rows)
            if column is None:
                spoiled[field][row] = bad
            else:
                spoiled[field][row][column] = bad
            where = f"{row}" if column is None else f"{row}\\.{column}"
            with pytest.raises(ValidationError, match=rf"{field}\.{where}\n"):
                TimedPath(**spoiled, path_deviation=0.0)
    timed = TimedPath(**rows, path_deviation=0.0)
    motion = MotionResult(status="solved", group=session.robot.default_group, joint_names=names)
    check = PathValidation(valid=True, states_checked=3, constraints=[])
    path, q0 = np.array([[0.0] * 6, [0.2] * 6]), np.zeros(6)
    built = session._file(motion, path, [], timed, check, PlanOptions(), q0)
    assert built.points[1].positions == [0.1] * 6
    # its own lists, as validation would copy them: changing the file changes no motion nor robot
    assert built.joint_names == motion.joint_names and built.joint_names is not motion.joint_names
    assert built.hands == session.robot.hand_postures and built.hands is not session.robot.hand_postures
    fewer = motion.model_copy(update={"joint_names": names[:2]})  # a motion given to `time` by a caller
    with pytest.raises(ValidationError, match=r"one value per joint \(2\)"):
        session._file(fewer, path, [], timed, check, PlanOptions(), q0)
