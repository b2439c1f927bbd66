"""Planning options (pydantic): which constrained space, which planner, limits and seed."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from hriplan import HriplanError

PLANNERS = (
    "CBiRRT",
    "RRTConnect",
    "RRT",
    "BKPIECE1",
    "KPIECE1",
    "LBKPIECE1",
    "PRM",
    "PRMstar",
    "RRTstar",
    "BITstar",
    "AORRTC",
    "FMT",
    "BFMT",
    "InformedRRTstar",
    "SORRTstar",
)
# Planners with a range (maximum motion length) setting; on the others `range` would be ignored.
RANGED_PLANNERS = (
    "RRTConnect",
    "RRT",
    "BKPIECE1",
    "KPIECE1",
    "LBKPIECE1",
    "RRTstar",
    "AORRTC",
    "InformedRRTstar",
    "SORRTstar",
)
Space = Literal["atlas", "tangent_bundle", "projected", "rejection"]
Formulation = Literal["hybrid", "deadzone", "slack"]


class PlanOptions(BaseModel):
    """How to plan one motion.

    - space: OMPL's constrained space (atlas, tangent_bundle, projected) or `rejection`, the seed
      framework's method (constraints only checked, never projected) kept as a baseline.
    - formulation: `hybrid` puts orientation constraints on the manifold as exact equalities and
      checks volumes and tolerance bands as validity; `deadzone` puts every constraint in one
      dead-zone row (max(margin, 0)) on the manifold (meant for the projected space); `slack`
      makes each band an equality with a bounded slack variable (Atlas, TangentBundle).
    - planner `CBiRRT` is hriplan's own: it projects onto the dead-zone rows only where a step
      leaves a band, so the whole band is used along the path (space `projected`, formulation
      `deadzone`). See benchmarks/REPORT-planner.md for how the methods compare.
    - seed: any integer; each one is its own reproducible run (see `search/seeds.ompl_seed`).
    - simplify: shortcut and simplify the path until it stops getting shorter.
    """

    model_config = ConfigDict(extra="forbid")

    planner: Literal[PLANNERS] = "CBiRRT"  # type: ignore[valid-type]
    space: Space = "projected"
    formulation: Formulation = "deadzone"
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

    @model_validator(mode="before")
    @classmethod
    def _formulation_of_the_space(cls, data: object) -> object:
        """No formulation given: the one the space plans with (Atlas/TangentBundle chart the
        hybrid equalities; projected and rejection take dead-zone rows)."""
        if isinstance(data, dict) and data.get("formulation") is None:
            charted = data.get("space") in ("atlas", "tangent_bundle")
            return {**data, "formulation": "hybrid" if charted else "deadzone"}
        return data

    @model_validator(mode="after")
    def _combination_works(self) -> PlanOptions:
        conflict = option_conflict(self)
        if conflict:
            raise ValueError(conflict)
        return self


def option_conflict(options: PlanOptions) -> str | None:
    """Why these options cannot work together (one line), or None. The one place that knows:
    PlanOptions validates with it, and `check_options` re-checks copies made with model_copy."""
    if options.planner == "CBiRRT" and (options.space, options.formulation) != ("projected", "deadzone"):
        return (
            f"planner CBiRRT plans with space 'projected' and formulation 'deadzone', not {options.space!r} and "
            f"{options.formulation!r}; choose an OMPL planner (e.g. RRTConnect) for those"
        )
    if options.formulation == "deadzone" and options.space in ("atlas", "tangent_bundle"):
        return (
            f"the deadzone formulation cannot be planned on the {options.space} space (its rows have no tangent "
            "space inside a band to chart); use space 'projected', or formulation 'hybrid' or 'slack'"
        )
    if options.formulation == "slack" and options.space == "projected":
        return "formulation 'slack' is for the atlas and tangent_bundle spaces; use 'deadzone' on the projected space"
    if options.range is not None and options.planner not in RANGED_PLANNERS:
        return f"planner {options.planner} has no range setting; leave range unset or use one of {', '.join(RANGED_PLANNERS)}"
    return None


def check_options(options: PlanOptions) -> None:
    """Raise HriplanError (one line) if the options cannot work together."""
    conflict = option_conflict(options)
    if conflict:
        raise HriplanError(f"options: {conflict}")
