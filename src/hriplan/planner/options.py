"""Planning options (pydantic): which constrained space, which planner, limits and seed."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from hriplan import HriplanError

PLANNERS = (
    "CBiRRT", "RRTConnect", "RRT", "BKPIECE1", "KPIECE1", "LBKPIECE1", "PRM", "PRMstar", "RRTstar",
    "BITstar", "AORRTC", "FMT", "BFMT", "InformedRRTstar", "SORRTstar",
)  # fmt: skip
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


def check_method(options: PlanOptions) -> None:
    """Refuse, in one line, a planner x space x formulation that cannot plan."""
    if options.planner == "CBiRRT" and (options.space, options.formulation) != ("projected", "deadzone"):
        raise HriplanError(f"planner CBiRRT plans with space 'projected' and formulation 'deadzone', not {options.space!r} and "
                           f"{options.formulation!r}; choose an OMPL planner (e.g. RRTConnect) for those")  # fmt: skip
    if options.formulation == "deadzone" and options.space in ("atlas", "tangent_bundle"):
        raise HriplanError(f"formulation 'deadzone' cannot be charted by the {options.space} space (its rows have no tangent "
                           "space inside a band); use space 'projected', or formulation 'hybrid' or 'slack'")  # fmt: skip
    if options.formulation == "slack" and options.space == "projected":
        raise HriplanError("formulation 'slack' is for the atlas and tangent_bundle spaces; use 'deadzone' on the projected space")
