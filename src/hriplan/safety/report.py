"""Per person, how a timed motion kept ISO/TS 15066 speed and separation: the trajectory report's
`separation` part, computed from the motion's positions and velocities (no planner types)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from pydantic import BaseModel, Field

from hriplan.safety.approach import CLOSING, ApproachMonitor
from hriplan.safety.separation import contact_speed_limit, minimum_separation


class SeparationTrace(BaseModel):
    """One person along the timed motion (ISO/TS 15066 speed and separation, see separation.py).

    Per trajectory point: the closest moving robot part's separation (to the whole person, and to
    the body outside its contact regions, where S_0 applies), and for the binding
    part-capsule pair (least margin) the allowed speed towards the person (with the policy's
    margin: what the timing kept) and the actual one (negative: moving away). None: no moving
    part faces the person (no limit)."""

    person: str
    role: str = ""
    minimum_separation: float  # S_0: where the allowed speed falls to 0 (m)
    contact_speed: float | None = None  # PFL cap near the person's contact region (m/s), if any
    min_separation: float | None  # closest approach of a moving part along the motion (m)
    worst_margin: float | None  # smallest allowed - actual speed towards the person (m/s; >= 0 kept)
    iso_worst_margin: float | None = None  # the same against ISO/TS 15066's own limit, without the margin
    slowest_allowed: float | None = None  # smallest allowed speed where the robot approached (m/s)
    slowest_separation: float | None = None  # the separation there (m)
    separation: list[float | None] = Field(default_factory=list)
    body_separation: list[float | None] = Field(default_factory=list)  # outside the contact regions
    allowed_speed: list[float | None] = Field(default_factory=list)
    approach_speed: list[float | None] = Field(default_factory=list)


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None


def separation_report(
    monitor: ApproachMonitor, positions: Sequence[Sequence[float]], velocities: Sequence[Sequence[float]]
) -> list[SeparationTrace]:
    """Separation, allowed and actual speed towards each person at every trajectory point (the
    monitored group's `positions` and `velocities`, one row per point)."""
    rows = monitor.samples_along(np.asarray(positions, dtype=float), np.asarray(velocities, dtype=float))
    traces = []
    for k, person in enumerate(monitor.people):
        samples = [row[k] for row in rows]
        approaching = [s for s in samples if s.approach > CLOSING and math.isfinite(s.allowed)]
        slowest = min(approaching, key=lambda s: s.allowed, default=None)
        contact = min((contact_speed_limit(monitor.policy.robot, person, c) for c in person.contact), default=None)
        traces.append(
            SeparationTrace(
                person=person.name,
                role=person.role,
                minimum_separation=minimum_separation(monitor.policy.robot, person),
                contact_speed=contact,
                min_separation=_finite(min(s.separation for s in samples)),
                worst_margin=_finite(
                    min((s.allowed - s.approach for s in samples if math.isfinite(s.allowed)), default=math.inf)
                ),
                iso_worst_margin=_finite(
                    min((s.iso_allowed - s.approach for s in samples if math.isfinite(s.iso_allowed)), default=math.inf)
                ),
                slowest_allowed=None if slowest is None else slowest.allowed,
                slowest_separation=None if slowest is None else slowest.separation,
                separation=[_finite(s.separation) for s in samples],
                body_separation=[_finite(s.body_separation) for s in samples],
                allowed_speed=[_finite(s.allowed) for s in samples],
                approach_speed=[_finite(s.approach) if math.isfinite(s.allowed) else None for s in samples],
            )
        )
    return traces
