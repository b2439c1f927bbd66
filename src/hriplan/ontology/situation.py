"""A situation as data: the task, the robot and its arms, the objects and the people around.

This is what the knowledge base reasons about. Class names (`kind`) are the ontology's, so a
user extending the ontology can use new kinds without touching Python; `facts` adds any other
assertion in ontology terms, for rules a user adds.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    StringConstraints,
    ValidationError,
    model_validator,
)

from hriplan import HriplanError
from hriplan.files import Finite, validation_message
from hriplan.robots.descriptions.registry import DEFAULT_ROBOT
from hriplan.robots.human import HAND, HumanSpec, Side, hand_they_reach_out
from hriplan.robots.spatial import Pose

EXAMPLES_DIR = Path(__file__).with_name("situations")

# Names become IRI local names and planner frame prefixes (PERSON/head), hence the pattern.
Name = Annotated[str, StringConstraints(pattern=r"^[A-Za-z_][A-Za-z0-9_]*$")]
Positive = Annotated[float, Field(gt=0.0, allow_inf_nan=False)]
SignedAxis = Literal["+x", "-x", "+y", "-y", "+z", "-z"]
FillLevel = Literal["Full", "Partial", "Empty"]
Role = Literal["Receiver", "Giver", "Supervisor", "Collaborator", "Bystander"]
Value = bool | int | float | str


class SituationObject(BaseModel):
    """A physical object. Its z axis is its own axis: up out of a container's opening, from a
    tool's handle to its working end, along a peg or a hole (see the ontology's comments)."""

    model_config = ConfigDict(extra="forbid")

    name: Name
    kind: Name  # an ontology class under PhysicalObject: Can, Cup, Glass, Knife, Peg, Hole, Table...
    fill_level: FillLevel | None = None
    open: bool | None = None
    sharp: bool | None = None
    fragile: bool | None = None
    hot: bool | None = None
    pose: Pose = Pose()
    size: tuple[Positive, Positive, Positive] | None = None  # bounding box (m), for the planning scene
    # Tool-frame axis along the object's z axis while held; None: the arm's usual grasp (ontology).
    grasp_axis: SignedAxis | None = None
    # World positions (m) the object passes through while carried, e.g. from a planned motion:
    # relations such as "near a person" then hold over the whole path (closest approach).
    path: list[tuple[Finite, Finite, Finite]] = Field(default_factory=list)


class SituationHuman(HumanSpec):
    """A person: where and how they stand (HumanSpec; `name` is their id), their role and the hand
    they give or receive with."""

    name: Name
    role: Role
    hand: Side = Field(default="right", description=HAND)

    _hand_they_reach_out = hand_they_reach_out


class SituationTask(BaseModel):
    model_config = ConfigDict(extra="forbid")

    name: Name = "task"
    kind: Name  # an ontology class under Task: RobotToHumanHandover, Transport, Insertion...
    arms: list[str] = Field(min_length=1)  # MADAR: right, left; UR5: arm
    carries: dict[str, str] = Field(default_factory=dict)  # object name -> arm holding it
    human: str | None = None  # the person handed to or taken from
    target: str | None = None  # the object acted on without carrying it (the hole of an insertion)
    # Per carried object, the object it goes into (each peg its own hole); default: `target`.
    targets: dict[str, str] = Field(default_factory=dict)

    def goal_targets(self) -> dict[str, str]:
        """Where each carried object goes: `targets`, else the task's one `target` for all of them."""
        if self.targets or self.target is None:
            return dict(self.targets)
        return {obj: self.target for obj in self.carries}


class Situation(BaseModel):
    """Everything the rules may look at; poses are in the world frame (z up)."""

    model_config = ConfigDict(extra="forbid")

    robot: str = DEFAULT_ROBOT
    robot_base: Pose = Pose()
    task: SituationTask
    objects: list[SituationObject] = Field(default_factory=list)
    humans: list[SituationHuman] = Field(default_factory=list)
    # World pose of each arm's tool frame when the task starts (a held object's centre is there);
    # constraints that guide an approach start from it (the approach cone aims at it).
    tool_poses: dict[str, Pose] = Field(default_factory=dict)
    # Extra assertions (subject, ontology property, object or value), e.g. ["cup1", "isHot", true].
    facts: list[tuple[Name, Name, Value]] = Field(default_factory=list)

    @model_validator(mode="after")
    def _references(self) -> Situation:
        names = [self.task.name] + [o.name for o in self.objects] + [h.name for h in self.humans]
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise ValueError(f"names must be unique; repeated: {', '.join(repeated)}")
        task, objects, humans = self.task, self.object_names(), {h.name for h in self.humans}
        if len(set(task.arms)) != len(task.arms):
            raise ValueError(f"task arms repeat: {task.arms}")
        for obj, arm in task.carries.items():
            if obj not in objects:
                raise ValueError(f"task carries {obj!r}, which is not among the objects")
            if arm not in task.arms:
                raise ValueError(
                    f"{obj!r} is carried by arm {arm!r}, which the task does not use ({', '.join(task.arms)})"
                )
        if task.human is not None and task.human not in humans:
            raise ValueError(f"task human {task.human!r} is not among the humans")
        if task.target is not None and task.target not in objects:
            raise ValueError(f"task target {task.target!r} is not among the objects")
        for obj, target in task.targets.items():
            if obj not in task.carries or target not in objects:
                raise ValueError(
                    f"task targets: {obj!r} -> {target!r} needs a carried object and an object of the situation"
                )
        return self

    def object_names(self) -> set[str]:
        return {o.name for o in self.objects}

    def object(self, name: str) -> SituationObject:
        return next(o for o in self.objects if o.name == name)

    def human(self, name: str) -> SituationHuman:
        return next(h for h in self.humans if h.name == name)


def load_situation(path: str | Path) -> Situation:
    """Read a situation file (JSON); errors name the file and the field."""
    path = Path(path)
    try:
        return Situation.model_validate_json(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise HriplanError(f"cannot read situation {path}: {exc.strerror or exc}") from None
    except ValidationError as exc:
        raise HriplanError(f"{path}: {validation_message(exc)}") from None
