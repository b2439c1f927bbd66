"""The cone, against a membership written in the test: nothing above its height, nothing beyond
its radius, through the signed distance, the evaluator's margins and dense validation.

The validator shares the cone's signed distance with the planner, so a cone made unbounded above
its height passed every test that only asked the validator; these points lie above and beside it."""

import numpy as np
import pytest

from hriplan.planner.constraints import geometry as G
from hriplan.planner.constraints.binding import bind
from hriplan.planner.constraints.evaluator import ConstraintEvaluator
from hriplan.planner.constraints.spec import ConeConstraint, FrameRef
from hriplan.planner.validate import validate_path
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.scene import Scene
from hriplan.robots.spatial import Pose
from independent import inside

RADIUS, HEIGHT = 0.2, 0.4
SHAPE = ConeConstraint(id="cone", joints=["j"], target_link="right_tool", radius=RADIUS, height=HEIGHT)


def _points(rng, count: int) -> np.ndarray:
    """Points around the cone, half of them above its height, most beyond its radius somewhere,
    none within 1 mm of its boundary (where a sign is a matter of rounding)."""
    rho = rng.uniform(0.0, 2.5 * RADIUS, count)
    z = np.where(rng.random(count) < 0.5, rng.uniform(HEIGHT, 3.0 * HEIGHT, count), rng.uniform(-0.2, HEIGHT, count))
    angle = rng.uniform(0.0, 2 * np.pi, count)
    points = np.column_stack([rho * np.cos(angle), rho * np.sin(angle), z])
    margin = np.minimum.reduce([np.abs(z), np.abs(z - HEIGHT), np.abs(rho - RADIUS * np.clip(z, 0, None) / HEIGHT)])
    return points[margin > 1e-3]


def test_the_membership_written_here_says_nothing_lies_above_the_cone():
    above = np.array([[0.0, 0.0, HEIGHT + 0.1], [0.05, 0.0, 2 * HEIGHT], [0.3, 0.0, 2 * HEIGHT]])
    assert not inside(SHAPE, above).any() and inside(SHAPE, np.array([[0.05, 0.0, 0.3]])).all()


def test_the_cone_signed_distance_agrees_with_membership_above_and_beside_the_cone(rng):
    points = _points(rng, 2000)
    assert (points[:, 2] > HEIGHT).sum() > 500  # the region a bounded cone must exclude is sampled
    member = inside(SHAPE, points)
    assert member.any() and not member.all()
    signed = np.array([G.cone_sd(p, RADIUS, HEIGHT)[0] for p in points])
    assert ((signed < 0.0) == member).all(), points[(signed < 0.0) != member][:5]
    # on the axis above the top the nearest boundary is the top disk
    for d in (0.05, 0.3, 1.0):
        assert G.cone_sd(np.array([0.0, 0.0, HEIGHT + d]), RADIUS, HEIGHT)[0] == pytest.approx(d)


@pytest.mark.parametrize("region", ["inside", "outside"])
def test_the_evaluator_margin_and_dense_validation_agree_with_membership(madar, rng, region):
    """The tool placed at each test point of a cone's frame (the frame moved, not the arm): the
    margin is <= 0 and the validation satisfied exactly where membership says the region holds."""
    joints = madar.group_joints("right_arm")
    x = np.array([0.3, -1.2, 1.4, -0.5, 0.6, 0.2])
    q = madar.configuration(dict(zip(joints, x)))
    tool = madar.frame_pose("right_tool", q)[:3, 3]
    checker = CollisionChecker(madar, Scene())
    points = _points(rng, 60)
    for p, member in zip(points, inside(SHAPE, points)):
        rpy = tuple(rng.uniform(-np.pi, np.pi, 3))
        origin = tool - Pose(rpy=rpy).rotation() @ p
        spec = SHAPE.model_copy(
            update={"joints": joints, "region": region, "frame": FrameRef(offset=Pose(xyz=tuple(origin), rpy=rpy))}
        )
        evaluator = ConstraintEvaluator(madar, bind([spec], madar, checker), "right_arm", np.zeros(12))
        holds = bool(member) == (region == "inside")
        margin = evaluator.margins(evaluator.full(x))[0]
        assert (margin <= 0.0) == holds, (p, margin)
        check = validate_path(evaluator, checker, [x, x])
        assert check.constraints[0].satisfied == holds, (p, check.constraints[0])
