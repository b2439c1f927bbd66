"""Planning options (pydantic): which constrained space, which planner, limits and seed."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

PLANNERS = (
    "CBiRRT", "RRTConnect", "RRT", "BKPIECE1", "KPIECE1", "LBKPIECE1", "PRM", "PRMstar", "RRTstar",
    "BITstar", "AORRTC", "FMT", "BFMT", "InformedRRTstar", "SORRTstar",
)  # fmt: skip
Space = Literal["atlas", "tangent_bundle", "projected", "rejection"]
Formulation = Literal["hybrid", "deadzone"]


class PlanOptions(BaseModel):
    """How to plan one motion.

    - space: OMPL's constrained space (atlas, tangent_bundle, projected) or `rejection`, the seed
      framework's method (constraints only checked, never projected) kept as a baseline.
    - formulation: `hybrid` puts orientation constraints on the manifold as exact equalities and
      checks volumes and tolerance bands as validity; `deadzone` puts every constraint in one
      dead-zone row (max(margin, 0)) on the manifold (meant for the projected space).
    """

    model_config = ConfigDict(extra="forbid")

    planner: Literal[PLANNERS] = "RRTConnect"  # type: ignore[valid-type]
    space: Space = "atlas"
    formulation: Formulation = "hybrid"
    time_limit: float = Field(default=5.0, gt=0.0, le=3600.0)
    seed: int | None = None
    simplify: bool = True
    range: float | None = Field(default=None, gt=0.0)
    delta: float = Field(default=0.05, gt=0.0, le=0.5)
    project_start: bool = False
    validation_step: float = Field(default=0.01, gt=0.0, le=0.05)
    # Timing: UR5 descriptions carry no acceleration limit; pi rad/s^2 is a conservative default.
    velocity_scale: float = Field(default=1.0, gt=0.0, le=1.0)
    acceleration_limit: float = Field(default=3.14159, gt=0.0)
