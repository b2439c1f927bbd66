"""Constraint specifications: JSON round trip, configuration errors named clearly."""

from pathlib import Path

import pytest

from hriplan import HriplanError
from hriplan.planner.constraints.binding import bind, check_groups
from hriplan.planner.constraints.spec import (
    BoxConstraint,
    ConeConstraint,
    ConstraintSet,
    FrameRef,
    OrientationConstraint,
)
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.descriptions.registry import load_robot_file
from hriplan.robots.model import load_robot
from hriplan.robots.scene import Scene
from hriplan.robots.spatial import Pose

RIGHT = [f"right_{j}_joint" for j in ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3")]


def test_constraint_set_round_trips_through_json():
    original = ConstraintSet(
        constraints=[
            OrientationConstraint(
                id="up",
                joints=RIGHT,
                target_link="right_tool",
                free_axes=["y"],
                target=Pose(quat_xyzw=(0, 0, 0, 1)),
                tolerance_gradient=0.2,
            ),
            ConeConstraint(
                id="cone",
                joints=RIGHT,
                target_link="right_tool",
                radius=0.2,
                height=0.4,
                frame=FrameRef(entity="bob/right_hand"),
            ),
            BoxConstraint(
                id="box",
                joints=RIGHT,
                target_link="right_tool",
                size=(1, 1, 1),
                region="outside",
                keep_out_all_links=True,
            ),
        ]
    )
    again = ConstraintSet.model_validate_json(original.model_dump_json())
    assert again == original
    assert again.constraints[1].frame.entity == "bob/right_hand" and again.constraints[0].type == "orientation"


@pytest.mark.parametrize(
    "data, message",
    [
        ({"type": "orientation", "free_axes": ["x", "y", "z"]}, "three free axes"),
        ({"type": "box", "size": [1, 1, 1], "keep_out_all_links": True}, "needs region 'outside'"),
        ({"type": "sphere", "radius": -1}, "greater than 0"),
        ({"type": "torus"}, "does not match any of the expected tags"),
    ],
)
def test_bad_specifications_are_rejected(data, message):
    with pytest.raises(ValueError, match=message):
        ConstraintSet.model_validate(
            {"constraints": [{"id": "c", "joints": RIGHT, "target_link": "right_tool", **data}]}
        )


def test_overlapping_joint_sets_name_both_constraints_and_the_shared_joints():
    a = OrientationConstraint(id="a", joints=RIGHT, target_link="right_tool")
    b = BoxConstraint(id="b", joints=RIGHT[3:], target_link="right_tool", size=(1, 1, 1))
    same = BoxConstraint(id="same", joints=RIGHT, target_link="right_tool", size=(1, 1, 1))
    assert len(check_groups([a, same])) == 1
    with pytest.raises(
        HriplanError, match=r"'a' and 'b' share joints right_wrist_1_joint, right_wrist_2_joint, right_wrist_3_joint"
    ):
        check_groups([a, b, same])


def test_binding_checks_chain_link_and_frame(madar):
    checker = CollisionChecker(madar, Scene())
    bind(
        [
            BoxConstraint(
                id="off",
                joints=RIGHT,
                target_link="right_tool",
                size=(1, 1, 1),
                enabled=False,
                frame=FrameRef(entity="nowhere"),
            )
        ],
        madar,
        checker,
    )  # disabled: skipped
    cases = [
        (dict(joints=[RIGHT[0], RIGHT[2]]), "contiguous chain"),
        (dict(joints=RIGHT[:3]), "does not move rigidly with the last joint"),
        (dict(joints=RIGHT, target_link="right_nose"), "no link 'right_nose'"),
        (dict(joints=RIGHT, frame=FrameRef(entity="fridge")), "'fridge' is not in the scene"),
        (dict(joints=RIGHT, frame=FrameRef(entity="alice/head")), "no person 'alice'"),
        (dict(joints=["right_knee"]), "no planning joint 'right_knee'"),
    ]
    for changes, message in cases:
        spec = BoxConstraint.model_validate({"id": "c", "target_link": "right_tool", "size": (1, 1, 1), **changes})
        with pytest.raises(HriplanError, match=message):
            bind([spec], madar, checker)


def test_a_chain_checked_before_is_this_robots_and_this_targets(madar, robot_registry):
    """Binding remembers a checked chain's link per robot and (joints, target link): another
    target, another robot with the same joints (its frames numbered apart) or another joint list
    is found and checked afresh, never given a link remembered for something else."""
    bare = load_robot(load_robot_file(Path(__file__).parents[2] / "examples" / "robots" / "madar_bare.yaml").name)

    def link(robot, target: str, joints: list[str] = RIGHT) -> int:
        spec = BoxConstraint(id="c", joints=joints, target_link=target, size=(1, 1, 1))
        return bind([spec], robot, CollisionChecker(robot, Scene()))[0].link

    for _ in range(2):  # made, then remembered
        assert link(madar, "right_tool") == madar.model.getFrameId("right_tool") == 127
        assert link(madar, "right_wrist_3_link") == madar.model.getFrameId("right_wrist_3_link") == 81
        assert link(bare, "right_wrist_3_link") == bare.model.getFrameId("right_wrist_3_link") == 35
        with pytest.raises(HriplanError, match="does not move rigidly with the last joint"):
            link(madar, "right_tool", RIGHT[:3])  # the target of a chain remembered, with fewer joints
        with pytest.raises(HriplanError, match="no link 'right_tool'"):
            link(bare, "right_tool")  # remembered for MADAR with its hands, which the bare one lacks
