"""Failure messages say what is wrong and what would help."""

from collections import Counter

from hriplan.planner.motion import ToolTarget
from hriplan.planner.options import PlanOptions
from hriplan.planner.session import PlanningSession
from hriplan.robots.descriptions.registry import posture
from hriplan.robots.ik import rejection_message
from hriplan.robots.scene import Scene, table
from hriplan.robots.spatial import Pose


def test_an_ik_goal_in_a_table_names_what_collides_and_what_would_help():
    session = PlanningSession("madar", Scene(obstacles=[table("table", (0.5, 0.5, 0.04), 0.72, (0.45, 0.85))]))
    # The grasp centre 1 cm inside the table top: the fingers go through it whatever the spin.
    goal = ToolTarget(arm="right", pose=Pose(xyz=(0.45, 0.75, 0.71), rpy=(3.1416, 0.0, 0.0)), free_axes=["z"])
    result = session.plan(posture("madar", "ready"), goal, PlanOptions(time_limit=1.0, seed=1), "right_arm")
    assert result.motion.status == "unreachable_goal"
    assert "collides: right_" in result.message and " - table (" in result.message
    assert "would help: move the goal away from what collides" in result.message


def test_the_rejection_message_counts_reasons_and_hints_for_each_kind():
    message = rejection_message(10, Counter({"collides: right_palm - table": 7, "violates upright_cup": 3}))
    assert message.startswith(
        "all 10 solutions are rejected: collides: right_palm - table (7 of 10), violates upright_cup (3 of 10)"
    )
    assert "higher above a table" in message and "orientation the violated constraint allows" in message
