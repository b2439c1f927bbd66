"""OMPL glue: a constrained (or plain) joint space, a validity callback, one planner, one solve.

Everything OMPL is created inside `solve_with_ompl` and dropped when it returns: OMPL objects
kept in module globals make nanobind report leaks at exit, and a seed only makes runs
reproducible when every OMPL object is built after it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from .options import PlanOptions

ou.setLogLevel(ou.LOG_NONE)  # failures reach us as exceptions or statuses
Rows = Callable[[np.ndarray], np.ndarray]


@dataclass
class Counters:
    function: int = 0
    jacobian: int = 0
    validity: int = 0


@dataclass
class OmplResult:
    solved: bool
    states: list[np.ndarray]
    seconds: float
    space: str
    message: str = ""
    counters: Counters = field(default_factory=Counters)


class RowsConstraint(ob.Constraint):
    """Constraint rows and their analytic Jacobian, computed in Python (hriplan's evaluator)."""

    def __init__(self, ambient: int, rows: Rows, jacobian: Rows, n_rows: int, counters: Counters) -> None:
        super().__init__(ambient, n_rows)
        self._rows, self._jacobian, self._counters = rows, jacobian, counters

    def function(self, x, out) -> None:  # noqa: ANN001 - OMPL's signature
        self._counters.function += 1
        out[:] = self._rows(np.asarray(x))

    def jacobian(self, x, out) -> None:  # noqa: ANN001
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
    kind = {"atlas": ob.AtlasStateSpace, "tangent_bundle": ob.TangentBundleStateSpace, "projected": ob.ProjectedStateSpace}
    space = kind[options.space](real, constraint)
    space.setDelta(options.delta)
    info = ob.TangentBundleSpaceInformation(space) if options.space == "tangent_bundle" else ob.ConstrainedSpaceInformation(space)
    return space, info, options.space


def _planner(name: str, info: ob.SpaceInformation, options: PlanOptions):  # noqa: ANN202
    planner = getattr(og, name)(info)
    if options.range is not None and hasattr(planner, "setRange"):
        planner.setRange(options.range)
    if hasattr(planner, "setStopOnSolnImprovement"):
        planner.setStopOnSolnImprovement(True)
    return planner


def solve_with_ompl(
    options: PlanOptions,
    bounds: tuple[np.ndarray, np.ndarray],
    start: np.ndarray,
    goal: np.ndarray,
    is_valid: Callable[[np.ndarray], bool],
    rows: tuple[Rows, Rows, int] | None,
) -> OmplResult:
    """Plan from `start` to `goal` (ambient vectors); `rows` = (function, jacobian, count) puts
    those rows on the manifold, None plans in the plain joint space."""
    if options.seed is not None:
        ou.RNG.setSeed(options.seed)
    counters = Counters()
    constraint = RowsConstraint(len(start), rows[0], rows[1], rows[2], counters) if rows else None
    space, info, space_name = _space(options, bounds, constraint)
    n = len(start)

    def valid(state) -> bool:  # noqa: ANN001
        counters.validity += 1
        return bool(is_valid(np.array([state[i] for i in range(n)])))

    setup = og.SimpleSetup(info)
    setup.setStateValidityChecker(valid)
    if constraint is None:
        info.setStateValidityCheckingResolution(min(0.5, options.delta / max(info.getMaximumExtent(), 1e-9)))
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
        setup.setPlanner(_planner(options.planner, info, options))
        setup.solve(options.time_limit)
    except RuntimeError as exc:  # OMPL reports chart or set-up failures as exceptions
        return OmplResult(False, [], time.perf_counter() - t0, space_name, f"OMPL: {exc}", counters)
    if not setup.haveExactSolutionPath():
        return OmplResult(False, [], time.perf_counter() - t0, space_name, "no exact solution within the time limit", counters)
    if options.simplify:
        setup.simplifySolution(max(0.05, min(1.0, options.time_limit - (time.perf_counter() - t0))))
    path = setup.getSolutionPath()
    path.interpolate()
    states = [np.array([path.getState(k)[i] for i in range(n)]) for k in range(path.getStateCount())]
    return OmplResult(True, states, time.perf_counter() - t0, space_name, "", counters)
