"""Request and response bodies: the project's file formats (task files, planning problems,
trajectory files, derivations) wrapped as little as possible, so /docs shows the formats."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from hriplan.formats.ros_trajectory import JointTrajectoryMessage
from hriplan.planner.constraints.spec import ConstraintSet
from hriplan.planner.motion import Target
from hriplan.planner.options import PlanOptions
from hriplan.planner.outcome import Status
from hriplan.planner.trajectory import TrajectoryFile
from hriplan.robots.descriptions.registry import DEFAULT_ROBOT
from hriplan.robots.scene import Scene
from hriplan.tasks.feasibility import TIME_LIMIT
from hriplan.tasks.model import Step, TaskFile
from hriplan.tasks.pipeline import StepOutcome

SessionId = str


class ErrorBody(BaseModel):
    """Every error: the one-line message the CLI would print, and the field at fault (422)."""

    error: str
    field: str | None = None


class PlanResponse(BaseModel):
    """One motion: the trajectory file if solved, else the status and the one-line reason."""

    solved: bool
    status: Status
    message: str = ""
    trajectory: TrajectoryFile | None = None
    leave: TrajectoryFile | None = Field(
        default=None,
        description="The leave phase to run first where the start lay in a keep-out volume or a person's "
        "minimum separation: the trajectory starts where it ends.",
    )
    joint_trajectory: JointTrajectoryMessage | None = Field(
        default=None, description="With ?ros=true: the trajectory as a ROS JointTrajectory."
    )


class TaskPlanResponse(BaseModel):
    """A task's outcome (every step's derivation, scene and trajectory) and whether all solved."""

    task: str
    steps: list[StepOutcome]
    solved: bool
    joint_trajectories: dict[str, JointTrajectoryMessage] = Field(
        default_factory=dict, description="With ?ros=true: per solved step."
    )


class StepExplanation(BaseModel):
    name: str
    kind: str
    arms: list[str]
    explanation: str  # what `hriplan explain` prints for the step


class ExplainResponse(BaseModel):
    task: str
    steps: list[StepExplanation]


class SessionCreate(BaseModel):
    """A running cell: the robot and hands once, then people, obstacles and constraints change."""

    model_config = ConfigDict(extra="forbid")

    id: SessionId | None = Field(
        default=None, pattern=r"^[A-Za-z0-9_.-]{1,64}$", description="Chosen by the client, else generated."
    )
    robot: str = DEFAULT_ROBOT
    hands: dict[str, str] = Field(default_factory=dict)
    scene: Scene = Field(default_factory=Scene)
    constraints: ConstraintSet = Field(default_factory=ConstraintSet)
    roles: dict[str, str] = Field(
        default_factory=dict,
        description="Each person's role (Receiver, Giver, ...): their ISO/TS 15066 speed limits; others are bystanders.",
    )


class SessionState(SessionCreate):
    """What the server keeps of a session; `version` counts its updates."""

    id: SessionId
    version: int = 0


class SessionPlanRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")

    start: dict[str, float]
    goal: Target
    options: PlanOptions = Field(default_factory=PlanOptions)
    group: str | None = None


class FeasibleRequest(BaseModel):
    """A task planner's question: can this step be done from this state (`hriplan.api.feasible`)."""

    model_config = ConfigDict(extra="forbid")

    state: TaskFile = Field(
        description="The world as a task file states it (objects and who holds them, people and roles, tables, "
        "start); the session's scene overrides it where it perceives the same people and objects."
    )
    step: Step | str = Field(description="A step as a task file writes one, or the name of one of the state's steps.")
    configuration: dict[str, float] | None = Field(
        default=None, description="Where the robot is now (joint values); default: the state's start."
    )
    time_limit: float = Field(default=TIME_LIMIT, gt=0.0, le=60.0, description="The planning budget, seconds.")


class StoredTask(BaseModel):
    """A task kept for SPARQL: /tasks/{id}/sparql and /tasks/{id}/steps/{step}/sparql."""

    id: str
    task: str
    steps: list[str]


class JobState(BaseModel):
    """A background plan (`POST /jobs/plan`, `/jobs/solve`): running, or done with its answer's
    HTTP status (GET /jobs/{id}/result gives the answer)."""

    id: str
    kind: str
    status: Literal["running", "done"]
    result_status: int | None = None
