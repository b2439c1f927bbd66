"""Semantic goals to tool poses: grasp poses per object, then IK in the motion planner.

Every semantic goal says where an object should be at the end of the step; the tool pose
follows from how the arm holds objects (the object's z axis along the arm's object axis, its
centre at the tool frame) and the spin about that axis is left free for IK to choose.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from hriplan import HriplanError
from hriplan.planner.motion import JointTarget, Target, ToolTarget
from hriplan.robots.bounding import frame_with_z
from hriplan.robots.descriptions.registry import posture
from hriplan.robots.spatial import Pose, Transform
from hriplan.tasks.grasps import object_length
from hriplan.tasks.model import Goal as TaskGoal
from hriplan.tasks.model import (
    GraspGoal,
    HandOverGoal,
    InsertGoal,
    JointsGoal,
    PlaceGoal,
    PostureGoal,
    TakeGoal,
    ToolPoseGoal,
)
from hriplan.tasks.task_state import TaskState, handover_point

# The planned motion stops short of contact; the last centimetres (setting an object down, pushing
# a peg in) are a guarded move for the controller. The finger capsules are conservative, so a
# placed object is released this far above where it will stand.
INSERTION_CLEARANCE = 0.02
PLACE_CLEARANCE = 0.04
# A pick ends with the object lifted straight up as far as a place releases it above its place.
LIFT = PLACE_CLEARANCE
TASK_KINDS = {
    HandOverGoal: "RobotToHumanHandover",
    TakeGoal: "HumanToRobotHandover",
    GraspGoal: "Pick",
    PlaceGoal: "Place",
    InsertGoal: "Insertion",
}


@dataclass(frozen=True)
class ResolvedGoal:
    goal: Target
    moved_object: str | None  # what the arm carries or takes in this step
    object_pose: Pose | None = None  # where that object is at the end of the step


def task_kind(goal: TaskGoal) -> str:
    """The ontology task class a goal stands for (joint and tool goals: a transport)."""
    return TASK_KINDS.get(type(goal), "Transport")


def _half_length(state: TaskState, name: str) -> float:
    length = object_length(state.object(name).shape)
    if length <= 0.0:
        raise HriplanError(f"object {name!r} needs a shape to be inserted (its length sets where the peg stops)")
    return length / 2.0


def _to_object(arm: str, name: str, object_pose: Transform, state: TaskState) -> ResolvedGoal:
    """The tool goal that brings the held (or grasped) object `name` to `object_pose`, by its
    grasp (state.grasps), the spin about the grasp axis free."""
    tool = object_pose * state.in_tool(name).inverse()
    goal = ToolTarget(arm=arm, pose=Pose.from_se3(tool), free_axes=[state.grasps[name].axis[1]])
    return ResolvedGoal(goal, name, Pose.from_se3(object_pose))


def resolve_goal(
    goal: TaskGoal,
    arm: str,
    state: TaskState,
    held_axis: np.ndarray | None = None,
    arm_joints: Sequence[str] = (),
) -> ResolvedGoal:
    """The motion goal of a step's goal for `arm`, and what it is about.

    `held_axis`: the world direction the held object's axis should have at the goal (kept from
    now, or turned onto an orientation constraint: scissors pointed away from the receiver),
    else it arrives upright. `arm_joints`: the arm's joints, which a posture goal sets (those
    its posture does not list to 0)."""
    if isinstance(goal, JointsGoal):
        return ResolvedGoal(JointTarget(values=goal.joints), None)
    if isinstance(goal, PostureGoal):
        values = posture(state.task.robot, goal.posture)
        return ResolvedGoal(JointTarget(values={j: values.get(j, 0.0) for j in arm_joints}), None)
    if isinstance(goal, ToolPoseGoal):
        return ResolvedGoal(ToolTarget(arm=arm, pose=goal.tool_pose, free_axes=goal.free_axes), None)
    if isinstance(goal, GraspGoal):
        return _to_object(arm, goal.grasp, state.pose(goal.grasp).se3(), state)
    if isinstance(goal, TakeGoal):
        if state.held_by_person.get(goal.take) != goal.from_:
            raise HriplanError(f"{goal.from_!r} does not hold {goal.take!r} at this step")
        return _to_object(arm, goal.take, state.pose(goal.take).se3(), state)
    if isinstance(goal, HandOverGoal):
        _require_held(state, goal.hand_over, arm)
        rotation = np.eye(3) if held_axis is None else frame_with_z(held_axis)
        target = handover_point(state.person(goal.to), state.object(goal.hand_over).shape, rotation)
        return _to_object(arm, goal.hand_over, target, state)
    if isinstance(goal, PlaceGoal):
        _require_held(state, goal.place, arm)
        release = Transform(np.eye(3), np.array([0.0, 0.0, PLACE_CLEARANCE])) * goal.at.se3()
        return ResolvedGoal(_to_object(arm, goal.place, release, state).goal, goal.place, goal.at)
    _require_held(state, goal.insert, arm)
    hole = state.pose(goal.into).se3()
    lift = _half_length(state, goal.insert) + _half_length(state, goal.into) + INSERTION_CLEARANCE
    return _to_object(arm, goal.insert, hole * Transform(np.eye(3), np.array([0.0, 0.0, lift])), state)


def _require_held(state: TaskState, name: str, arm: str) -> None:
    if state.held_by_arm.get(name) != arm:
        raise HriplanError(f"the {arm} arm does not hold {name!r} at this step")


def after_step(goal: TaskGoal, resolved: ResolvedGoal, arm: str, state: TaskState) -> None:
    """Who holds what once the step's goal is reached."""
    obj = resolved.moved_object
    if isinstance(goal, (GraspGoal, TakeGoal)):
        state.held_by_person.pop(obj, None)
        state.held_by_arm[obj] = arm
    elif isinstance(goal, HandOverGoal):
        state.held_by_arm.pop(obj)
        state.held_by_person[obj] = goal.to
    elif isinstance(goal, (PlaceGoal, InsertGoal)):
        state.held_by_arm.pop(obj)
        state.poses[obj] = resolved.object_pose
