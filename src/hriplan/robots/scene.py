"""Scene description: named obstacles, objects that a hand can carry, and the people around.

Shapes follow URDF/coal conventions: box centred, cylinder centred with axis z, capsule centred
with axis z (`length` is the cylinder part), mesh in its own frame scaled by `scale`.
"""

from __future__ import annotations

from typing import Annotated, Literal

import coal
import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from hriplan import HriplanError
from hriplan.robots.human import HumanSpec
from hriplan.robots.spatial import Immutable, Pose

Positive = Annotated[float, Field(gt=0.0, allow_inf_nan=False)]


class _Shape(Immutable):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Box(_Shape):
    type: Literal["box"] = "box"
    size: tuple[Positive, Positive, Positive]

    def geometry(self) -> coal.CollisionGeometry:
        return coal.Box(*self.size)


class Cylinder(_Shape):
    type: Literal["cylinder"] = "cylinder"
    radius: Positive
    height: Positive

    def geometry(self) -> coal.CollisionGeometry:
        return coal.Cylinder(self.radius, self.height)


class Sphere(_Shape):
    type: Literal["sphere"] = "sphere"
    radius: Positive

    def geometry(self) -> coal.CollisionGeometry:
        return coal.Sphere(self.radius)


class Capsule(_Shape):
    type: Literal["capsule"] = "capsule"
    radius: Positive
    length: Annotated[float, Field(ge=0.0)]

    def geometry(self) -> coal.CollisionGeometry:
        return coal.Capsule(self.radius, self.length)


class Cone(_Shape):
    """Centred cone, axis z, base (radius) at z = -height/2, apex at z = +height/2 (coal's)."""

    type: Literal["cone"] = "cone"
    radius: Positive
    height: Positive

    def geometry(self) -> coal.CollisionGeometry:
        return coal.Cone(self.radius, self.height)


class Mesh(_Shape):
    """A mesh file, checked through its convex hull (conservative and fast)."""

    type: Literal["mesh"] = "mesh"
    path: str
    scale: tuple[Positive, Positive, Positive] = (1.0, 1.0, 1.0)

    def geometry(self) -> coal.CollisionGeometry:
        try:
            mesh = coal.MeshLoader().load(self.path, np.asarray(self.scale, dtype=float))
        except Exception as exc:  # coal raises a bare RuntimeError with a C++ message
            raise HriplanError(f"cannot load mesh {self.path!r}: {exc}") from None
        mesh.buildConvexHull(True, "Qt")
        return mesh.convex


Shape = Annotated[Box | Cylinder | Sphere | Capsule | Cone | Mesh, Field(discriminator="type")]


class Obstacle(BaseModel):
    """A static body: a table, a shelf, an object standing somewhere."""

    model_config = ConfigDict(extra="forbid")

    name: str
    shape: Shape
    pose: Pose = Pose()
    # The arm whose hand closes on this object in the motion planned now (a grasp, a take): that
    # hand may touch it, every other part of the robot may not.
    touched_by: str | None = None


class AttachedObject(BaseModel):
    """An object held by a hand: it moves with the tool frame and is checked against the scene."""

    model_config = ConfigDict(extra="forbid")

    name: str
    shape: Shape
    arm: str
    grasp: Pose = Pose()  # the object's pose in the tool frame
    # Obstacles it stands on while it is lifted off them (planner/lift.py): not checked against it.
    resting_on: list[str] = Field(default_factory=list)


class Scene(BaseModel):
    model_config = ConfigDict(extra="forbid")

    obstacles: list[Obstacle] = Field(default_factory=list)
    attached: list[AttachedObject] = Field(default_factory=list)
    humans: list[HumanSpec] = Field(default_factory=list)

    @model_validator(mode="after")
    def _unique_names(self) -> Scene:
        names = [o.name for o in self.obstacles] + [a.name for a in self.attached] + [h.name for h in self.humans]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise ValueError(f"scene names must be unique; repeated: {', '.join(duplicates)}")
        return self


def table(
    name: str = "table",
    size: tuple[float, float, float] = (0.8, 1.2, 0.04),
    top: float = 0.75,
    position: tuple[float, float] = (0.8, 0.0),
) -> Obstacle:
    """A table top as a box whose upper face is at height `top`."""
    return Obstacle(name=name, shape=Box(size=size), pose=Pose(xyz=(position[0], position[1], top - size[2] / 2)))
