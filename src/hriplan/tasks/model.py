"""Task files: what a user asks for, validated by pydantic (YAML or JSON; `hriplan schema`).

A task names the robot, the objects (with their ontology class and properties), the people
(with their roles and where they stand), the rest of the scene, where the robot starts and one
or more steps, each with a goal: joint values, a tool pose, or a semantic goal (grasp, hand
over, take, place, insert) that resolves through grasp poses and IK. Each step is planned with
the constraints the rules derive for it.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Discriminator, Field, Tag, ValidationError, field_validator, model_validator

from hriplan.files import Finite, validation_message
from hriplan.ontology.situation import FillLevel, Name, Role
from hriplan.planner.constraints.spec import Axis
from hriplan.planner.options import PLANNERS, Formulation, PlanOptions, Space
from hriplan.robots.descriptions.description import HAND_MODELS, hand_model
from hriplan.robots.descriptions.registry import (
    DEFAULT_ROBOT,
    DESCRIPTIONS,
    description_of,
    registered_robot_file,
    unknown_posture,
)
from hriplan.robots.human import HAND, HumanSpec, Side, hand_they_reach_out
from hriplan.robots.scene import Obstacle, Shape
from hriplan.robots.spatial import Pose
from hriplan.safety.separation import SafetyMargin

Positive = Annotated[float, Field(gt=0.0, allow_inf_nan=False)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class HeldBy(_Strict):
    """A robot arm holding an object at the start, and the grasp it holds it by (an ontology
    grasp its kind affords; none: the grasps the rules allow are tried, as for a first pick)."""

    arm: str
    grasp: Name | None = None


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
    shape: Shape | None = Field(
        default=None, description="Collision shape (centred); none: the object is not an obstacle."
    )
    held_by: HeldBy | None = Field(
        default=None,
        description="A robot arm holding it at the start: `right`, or `{arm: right, grasp: TopGrasp}`.",
        json_schema_extra=lambda schema: schema["anyOf"].insert(0, {"type": "string"}),
    )
    in_hand_of: Name | None = Field(
        default=None, description="A person holding it at the start (in their active hand)."
    )

    @field_validator("held_by", mode="before")
    @classmethod
    def _arm_alone(cls, value: object) -> object:
        """`held_by: right` is the arm alone, its grasp unstated."""
        return {"arm": value} if isinstance(value, str) else value

    @model_validator(mode="after")
    def _one_holder(self) -> TaskObject:
        if self.held_by and self.in_hand_of:
            raise ValueError(f"object {self.name!r} cannot be held by the robot and by {self.in_hand_of!r} at once")
        return self

    @property
    def holding_arm(self) -> str | None:
        """The arm holding it at the start, if one does."""
        return self.held_by.arm if self.held_by else None

    @property
    def stated_grasp(self) -> str | None:
        """The grasp the task says it is held by at the start, if it says."""
        return self.held_by.grasp if self.held_by else None


class TaskHuman(HumanSpec):
    """A person (HumanSpec: posture, position, yaw, height, reach, margin), their role and the
    hand they hand with."""

    model_config = ConfigDict(allow_inf_nan=False)

    name: Name
    role: Role
    hand: Side = Field(default="right", description=HAND)

    _hand_they_reach_out = hand_they_reach_out


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

    posture: str = Field(
        "ready",
        description="One of the robot's named postures (its description's).",
        json_schema_extra={"enum": list(dict.fromkeys(p for d in DESCRIPTIONS.values() for p in d.postures))},
    )
    joints: dict[str, Finite] = Field(default_factory=dict)


class JointsGoal(_Strict):
    joints: dict[str, Finite]


class PostureGoal(_Strict):
    """One of the robot's named postures, for the arms the step moves."""

    posture: str


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


GOAL_KINDS = {
    "joints": JointsGoal,
    "posture": PostureGoal,
    "tool_pose": ToolPoseGoal,
    "grasp": GraspGoal,
    "hand_over": HandOverGoal,
    "take": TakeGoal,
    "place": PlaceGoal,
    "insert": InsertGoal,
}


def _goal_kind(value: object) -> str | None:
    """Which goal a mapping means, by its key (`joints`, `grasp`, ...), so errors are that goal's."""
    if isinstance(value, BaseModel):
        return next(k for k, cls in GOAL_KINDS.items() if isinstance(value, cls))
    if not isinstance(value, dict):
        return None
    kinds = [k for k in GOAL_KINDS if k in value]
    return kinds[0] if len(kinds) == 1 else None


Goal = Annotated[
    Annotated[JointsGoal, Tag("joints")]
    | Annotated[PostureGoal, Tag("posture")]
    | Annotated[ToolPoseGoal, Tag("tool_pose")]
    | Annotated[GraspGoal, Tag("grasp")]
    | Annotated[HandOverGoal, Tag("hand_over")]
    | Annotated[TakeGoal, Tag("take")]
    | Annotated[PlaceGoal, Tag("place")]
    | Annotated[InsertGoal, Tag("insert")],
    Discriminator(
        _goal_kind,
        custom_error_type="goal_kind",
        custom_error_message=f"a goal is a mapping with exactly one of the keys {', '.join(GOAL_KINDS)}",
    ),
]


class Step(_Strict):
    name: Name | None = None
    arm: str | None = Field(
        default=None, description="The arm that moves (default: the one holding the object, else the first)."
    )
    goal: Goal | None = None
    goals: list[Goal] = Field(default_factory=list, description="One goal per arm, planned together (both arms).")
    arms: list[str] = Field(default_factory=list, description="With `goals`: the arm of each goal.")
    kind: Name | None = Field(
        default=None, description="Ontology task class; default from the goal (hand over -> RobotToHumanHandover...)."
    )

    @model_validator(mode="before")
    @classmethod
    def _goal_kinds(cls, data: object) -> object:
        """Name the keys of a goal that is none (or several) of the goal kinds."""
        if isinstance(data, dict):
            if isinstance(data.get("goal"), dict) and {"arms", "goals"} & data["goal"].keys():
                raise ValueError("`arms` and `goals` are keys of the step, beside its name, not of its `goal`")
            goals = [data.get("goal"), *(data.get("goals") or [])]
            for goal in [g for g in goals if isinstance(g, dict) and _goal_kind(g) is None]:
                raise ValueError(
                    f"goal {{{', '.join(map(str, goal))}}} needs exactly one of the keys {', '.join(GOAL_KINDS)}"
                )
        return data

    @model_validator(mode="after")
    def _goal_or_goals(self) -> Step:
        if (self.goal is None) == (not self.goals):
            raise ValueError("a step has either `goal` or `goals`")
        if self.goals and len(self.arms) != len(self.goals):
            raise ValueError("`goals` needs `arms` with one arm per goal")
        return self


def step_name(step: Step, index: int) -> str:
    """A step's name: given, else `step1`, `step2`, ... by position."""
    return step.name or f"step{index + 1}"


class Planning(_Strict):
    """How to plan the steps: the planner options a task may set (checked by PlanOptions' limits)."""

    planner: Literal[PLANNERS] = "CBiRRT"  # type: ignore[valid-type]
    space: Space = "projected"  # CBiRRT's space (PlanOptions' defaults)
    formulation: Formulation | None = Field(
        default=None, description="Default: the space's own (atlas, tangent_bundle: hybrid; else deadzone)."
    )
    time_limit: Positive = 10.0
    seed: int | None = None
    project_start: bool = Field(default=False, description="Move a start that violates a constraint onto it first.")
    safety_margin: SafetyMargin = Field(
        default_factory=SafetyMargin,
        description="Kept beyond ISO/TS 15066's limits near people: a padding (m) on every separation, a factor "
        "below every speed cap.",
    )

    def options(self) -> PlanOptions:
        """The planner's options (the safety margin goes with the separation policy)."""
        return PlanOptions(**self.model_dump(exclude_none=True, exclude={"safety_margin"}))

    @model_validator(mode="after")
    def _within_planner_limits(self) -> Planning:
        try:
            self.options()
        except ValidationError as exc:
            raise ValueError(validation_message(exc)) from None
        return self


class TaskFile(_Strict):
    name: Name = "task"
    description: str = ""
    robot: str = Field(
        DEFAULT_ROBOT,
        description="A robot's name, or a robot file (YAML, relative to the task file).",
        json_schema_extra={"examples": list(DESCRIPTIONS)},
    )
    robot_file: str = Field("", description="The robot file `robot` came from (absolute; set by the task loader).")
    hands: dict[str, str] = Field(
        default_factory=dict,
        json_schema_extra={
            "additionalProperties": {
                "enum": list(dict.fromkeys(p for m in HAND_MODELS.values() for p in m.postures)),
                "type": "string",
            }
        },
    )
    objects: list[TaskObject] = Field(default_factory=list)
    humans: list[TaskHuman] = Field(default_factory=list)
    scene: TaskScene = Field(default_factory=TaskScene)
    start: Start = Field(default_factory=Start)
    steps: list[Step] = Field(min_length=1)
    planning: Planning = Field(default_factory=Planning)
    rule_files: list[str] = Field(
        default_factory=list, description="Extra rule files (paths relative to the task file)."
    )

    @model_validator(mode="before")
    @classmethod
    def _robot_file_loaded(cls, data: object) -> object:
        return registered_robot_file(data)

    @field_validator("robot")
    @classmethod
    def _known_robot(cls, name: str) -> str:
        description_of(name)  # an unknown name is an error naming the known ones
        return name

    @model_validator(mode="after")
    def _references(self) -> TaskFile:
        description = description_of(self.robot)
        if self.start.posture not in description.postures:
            raise ValueError(f"start.posture: {unknown_posture(self.robot, self.start.posture)}")
        for side, posture in self.hands.items():
            if side not in description.hands:
                raise ValueError(
                    f"hands: robot {self.robot!r} has no hand {side!r}; hands: {', '.join(description.hands) or 'none'}"
                )
            known = hand_model(description.arms[side].hand).postures
            if posture not in known:
                raise ValueError(f"hands.{side}: unknown hand posture {posture!r}; choose one of {', '.join(known)}")
        objects = {o.name for o in self.objects}
        humans = {h.name for h in self.humans}
        names = [o.name for o in self.objects] + [h.name for h in self.humans] + [t.name for t in self.scene.tables]
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise ValueError(f"names must be unique; repeated: {', '.join(repeated)}")
        steps = [step_name(step, k) for k, step in enumerate(self.steps)]
        repeated = sorted({n for n in steps if steps.count(n) > 1})
        if repeated:
            raise ValueError(f"step names must be unique (each names its trajectory); repeated: {', '.join(repeated)}")
        for obj in self.objects:
            if obj.holding_arm is not None and obj.holding_arm not in description.arms:
                raise ValueError(
                    f"object {obj.name!r} is held by arm {obj.holding_arm!r}; robot {self.robot!r} has the arms "
                    f"{', '.join(description.arms)}"
                )
            if obj.in_hand_of and obj.in_hand_of not in humans:
                raise ValueError(
                    f"object {obj.name!r} is in the hand of {obj.in_hand_of!r}, who is not among the humans"
                )
        for k, step in enumerate(self.steps):
            for goal in [step.goal, *step.goals]:
                if isinstance(goal, PostureGoal) and goal.posture not in description.postures:
                    raise ValueError(f"steps.{k}: {unknown_posture(self.robot, goal.posture)}")
                for field in ("grasp", "hand_over", "take", "place", "insert", "into"):
                    value = getattr(goal, field, None)
                    if value is not None and value not in objects:
                        raise ValueError(f"steps.{k}: {field} {value!r} is not among the objects")
                for field in ("to", "from_"):
                    value = getattr(goal, field, None)
                    if value is not None and value not in humans:
                        raise ValueError(f"steps.{k}: {field.rstrip('_')} {value!r} is not among the humans")
        return self
