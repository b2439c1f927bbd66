"""Planning options (pydantic): which constrained space, which planner, limits and seed."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from hriplan import HriplanError

PLANNERS = (
    "RRTConnect", "RRT", "BKPIECE1", "KPIECE1", "LBKPIECE1", "PRM", "PRMstar", "RRTstar",
    "BITstar", "AORRTC", "FMT", "BFMT", "InformedRRTstar", "SORRTstar",
)  # fmt: skip
# Planners with a range (maximum motion length) setting; on the others `range` would be ignored.
RANGED_PLANNERS = ("RRTConnect", "RRT", "BKPIECE1", "KPIECE1", "LBKPIECE1", "RRTstar", "AORRTC", "InformedRRTstar", "SORRTstar")
Space = Literal["atlas", "tangent_bundle", "projected", "rejection"]
Formulation = Literal["hybrid", "deadzone"]


class PlanOptions(BaseModel):
    """How to plan one motion.

    - space: OMPL's constrained space (atlas, tangent_bundle, projected) or `rejection`, the seed
      framework's method (constraints only checked, never projected) kept as a baseline.
    - formulation: `hybrid` puts orientation constraints on the manifold as exact equalities and
      checks volumes and tolerance bands as validity; `deadzone` puts every constraint in one
      dead-zone row (max(margin, 0)) on the manifold (meant for the projected space).
    - seed: any integer; each one is its own reproducible run (see `ompl_backend.ompl_seed`).
    - simplify: shortcut and simplify the path until it stops getting shorter.
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

    @model_validator(mode="after")
    def _combination_works(self) -> PlanOptions:
        conflict = option_conflict(self)
        if conflict:
            raise ValueError(conflict)
        return self


def option_conflict(options: PlanOptions) -> str | None:
    """Why these options cannot work together (one line), or None. The one place that knows:
    PlanOptions validates with it, and `check_options` re-checks copies made with model_copy."""
    if options.formulation == "deadzone" and options.space in ("atlas", "tangent_bundle"):
        return (f"the deadzone formulation cannot be planned on the {options.space} space (its rows have no tangent "
                "space to chart); use space 'projected', or the hybrid formulation")  # fmt: skip
    if options.range is not None and options.planner not in RANGED_PLANNERS:
        return f"planner {options.planner} has no range setting; leave range unset or use one of {', '.join(RANGED_PLANNERS)}"
    return None


def check_options(options: PlanOptions) -> None:
    """Raise HriplanError (one line) if the options cannot work together."""
    conflict = option_conflict(options)
    if conflict:
        raise HriplanError(f"options: {conflict}")
