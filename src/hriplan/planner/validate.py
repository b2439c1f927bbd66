"""Dense validation: a path is returned only if every interpolated state is valid.

Every segment is split so that no joint moves more than `step` (0.01 rad by default) between
checked states; each state must be collision free and satisfy every active constraint within its
tolerance + 1e-4.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydantic import BaseModel

from hriplan import HriplanError
from hriplan.planner.constraints.evaluator import ConstraintEvaluator
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.kernel_switch import kernels_on
from hriplan.safety.person_distance import nearest_moving

VALIDATION_TOLERANCE = 1e-4
DISTANCE_SAMPLES = 150


class ConstraintCheck(BaseModel):
    id: str
    max_violation: float  # largest margin along the path: <= 0 satisfied, > 0 violated by that
    satisfied: bool


class PathValidation(BaseModel):
    valid: bool
    states_checked: int
    constraints: list[ConstraintCheck]
    collision: str | None = None  # "a - b at state k" for the first colliding state
    min_human_distance: float | None = None
    closest_pair: tuple[str, str] | None = None
    message: str = ""
    failed_state: list[float] | None = None  # the first dense state that collides or violates, if any


def densify(states: Sequence[np.ndarray], step: float) -> np.ndarray:
    """Linear interpolation with at most `step` change per joint between consecutive rows: row k
    of a segment from a to b split in n is a + (b - a) * (k / n), k = 1..n, for all segments in
    one numpy pass (the same floating-point operations as one row at a time, so the same bits).
    `states`: an (m, n) array or m rows, read in one conversion (row by row: ~0.1 ms a timed path).
    With the kernels on one compiled call (`path_kernels.densified`, the same bits; ~20 numpy
    calls cost ~50 us, three a plan). A number that is not finite cannot be split: HriplanError."""
    rows = np.asarray(states, dtype=float)
    if not np.isfinite(rows).all():
        raise HriplanError("a path to validate holds a number that is not finite (NaN or infinite)")
    if kernels_on() and rows.ndim == 2 and len(rows) and step > 0.0:  # numba raises on / 0.0
        from hriplan.planner import path_kernels  # numba: imported with the kernels on

        return path_kernels.densified(np.ascontiguousarray(rows), float(step))
    a, change = rows[:-1], np.diff(rows, axis=0)
    counts = np.maximum(1, np.ceil(np.abs(change).max(axis=1, initial=0.0) / step).astype(int))
    segment = np.repeat(np.arange(len(change)), counts)
    k = np.arange(len(segment)) - np.repeat(np.cumsum(counts) - counts, counts) + 1
    fraction = k / counts[segment]
    return np.concatenate([rows[:1], a[segment] + change[segment] * fraction[:, None]])


def _spread(count: int, most: int) -> np.ndarray:
    """At most `most` indices of `count` rows spread evenly from the first to the last, each once
    (ascending: np.unique's answer without its import of numpy.ma, ~10 ms of a command's start)."""
    indices = np.linspace(0, count - 1, min(count, most)).astype(int)
    return indices[np.concatenate([[True], np.diff(indices) > 0])] if len(indices) else indices


def validate_path(
    evaluator: ConstraintEvaluator,
    checker: CollisionChecker,
    states: Sequence[np.ndarray],
    step: float = 0.01,
    human_distance: bool = False,
) -> PathValidation:
    """Check the path (ambient vectors of the evaluator's group) densely; `human_distance` adds
    the closest approach to a person (a report figure, costly: only the timed path's report asks)."""
    dense = densify(states, step)
    qs = evaluator.full_many(dense)
    margins = evaluator.margins_many(qs)
    worst = margins.max(axis=0, initial=-np.inf)
    violated_at = np.flatnonzero(margins.max(axis=1, initial=-np.inf) > VALIDATION_TOLERANCE)
    with checker.moving(evaluator.group, evaluator.q):  # only the group's joints leave the evaluator's base
        hit = checker.first_collision(qs)
    collision = None
    if hit is not None:
        contacts = checker.contacts(qs[hit])
        pair = f"{contacts[0].a} - {contacts[0].b}" if contacts else "collision"
        collision = f"{pair} at dense state {hit} of {len(dense)}"
    firsts = [k for k in (hit, violated_at[0] if violated_at.size else None) if k is not None]
    failed = dense[min(firsts)] if firsts else None
    checks = [
        ConstraintCheck(id=c.id, max_violation=float(w), satisfied=bool(w <= VALIDATION_TOLERANCE))
        for c, w in zip(evaluator.constraints, worst)
    ]
    best = (
        checker.closest_human(qs[_spread(len(dense), DISTANCE_SAMPLES)], nearest_moving if kernels_on() else None)
        if human_distance
        else (float("inf"), "", "")
    )
    violated = [c.id for c in checks if not c.satisfied]
    problems = ([f"constraint {', '.join(violated)} violated"] if violated else []) + ([collision] if collision else [])
    return PathValidation(
        valid=not problems,
        states_checked=len(dense),
        constraints=checks,
        collision=collision,
        min_human_distance=None if best[0] == float("inf") else best[0],
        closest_pair=None if best[0] == float("inf") else (best[1], best[2]),
        message="; ".join(problems),
        failed_state=None if failed is None else failed.tolist(),
    )
