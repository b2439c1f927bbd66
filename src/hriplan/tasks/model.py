"""Task files: what a user asks for, validated by pydantic (YAML or JSON; `hriplan schema`).

A task names the robot, the objects (with their ontology class and properties), the people
(with their roles and where they stand), the rest of the scene, where the robot starts and one
or more steps, each with a goal: joint values, a tool pose, or a semantic goal (grasp, hand
over, take, place, insert) that resolves through grasp poses and IK. Each step is planned with
the constraints the rules derive for it.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from hriplan.ontology.situation import FillLevel, Name, Role
from hriplan.planner.options import PLANNERS, Space
from hriplan.planner.spec import Axis
from hriplan.robots.human import HumanSpec, Side
from hriplan.robots.scene import Obstacle, Shape
from hriplan.robots.spatial import Pose

Positive = Annotated[float, Field(gt=0.0, allow_inf_nan=False)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class TaskObject(_Strict):
    """An object; its z axis is its own axis (up out of a container, along a peg or a hole)."""

    name: Name
    kind: Name = Field(description="Ontology class: Can, Cup, Glass, Bottle, Bowl, Knife, Scissors, Peg, Hole, ...")
    fill_level: FillLevel | None = None
    open: bool | None = None
    sharp: bool | None = None
    fragile: bool | None = None
    hot: bool | None = None
    pose: Pose = Field(default_factory=Pose, description="World pose (ignored while a person or the robot holds it).")
    shape: Shape | None = Field(default=None, description="Collision shape (centred); none: the object is not an obstacle.")
    held_by: str | None = Field(default=None, description="A robot arm holding it at the start.")
    in_hand_of: Name | None = Field(default=None, description="A person holding it at the start (in their active hand).")

    @model_validator(mode="after")
    def _one_holder(self) -> "TaskObject":
        if self.held_by and self.in_hand_of:
            raise ValueError(f"object {self.name!r} cannot be held by the robot and by {self.in_hand_of!r} at once")
        return self


class TaskHuman(HumanSpec):
    """A person (HumanSpec: posture, position, yaw, height, reach, margin) and their role."""

    name: Name
    role: Role
    hand: Side = "right"


class Table(_Strict):
    name: Name = "table"
    position: tuple[float, float]
    size: tuple[Positive, Positive, Positive] = (0.8, 1.2, 0.04)
    top: Positive = 0.75


class TaskScene(_Strict):
    tables: list[Table] = Field(default_factory=list)
    obstacles: list[Obstacle] = Field(default_factory=list)


class Start(_Strict):
    """Named posture, then joint values on top of it."""

    posture: Literal["home", "ready"] = "ready"
    joints: dict[str, float] = Field(default_factory=dict)


class JointsGoal(_Strict):
    joints: dict[str, float]


class ToolPoseGoal(_Strict):
    tool_pose: Pose
    free_axes: list[Axis] = Field(default_factory=list)


class GraspGoal(_Strict):
    grasp: Name


class HandOverGoal(_Strict):
    hand_over: Name
    to: Name


class TakeGoal(_Strict):
    model_config = ConfigDict(extra="forbid", populate_by_name=True)
    take: Name
    from_: Name = Field(alias="from")


class PlaceGoal(_Strict):
    place: Name
    at: Pose


class InsertGoal(_Strict):
    insert: Name
    into: Name


Goal = JointsGoal | ToolPoseGoal | GraspGoal | HandOverGoal | TakeGoal | PlaceGoal | InsertGoal


class Step(_Strict):
    name: Name | None = None
    arm: str | None = Field(default=None, description="The arm that moves (default: the one holding the object, else the first).")
    goal: Goal | None = None
    goals: list[Goal] = Field(default_factory=list, description="One goal per arm, planned together (both arms).")
    arms: list[str] = Field(default_factory=list, description="With `goals`: the arm of each goal.")
    kind: Name | None = Field(default=None, description="Ontology task class; default from the goal (hand over -> RobotToHumanHandover...).")

    @model_validator(mode="after")
    def _goal_or_goals(self) -> "Step":
        if (self.goal is None) == (not self.goals):
            raise ValueError("a step has either `goal` or `goals`")
        if self.goals and len(self.arms) != len(self.goals):
            raise ValueError("`goals` needs `arms` with one arm per goal")
        return self


class Planning(_Strict):
    planner: Literal[PLANNERS] = "CBiRRT"  # type: ignore[valid-type]
    space: Space = "projected"  # CBiRRT's space (PlanOptions' defaults)
    time_limit: Positive = 10.0
    seed: int | None = None


class TaskFile(_Strict):
    name: Name = "task"
    description: str = ""
    robot: Literal["madar", "ur5"] = "madar"
    hands: dict[str, Literal["open", "power", "pinch"]] = Field(default_factory=dict)
    objects: list[TaskObject] = Field(default_factory=list)
    humans: list[TaskHuman] = Field(default_factory=list)
    scene: TaskScene = Field(default_factory=TaskScene)
    start: Start = Field(default_factory=Start)
    steps: list[Step] = Field(min_length=1)
    planning: Planning = Field(default_factory=Planning)
    rule_files: list[str] = Field(default_factory=list, description="Extra rule files (paths relative to the task file).")

    @model_validator(mode="after")
    def _references(self) -> "TaskFile":
        objects = {o.name for o in self.objects}
        humans = {h.name for h in self.humans}
        names = [o.name for o in self.objects] + [h.name for h in self.humans] + [t.name for t in self.scene.tables]
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise ValueError(f"names must be unique; repeated: {', '.join(repeated)}")
        for obj in self.objects:
            if obj.in_hand_of and obj.in_hand_of not in humans:
                raise ValueError(f"object {obj.name!r} is in the hand of {obj.in_hand_of!r}, who is not among the humans")
        for k, step in enumerate(self.steps):
            for goal in [step.goal, *step.goals]:
                for field in ("grasp", "hand_over", "take", "place", "insert", "into"):
                    value = getattr(goal, field, None)
                    if value is not None and value not in objects:
                        raise ValueError(f"steps.{k}: {field} {value!r} is not among the objects")
                for field in ("to", "from_"):
                    value = getattr(goal, field, None)
                    if value is not None and value not in humans:
                        raise ValueError(f"steps.{k}: {field.rstrip('_')} {value!r} is not among the humans")
        return self
