"""Per person, how the timed motion kept ISO/TS 15066 speed and separation (trajectory report)."""

from __future__ import annotations

import math

import numpy as np

from hriplan.planner.timing import TimedPath
from hriplan.planner.trajectory import SeparationTrace
from hriplan.safety.approach import ApproachMonitor
from hriplan.safety.separation import contact_speed_limit, minimum_separation


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None


def separation_report(monitor: ApproachMonitor, timed: TimedPath) -> list[SeparationTrace]:
    """Separation, allowed and actual speed towards each person at every trajectory point."""
    rows = [monitor.samples(np.asarray(x), np.asarray(v)) for x, v in zip(timed.positions, timed.velocities)]
    traces = []
    for k, person in enumerate(monitor.people):
        samples = [row[k] for row in rows]
        approaching = [s for s in samples if s.approach > 0.0 and math.isfinite(s.allowed)]
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
                slowest_allowed=None if slowest is None else slowest.allowed,
                slowest_separation=None if slowest is None else slowest.separation,
                separation=[_finite(s.separation) for s in samples],
                body_separation=[_finite(s.body_separation) for s in samples],
                allowed_speed=[_finite(s.allowed) for s in samples],
                approach_speed=[_finite(s.approach) if math.isfinite(s.allowed) else None for s in samples],
            )
        )
    return traces
