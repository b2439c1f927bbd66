"""Dense validation (`validate_path`) against the plain state-by-state check it replaced: densify
one segment at a time, every state's margins and collision in order, the closest person from
`human_distances` at every sampled state. Same PathValidation, field for field, on paths that
stay valid, leave constraints, collide (the first colliding state named) and pass a person."""

import numpy as np
import pinocchio as pin
import pytest

from hriplan import HriplanError
from hriplan.planner.constraints.binding import bind
from hriplan.planner.constraints.evaluator import ConstraintEvaluator
from hriplan.planner.constraints.spec import BoxConstraint, FrameRef, OrientationConstraint
from hriplan.planner.validate import (
    DISTANCE_SAMPLES,
    VALIDATION_TOLERANCE,
    ConstraintCheck,
    PathValidation,
    densify,
    validate_path,
)
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.human import HumanSpec
from hriplan.robots.kernel_switch import kernels_on, use_kernels
from hriplan.robots.scene import Scene, table
from hriplan.robots.spatial import Pose
from independent import densified
from madar_states import CLEAR


def _one_state_at_a_time(evaluator, checker, states, step, human_distance) -> PathValidation:
    """The validation as it was: densify row by row, then each state in turn."""
    dense = [np.asarray(states[0], dtype=float)]
    for a, b in zip(states, states[1:]):
        count = max(1, int(np.ceil(np.abs(b - a).max() / step)))
        dense.extend(a + (b - a) * (k / count) for k in range(1, count + 1))
    dense = np.array(dense)
    worst = np.full(len(evaluator.constraints), -np.inf)
    collision, failed = None, None
    for k, x in enumerate(dense):
        q = evaluator.full(x)
        margins = evaluator.margins(q) if evaluator.constraints else np.zeros(0)
        worst = np.maximum(worst, margins)
        if collision is None and checker.in_collision(q):
            contacts = checker.contacts(q)
            pair = f"{contacts[0].a} - {contacts[0].b}" if contacts else "collision"
            collision = f"{pair} at dense state {k} of {len(dense)}"
        if failed is None and (collision is not None or margins.max(initial=-np.inf) > VALIDATION_TOLERANCE):
            failed = x
    checks = [
        ConstraintCheck(id=c.id, max_violation=float(w), satisfied=bool(w <= VALIDATION_TOLERANCE))
        for c, w in zip(evaluator.constraints, worst)
    ]
    sample = dense[np.unique(np.linspace(0, len(dense) - 1, min(len(dense), DISTANCE_SAMPLES)).astype(int))]
    distances = checker.human_distances(np.array([evaluator.full(x) for x in sample])) if human_distance else []
    best = min(distances, key=lambda d: d[0]) if distances else (float("inf"), "", "")
    violated = [c.id for c in checks if not c.satisfied]
    problems = ([f"constraint {', '.join(violated)} violated"] if violated else []) + ([collision] if collision else [])
    return PathValidation(
        valid=not problems,
        states_checked=len(dense),
        constraints=checks,
        collision=collision,
        min_human_distance=None if best[0] == float("inf") else best[0],
        closest_pair=None if best[0] == float("inf") else (best[1], best[2]),
        message="; ".join(problems),
        failed_state=None if failed is None else failed.tolist(),
    )


def test_densify_is_the_segments_one_at_a_time(rng):
    """Bit for bit, whatever the segment lengths (repeated rows, one row, long and short)."""
    for _ in range(300):
        rows = rng.normal(0.0, rng.choice([1e-3, 0.05, 1.0]), (rng.integers(1, 7), rng.integers(1, 8)))
        if len(rows) > 2:
            rows[2] = rows[1]
        step = float(rng.choice([0.003, 0.01, 0.05]))
        assert np.array_equal(densify(list(rows), step), densified(rows, step))
        kept = rows.copy()
        assert np.array_equal(densify(rows, step), densified(rows, step))  # an array, as is
        assert np.array_equal(rows, kept)
    assert densify([np.zeros(3)], 0.01).shape == (1, 3)


@pytest.mark.parametrize("kernels", [False, True])
@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf")])
def test_a_path_not_finite_is_refused_in_one_line(kernels, bad):
    """A NaN or an infinity cannot be split into steps (its segment's count is no number): one
    line, with the kernels on or off, rather than arrays of any size."""
    rows = np.zeros((4, 3))
    rows[2, 1] = bad
    before = kernels_on()
    use_kernels(kernels)
    try:
        with pytest.raises(
            HriplanError, match=r"^a path to validate holds a number that is not finite \(NaN or infinite\)$"
        ):
            densify(rows, 0.01)
    finally:
        use_kernels(before)


@pytest.fixture(scope="module")
def problem(madar):
    """The right arm under an orientation and a box constraint, beside a table and a person."""
    joints = madar.group_joints("right_arm")
    q0 = madar.configuration(CLEAR)
    tool = madar.frame_pose("right_tool", q0)
    frame = Pose(xyz=tuple(tool[:3, 3]))
    upright = Pose(rpy=tuple(pin.rpy.matrixToRpy(tool[:3, :3])))
    specs = [
        OrientationConstraint(
            id="upright", joints=joints, target_link="right_tool", target=upright, free_axes=["z"], tolerance=0.3
        ),
        BoxConstraint(
            id="reach", joints=joints, target_link="right_tool", frame=FrameRef(offset=frame), size=(0.6, 0.6, 0.6)
        ),
    ]
    scene = Scene(
        obstacles=[table(position=(0.6, 0.6), size=(0.5, 0.6, 0.04), top=0.72)],
        humans=[HumanSpec(name="bob", position=(0.1, 1.3), yaw=-np.pi / 2, margin=0.05)],
    )
    checker = CollisionChecker(madar, scene)
    constrained = ConstraintEvaluator(madar, bind(specs, madar, checker), "right_arm", q0)
    free = ConstraintEvaluator(madar, [], "right_arm", q0)
    return (constrained, free), checker, q0[madar.group_indices("right_arm")]


def _same(found: PathValidation, expected: PathValidation) -> bool:
    """Field for field, the largest margins and the closest person's distance to 1e-12: with the
    kernels on the margins come from one compiled batch, whose kinematics round apart from
    pinocchio's by ~1e-16, and the closest approach from compiled distances (exact, as coal's
    capsule pairs, rounded otherwise)."""
    worst = [(a.max_violation, b.max_violation) for a, b in zip(found.constraints, expected.constraints)]
    if any(abs(a - b) > 1e-12 for a, b in worst):
        return False
    distances = (found.min_human_distance, expected.min_human_distance)
    if (distances[0] is None) != (distances[1] is None) or (
        None not in distances and abs(distances[0] - distances[1]) > 1e-12
    ):
        return False
    checks = [
        c.model_copy(update={"max_violation": e.max_violation}) for c, e in zip(found.constraints, expected.constraints)
    ]
    return found.model_copy(update={"constraints": checks, "min_human_distance": distances[1]}) == expected


def test_validate_path_is_the_state_by_state_check(problem, rng, either_route):
    evaluators, checker, x0 = problem
    kinds = {"valid": 0, "violated": 0, "collides": 0, "both": 0}
    for n in range(40):
        waypoints = x0 + rng.normal(0.0, 0.05 + 0.02 * n, (rng.integers(1, 5), x0.size))
        waypoints[0] = x0
        for evaluator, human_distance in zip(evaluators * 2, (False, False, True, True)):
            found = validate_path(evaluator, checker, list(waypoints), 0.01, human_distance)
            assert _same(found, _one_state_at_a_time(evaluator, checker, list(waypoints), 0.01, human_distance))
            violated, collides = any(not c.satisfied for c in found.constraints), found.collision is not None
            kinds[{(0, 0): "valid", (1, 0): "violated", (0, 1): "collides", (1, 1): "both"}[violated, collides]] += 1
    assert all(kinds.values()), kinds  # every outcome was compared


def test_the_report_samples_are_spread_evenly_each_once():
    """The closest person is measured at up to DISTANCE_SAMPLES states spread from the first to
    the last, each once: np.unique's answer (which imports numpy.ma), for every path length."""
    from hriplan.planner.validate import _spread

    for count in [*range(1, 400), 1000, 4515]:
        for most in (1, 2, 3, 150):
            expected = np.unique(np.linspace(0, count - 1, min(count, most)).astype(int))
            assert np.array_equal(_spread(count, most), expected)
    assert _spread(4515, 150)[[0, -1]].tolist() == [0, 4514] and len(_spread(4515, 150)) == 150
