"""A planning problem as data: robot, scene, constraints, start, goal, options (JSON file).

This is the stage between the rules (which produce constraints) and the planner; benchmark
scenarios and `hriplan` problem files are instances of it.
"""

from __future__ import annotations

from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, model_validator

from hriplan.files import load_model
from hriplan.planner.constraints.spec import ConstraintSet
from hriplan.planner.motion import Target
from hriplan.planner.options import PlanOptions
from hriplan.robots.descriptions.registry import DEFAULT_ROBOT, registered_robot_file, with_robot_name
from hriplan.robots.scene import Scene


class PlanningProblem(BaseModel):
    model_config = ConfigDict(extra="forbid")

    name: str = "problem"
    description: str = ""
    robot: str = DEFAULT_ROBOT
    robot_file: str = Field("", description="The robot file `robot` came from (absolute; set by load_problem).")
    hands: dict[str, str] = Field(default_factory=dict)
    scene: Scene = Field(default_factory=Scene)
    constraints: ConstraintSet = Field(default_factory=ConstraintSet)
    group: str | None = None
    start: dict[str, float]
    goal: Target
    options: PlanOptions = Field(default_factory=PlanOptions)
    # Speed and separation: each person's role (ontology: Receiver, Giver, Supervisor, ...), which
    # sets their ISO/TS 15066 parameters; people not named are bystanders.
    roles: dict[str, str] = Field(default_factory=dict)

    @model_validator(mode="before")
    @classmethod
    def _robot_file_loaded(cls, data: object) -> object:
        return registered_robot_file(data)


def load_problem(path: str | Path) -> PlanningProblem:
    """Read a problem file (its `robot:` a name or a robot file); errors name the file and the field."""
    return load_model(path, PlanningProblem, lambda data: with_robot_name(data, Path(path).parent))
