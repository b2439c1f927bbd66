"""Constraint specifications: what a motion must respect, as data (JSON round-trip).

Semantics (the validator checks plans with exactly these; see `geometry.py`):
- orientation: R is the target link's orientation in `frame`, Rt the target. No free axis: the
  angle of Rt^T R <= tol. One free axis a: the angle between R a and Rt a <= tol (spin about a
  is free). Two free axes (restricted axis b): |twist of Rt^T R about b| <= tol.
  tol(q) = tolerance + tolerance_gradient * |p(q) - p_goal| (dynamic tolerance).
- volumes constrain the target link's position in `frame`: box centred (size l, w, h), sphere
  centred, cylinder axis z from z = 0 to z = h, cone apex at the origin opening along +z with
  radius r z / h for 0 <= z <= h. inside: in the closed region; outside: out of the open region.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from hriplan.robots.spatial import Pose

Positive = Annotated[float, Field(gt=0.0, allow_inf_nan=False)]
Axis = Literal["x", "y", "z"]


class FrameRef(BaseModel):
    """What a constraint is expressed in: `world`, `robot_base`, an obstacle's name, or a person's
    frame as `PERSON/head|torso|left_hand|right_hand|base`; plus an offset pose in that frame."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    entity: str = "world"
    offset: Pose = Pose()


class _Constraint(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    id: str = Field(min_length=1)
    joints: list[str] = Field(min_length=1)
    target_link: str
    enabled: bool = True
    frame: FrameRef = FrameRef()

    @field_validator("joints")
    @classmethod
    def _distinct(cls, v: list[str]) -> list[str]:
        if len(set(v)) != len(v):
            raise ValueError(f"joints must be distinct, got {v}")
        return v


class OrientationConstraint(_Constraint):
    type: Literal["orientation"] = "orientation"
    target: Pose = Pose()  # only its orientation is used
    free_axes: list[Axis] = Field(default_factory=list)
    tolerance: Annotated[float, Field(ge=0.0, allow_inf_nan=False)] = 0.1
    tolerance_gradient: Annotated[float, Field(ge=0.0, allow_inf_nan=False)] = 0.0

    @model_validator(mode="after")
    def _axes(self) -> OrientationConstraint:
        if len(set(self.free_axes)) != len(self.free_axes):
            raise ValueError(f"constraint {self.id!r}: free_axes repeats an axis")
        if len(self.free_axes) == 3:
            raise ValueError(f"constraint {self.id!r}: three free axes constrain nothing")
        return self


class _Volume(_Constraint):
    region: Literal["inside", "outside"] = "inside"
    # With region "outside": also keep every robot link (and carried object) out, as an obstacle.
    keep_out_all_links: bool = False

    @model_validator(mode="after")
    def _keep_out_needs_outside(self) -> _Volume:
        if self.keep_out_all_links and self.region != "outside":
            raise ValueError(f"constraint {self.id!r}: keep_out_all_links needs region 'outside'")
        return self


class BoxConstraint(_Volume):
    type: Literal["box"] = "box"
    size: tuple[Positive, Positive, Positive]


class SphereConstraint(_Volume):
    type: Literal["sphere"] = "sphere"
    radius: Positive


class CylinderConstraint(_Volume):
    type: Literal["cylinder"] = "cylinder"
    radius: Positive
    height: Positive


class ConeConstraint(_Volume):
    type: Literal["cone"] = "cone"
    radius: Positive
    height: Positive


VolumeConstraint = BoxConstraint | SphereConstraint | CylinderConstraint | ConeConstraint
# The volume constraints by their `type` (what a file names them).
VOLUME_TYPES: dict[str, type[_Volume]] = {
    "box": BoxConstraint,
    "sphere": SphereConstraint,
    "cylinder": CylinderConstraint,
    "cone": ConeConstraint,
}

ConstraintSpec = Annotated[
    OrientationConstraint | BoxConstraint | SphereConstraint | CylinderConstraint | ConeConstraint,
    Field(discriminator="type"),
]


class ConstraintSet(BaseModel):
    """Constraints for one motion; a JSON file holds exactly this."""

    model_config = ConfigDict(extra="forbid")

    constraints: list[ConstraintSpec] = Field(default_factory=list)

    @model_validator(mode="after")
    def _unique_ids(self) -> ConstraintSet:
        ids = [c.id for c in self.constraints]
        repeated = sorted({i for i in ids if ids.count(i) > 1})
        if repeated:
            raise ValueError(f"constraint ids must be unique; repeated: {', '.join(repeated)}")
        return self
