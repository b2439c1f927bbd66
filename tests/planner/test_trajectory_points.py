"""A trajectory file's points: built around a timed motion's own lists (`timed_points`) they are
the validated points, the file's text the same; a file that is not a motion is refused with the
validated file's messages. (A timed motion's numbers are finite by its type: test_timed_built.py,
test_timing_stays_on_path.py.)"""

import json

import numpy as np
import pytest
from pydantic import ValidationError

from hriplan.planner.trajectory import TrajectoryFile, TrajectoryPoint, timed_points

JOINTS = ["a", "b", "c"]


def _samples(count: int = 40) -> tuple[list[float], list[list[float]], list[list[float]], list[list[float]]]:
    """A timed motion's rows as `TimedPath` holds them (tolist of float arrays)."""
    rng = np.random.default_rng(7)
    times = np.append(0.01 * np.arange(count - 1), 0.01 * (count - 1.5))
    return times.tolist(), *(rng.normal(size=(count, len(JOINTS))).tolist() for _ in range(3))


def _file(points: list) -> TrajectoryFile:
    report = {
        "status": "solved",
        "planner": "p",
        "space": "joint",
        "planning_time": 0.1,
        "duration": 1.0,
        "path_length": 1.0,
        "states_checked": 3,
        "max_violation": {},
    }
    return TrajectoryFile(robot="ur5", joint_names=JOINTS, points=points, constraints=[], report=report)


def _as_dicts(rows) -> list[dict]:
    return [
        {"time_from_start": t, "positions": p, "velocities": v, "accelerations": a}
        for t, p, v, a in zip(*rows, strict=True)
    ]


def test_built_points_are_the_validated_ones_around_the_same_lists():
    rows = _samples()
    built = timed_points(*rows)
    validated = [TrajectoryPoint(**d) for d in _as_dicts(rows)]
    assert all(type(p) is TrajectoryPoint for p in built)
    for made, valid, positions in zip(built, validated, rows[1], strict=True):
        assert made == valid and made.model_dump_json() == valid.model_dump_json()
        assert made.model_fields_set == valid.model_fields_set
        assert (made.__pydantic_extra__, made.__pydantic_private__) == (valid.__pydantic_extra__, None)
        assert made.positions is positions  # not copied
    assert _file(built).text() == _file(_as_dicts(rows)).text()
    built[0].positions = [1.0, 2.0, 3.0]  # their fields set is one, holding every field
    assert built[0].positions == [1.0, 2.0, 3.0] and built[1].model_fields_set == set(TrajectoryPoint.model_fields)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda p: p.clear(), "a trajectory needs at least 1 point, got 0"),
        (
            lambda p: (p.__delitem__(slice(1, None)), p[0]["velocities"].__setitem__(1, 0.5)),
            "points.0: a trajectory of one point (its start is its goal) is at rest",
        ),
        (
            lambda p: p[7]["accelerations"].pop(),
            "points.7: positions, velocities and accelerations need one value per joint (3)",
        ),
        (
            lambda p: p[9]["positions"].append(0.0),
            "points.9: positions, velocities and accelerations need one value per joint (3)",
        ),
        (
            lambda p: p[0].__setitem__("time_from_start", 0.5),
            "points.0: time_from_start is 0.5, a trajectory starts at 0",
        ),
        (
            lambda p: p[12].__setitem__("time_from_start", 0.11),
            "points.12: time_from_start 0.11 does not come after 0.11 (times must increase)",
        ),
        (
            lambda p: p[39].__setitem__("time_from_start", 0.2),
            "points.39: time_from_start 0.2 does not come after 0.38 (times must increase)",
        ),
    ],
)
def test_a_file_that_is_no_motion_is_refused_with_its_message(change, message):
    points = _as_dicts(_samples())
    change(points)
    with pytest.raises(ValidationError) as raised:
        _file(points)
    assert [e["msg"] for e in raised.value.errors()] == [f"Value error, {message}"]
    # as a file read from disk: the same message
    with pytest.raises(ValidationError) as loaded:
        TrajectoryFile.model_validate_json(
            json.dumps(json.loads(_file(_as_dicts(_samples())).text()) | {"points": points})
        )
    assert [e["msg"] for e in loaded.value.errors()] == [f"Value error, {message}"]
