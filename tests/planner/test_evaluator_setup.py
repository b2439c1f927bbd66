"""What a constraint evaluator makes when it is made (a plan makes two): its pinocchio workspace
and its terms' frames as rows of floats only when the Python route asks, the workspace its own;
its joints' slots as slices where they follow one another."""

import numpy as np
import pytest

from hriplan.planner.constraints.binding import bind
from hriplan.planner.constraints.evaluator import ConstraintEvaluator, _slot
from hriplan.planner.constraints.spec import BoxConstraint, FrameRef, OrientationConstraint
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.scene import Scene
from hriplan.robots.spatial import Pose


@pytest.fixture(scope="module")
def bound(madar):
    joints = madar.group_joints("right_arm")
    specs = [
        OrientationConstraint(id="up", joints=joints, target_link="right_tool", free_axes=["z"], tolerance=0.2),
        BoxConstraint(
            id="box",
            joints=joints,
            target_link="right_tool",
            size=(2, 2, 2),
            frame=FrameRef(offset=Pose(xyz=(0, 0, 1))),
        ),
    ]
    return bind(specs, madar, CollisionChecker(madar, Scene()))


def test_the_workspace_is_made_only_for_the_python_route_and_is_each_evaluators_own(madar, bound, compiled_route):
    q = madar.configuration({})
    a, b = (ConstraintEvaluator(madar, bound, "right_arm", q) for _ in range(2))
    x = madar.group_values(q, "right_arm") + 0.1
    compiled = a.margins(a.full(x)), a.gradients(x)
    assert "data" not in vars(a)  # the compiled route needs none, nor the terms' frames as rows of floats
    assert not any(name in vars(t) for t in a.terms for name in ("frame", "frame_t", "origin_xyz"))
    equality = a.equality(x)  # the Python route's rows: made now
    assert "data" in vars(a) and a.data is not b.data and a.data is not madar.data
    tool = madar.model.getFrameId("right_tool")
    pose = madar.frame_pose("right_tool", a.full(x))
    assert np.array_equal(a.data.oMf[tool].homogeneous, pose)  # at x, where the rows were asked
    assert np.isfinite(equality).all() and compiled[0].shape == (2,) and compiled[1][1].shape == (2, 6)


@pytest.mark.parametrize(
    "indices, want",
    [([6, 7, 8, 9, 10, 11], slice(6, 12)), ([0], slice(0, 1)), ([0, 2, 3], None), ([3, 2, 1], None), ([], None)],
)
def test_consecutive_indices_are_a_slice_and_any_others_stay_as_they_are(indices, want):
    given = np.array(indices, dtype=np.int64)
    got = _slot(given)
    assert got == want if want is not None else got is given
    q = np.arange(20.0)
    assert np.array_equal(q[got], q[given])
