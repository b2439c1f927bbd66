"""OMPL glue: a constrained (or plain) joint space, a validity callback, one planner, one solve.

Everything OMPL is created inside `solve_with_ompl` and dropped when it returns: OMPL objects
kept in module globals make nanobind report leaks at exit, and a seed only makes runs
reproducible when every OMPL object is built after it.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from hriplan.planner.options import PlanOptions
from hriplan.planner.outcome import Status
from hriplan.planner.search.result import Counters, SearchResult
from hriplan.planner.search.seeds import ompl_seed

ou.setLogLevel(ou.LOG_NONE)  # failures reach us as exceptions or statuses
Rows = Callable[[np.ndarray], np.ndarray]
# Default range (rad) of tree planners in the plain joint space: OMPL's default, a fifth of the
# space's extent, is 8.7 rad for two arms, and such steps make paths wander that no shortcut repairs.
PLAIN_SPACE_RANGE = 1.0
# Simplification stops when a round shortens the path by less than this fraction, twice running.
SHRINK_TOLERANCE = 5e-3
STALE_ROUNDS = 2
# Shortcut attempts per round (and consecutive failed attempts before a round gives up).
SHORTCUT_STEPS, SHORTCUT_EMPTY_STEPS = 200, 50


class RowsConstraint(ob.Constraint):
    """Constraint rows and their analytic Jacobian, computed in Python (hriplan's evaluator)."""

    def __init__(self, ambient: int, rows: Rows, jacobian: Rows, n_rows: int, counters: Counters) -> None:
        super().__init__(ambient, n_rows)
        self._rows, self._jacobian, self._counters = rows, jacobian, counters

    def function(self, x, out) -> None:
        self._counters.function += 1
        out[:] = self._rows(np.asarray(x))

    def jacobian(self, x, out) -> None:
        self._counters.jacobian += 1
        out[:, :] = self._jacobian(np.asarray(x))


def _space(options: PlanOptions, bounds: tuple[np.ndarray, np.ndarray], constraint: RowsConstraint | None):
    n = len(bounds[0])
    real = ob.RealVectorStateSpace(n)
    box = ob.RealVectorBounds(n)
    for i, (lo, hi) in enumerate(zip(*bounds)):
        box.setLow(i, float(lo))
        box.setHigh(i, float(hi))
    real.setBounds(box)
    if constraint is None:
        return real, ob.SpaceInformation(real), "real_vector"
    kind = {
        "atlas": ob.AtlasStateSpace,
        "tangent_bundle": ob.TangentBundleStateSpace,
        "projected": ob.ProjectedStateSpace,
    }
    space = kind[options.space](real, constraint)
    space.setDelta(options.delta)
    info = (
        ob.TangentBundleSpaceInformation(space)
        if options.space == "tangent_bundle"
        else ob.ConstrainedSpaceInformation(space)
    )
    return space, info, options.space


def _planner(name: str, info: ob.SpaceInformation, options: PlanOptions, plain: bool):
    planner = getattr(og, name)(info)
    reach = options.range if options.range is not None else PLAIN_SPACE_RANGE if plain else None
    if reach is not None and hasattr(planner, "setRange"):
        planner.setRange(reach)
    if hasattr(planner, "setStopOnSolnImprovement"):
        planner.setStopOnSolnImprovement(True)
    return planner


def shorten(simplifier: og.PathSimplifier, path: og.PathGeometric, deadline: float, constrained: bool) -> None:
    """Simplify until the path stops getting shorter or the deadline passes.

    On a manifold this is OMPL's own simplification, which already repeats its shortcuts along
    the manifold until they stop paying (a per-joint shortcut would leave the manifold). In the
    joint space one OMPL pass tries only as many shortcuts as the path has states (a handful after
    RRTConnect), which left paths several times longer than needed: rounds of many vertex-dropping
    and per-joint (partial) shortcuts continue until a round gains less than SHRINK_TOLERANCE,
    STALE_ROUNDS times in a row."""
    if constrained:
        simplifier.simplify(path, max(0.0, deadline - time.perf_counter()))
        return
    best, stale = path.length(), 0
    while stale < STALE_ROUNDS and time.perf_counter() < deadline:
        simplifier.reduceVertices(path, SHORTCUT_STEPS, SHORTCUT_EMPTY_STEPS)
        simplifier.partialShortcutPath(path, SHORTCUT_STEPS, SHORTCUT_EMPTY_STEPS)
        simplifier.collapseCloseVertices(path)
        length = path.length()
        stale = stale + 1 if length > best * (1.0 - SHRINK_TOLERANCE) else 0
        best = min(best, length)


def solve_with_ompl(
    options: PlanOptions,
    bounds: tuple[np.ndarray, np.ndarray],
    start: np.ndarray,
    goal: np.ndarray,
    is_valid: Callable[[np.ndarray], bool],
    rows: tuple[Rows, Rows, int] | None,
    attempt: int = 0,
) -> SearchResult:
    """Plan from `start` to `goal` (ambient vectors); `rows` = (function, jacobian, count) puts
    those rows on the manifold, None plans in the plain joint space. `attempt` counts re-plans
    of one run, each with its own seed."""
    if options.seed is not None:
        ou.RNG.setSeed(ompl_seed(options.seed, attempt))
    counters = Counters()
    constraint = RowsConstraint(len(start), rows[0], rows[1], rows[2], counters) if rows else None
    space, info, space_name = _space(options, bounds, constraint)
    n = len(start)

    def valid(state) -> bool:
        counters.validity += 1
        return bool(is_valid(np.array([state[i] for i in range(n)])))

    setup = og.SimpleSetup(info)
    setup.setStateValidityChecker(valid)
    if constraint is None:
        _set_resolution(info, space, options.delta)
    ends = []
    for values in (start, goal):
        state = space.allocState()
        if constraint is None:  # plain real-vector states are set per coordinate
            for i, v in enumerate(values):
                state[i] = float(v)
        else:
            state.copy([float(v) for v in values])
        ends.append(state)
    t0 = time.perf_counter()
    try:
        if space_name in ("atlas", "tangent_bundle"):
            for state in ends:
                space.anchorChart(state)
        setup.setStartAndGoalStates(ends[0], ends[1])
        setup.setPlanner(_planner(options.planner, info, options, constraint is None))
        setup.solve(options.time_limit)
    except RuntimeError as exc:  # OMPL reports chart or set-up failures as exceptions
        return SearchResult(Status.PLANNER_ERROR, [], space_name, f"OMPL: {exc}", counters)
    if not setup.haveExactSolutionPath():
        return SearchResult(Status.TIMEOUT, [], space_name, "no exact solution within the time limit", counters)
    path = setup.getSolutionPath()
    raw = _states(og.PathGeometric(path), n)
    if options.simplify:
        if constraint is None:  # shortcuts are long straight segments: check them as densely as validation will
            _set_resolution(info, space, options.validation_step)
        shorten(
            og.PathSimplifier(info),
            path,
            max(t0 + options.time_limit, time.perf_counter() + 0.05),
            constraint is not None,
        )
        if constraint is None:  # and hand back states at the planning resolution, as unsimplified paths
            _set_resolution(info, space, options.delta)
    return SearchResult(Status.SOLVED, _states(path, n), space_name, "", counters, raw if options.simplify else [])


def _set_resolution(info: ob.SpaceInformation, space: ob.StateSpace, step: float) -> None:
    """Check motions of the plain joint space every `step` rad (joint-space distance)."""
    info.setStateValidityCheckingResolution(min(0.5, step / max(info.getMaximumExtent(), 1e-9)))
    space.setup()


def _states(path: og.PathGeometric, n: int) -> list[np.ndarray]:
    """The path's states (interpolated at the space's resolution) as ambient vectors."""
    path.interpolate()
    return [np.array([path.getState(k)[i] for i in range(n)]) for k in range(path.getStateCount())]
