"""A task in a session's perceived world (tasks/world.py): what the session sees overrides or adds
to the file, a held object's grasp is read back from its pose in the hand, a task is continued
from a named step; bad input is one clear error."""

from pathlib import Path

import numpy as np
import pytest

from hriplan import HriplanError
from hriplan.robots.human import HumanSpec
from hriplan.robots.scene import AttachedObject, Box, Cylinder, Obstacle, Scene, table
from hriplan.robots.spatial import Pose, Transform
from hriplan.tasks.grasps import Grasp, grasp_holding
from hriplan.tasks.load import load_task
from hriplan.tasks.world import PERCEIVED_KIND, continued, in_world

EXAMPLES = Path(__file__).parents[2] / "examples"
TASK = load_task(EXAMPLES / "handover_full_can.yaml")
CRATE = Obstacle(name="crate", shape=Box(size=(0.1, 0.1, 0.16)), pose=Pose(xyz=(0.25, 0.85, 0.8)), touched_by="right")


@pytest.mark.parametrize("axis", ["+x", "-x", "+y", "-y", "+z", "-z"])
@pytest.mark.parametrize("offset", [0.0, 0.25, -0.3])
def test_a_held_pose_gives_back_the_grasp_that_made_it(axis, offset):
    can = Cylinder(radius=0.033, height=0.12)
    made = Grasp("SideGrasp", axis, offset).object_in_tool(0.12)
    # The pose written by hand: the object's z along the signed tool axis, the grasp point at the tool.
    z = np.zeros(3)
    z["xyz".index(axis[1])] = -1.0 if axis[0] == "-" else 1.0
    assert np.allclose(made.rotation[:, 2], z) and np.allclose(made.translation, -offset * 0.12 * z)
    back = grasp_holding(made, can)
    assert (back.axis, back.offset) == (axis, pytest.approx(offset, abs=1e-12))
    # A hold turned 0.2 rad off that axis is still read as that grasp.
    tilt = Transform(Pose(rpy=(0.2, 0.0, 0.0)).rotation(), np.zeros(3))
    assert grasp_holding(tilt * made, can).axis == axis


def test_the_session_world_overrides_the_files_people_and_objects_and_adds_the_rest():
    alice = HumanSpec(name="alice", position=(0.1, 1.5), yaw=-1.5708, reach={"right": (0.05, 1.05, 1.05)})
    zoe = HumanSpec(name="zoe", position=(1.6, 0.2), yaw=3.14)
    lid = AttachedObject(name="lid", shape=Box(size=(0.1, 0.1, 0.01)), arm="left", grasp=Pose(xyz=(0.0, 0.0, 0.02)))
    on_table = Obstacle(name="coke_can", shape=Cylinder(radius=0.03, height=0.12), pose=Pose(xyz=(0.4, 0.8, 0.78)))
    moved_table = table("table", (0.5, 0.5, 0.04), 0.7, (0.5, 0.9))
    world = Scene(obstacles=[CRATE, on_table, moved_table], attached=[lid], humans=[alice, zoe])
    placed, grasps = in_world(TASK, world, {"zoe": "Supervisor"})
    people = {h.name: h for h in placed.humans}
    assert people["alice"].position == (0.1, 1.5) and people["alice"].role == "Giver"  # the file's role stays
    assert people["zoe"].role == "Supervisor" and people["zoe"].position == (1.6, 0.2)
    can = next(o for o in placed.objects if o.name == "coke_can")
    assert can.in_hand_of is None and can.pose.xyz == (0.4, 0.8, 0.78) and can.shape.radius == 0.03
    assert can.kind == "Can" and can.fill_level == "Full"  # what the file says of it stays
    held = next(o for o in placed.objects if o.name == "lid")
    assert (held.kind, held.holding_arm) == (PERCEIVED_KIND, "left")
    assert grasps == {"lid": Grasp("perceived", "+z", pytest.approx(-0.02 / 0.01))}
    obstacles = {o.name: o for o in placed.scene.obstacles}
    assert obstacles["crate"].touched_by is None and obstacles["crate"].pose == CRATE.pose
    assert placed.scene.tables == [] and obstacles["table"].pose.xyz == pytest.approx((0.5, 0.9, 0.68))
    # Nobody unnamed is a bystander by default; the file alone is unchanged.
    assert {h.name: h.role for h in in_world(TASK, Scene(humans=[zoe]))[0].humans}["zoe"] == "Bystander"
    assert in_world(TASK, Scene()) == (TASK, {})


def test_names_that_clash_and_invalid_people_are_one_clear_error():
    with pytest.raises(HriplanError, match="^the session's object 'alice' is a person in task 'handover_full_can'$"):
        in_world(TASK, Scene(obstacles=[CRATE.model_copy(update={"name": "alice"})]))
    with pytest.raises(HriplanError, match="^the session's person 'coke_can' is an object in task"):
        in_world(TASK, Scene(humans=[HumanSpec(name="coke_can")]))
    with pytest.raises(HriplanError, match="^task 'handover_full_can' in the session's world: humans.1.name"):
        in_world(TASK, Scene(humans=[HumanSpec(name="zoe 2")]))


def test_a_continued_task_keeps_its_later_steps_by_name_and_starts_where_told():
    start = {"right_elbow_joint": -0.3, "left_elbow_joint": 1.2}
    rest = continued(TASK, "place_can", start)
    assert [s.name for s in rest.steps] == ["place_can"] and rest.steps[0].goal == TASK.steps[1].goal
    assert rest.start.posture == TASK.start.posture and rest.start.joints == start
    unnamed = TASK.model_copy(update={"steps": [s.model_copy(update={"name": None}) for s in TASK.steps]})
    assert [s.name for s in continued(unnamed, "step2", {}).steps] == ["step2"]  # named by their place
    with pytest.raises(
        HriplanError, match="^task 'handover_full_can' has no step 'place'; steps: take_can, place_can$"
    ):
        continued(TASK, "place", start)
