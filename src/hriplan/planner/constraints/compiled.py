"""Constraint margins of many states in one compiled call (numba), from the Python route's own
source: geometry.py's scalar functions (`geometry.COMPILED`), compiled unchanged.

Why: dense validation asks the margins of hundreds of states at a time, one Python call per
state and term (~6-9 us a state); compiled, a batch costs well under 1 us a state. Why the same
source: a second copy of every formula for the compiled route would drift from the first. Each
function is re-made with globals in which its callees are their compiled versions, then handed
to numba; numba caches them on disk keyed by geometry.py, the one file they all come from (its
cache is keyed by a function's own file, not by its callees'), so an edit there recompiles.

Covered: every volume kind, inside and outside, and orientations with one free axis, with or
without a tolerance gradient: everything the rules derive. An evaluator holding an orientation
with no or two free axes (Kautham files, hand-written problems) gets None: its margins are
computed state by state.
"""

from __future__ import annotations

import types
from collections.abc import Callable

import numpy as np
from numba import njit

from hriplan.planner.constraints import geometry as G
from hriplan.robots.batch_kinematics import BatchKinematics


def _compiled(names: tuple[str, ...]) -> dict[str, Callable]:
    """geometry.py's functions `names`, compiled, each calling the others' compiled versions."""
    scope = dict(vars(G))
    for name in names:
        source = vars(G)[name]
        remade = types.FunctionType(source.__code__, scope, name, source.__defaults__)
        remade.__qualname__ = source.__qualname__
        scope[name] = njit(cache=True, nogil=True)(remade)
    return scope


_term_margins = _compiled(G.COMPILED)["term_margins"]


class CompiledMargins:
    """An evaluator's terms packed for `geometry.term_margins`, with the batched kinematics of
    the links they constrain. Terms are read again at every call: a dynamic tolerance's goal is
    set after the evaluator is made."""

    def __init__(self, evaluator: object) -> None:
        model = evaluator.model
        frames = [model.frames[link] for link in evaluator.links]
        joints = sorted({frame.parentJoint for frame in frames})
        self._evaluator = evaluator
        self._kinematics = BatchKinematics(model, joints)
        self._joint_of = np.array([joints.index(frame.parentJoint) for frame in frames], dtype=int)
        self._frame_rotation = np.array([frame.placement.rotation for frame in frames])
        self._frame_translation = np.array([frame.placement.translation for frame in frames])
        self._links = np.array(
            [(evaluator.links.index(t.link), t.free[0] if t.free else 0) for t in evaluator._terms], dtype=np.int64
        ).reshape(-1, 2)

    @classmethod
    def of(cls, evaluator: object) -> CompiledMargins | None:
        """The compiled route for `evaluator`, or None if one of its terms is not covered."""
        covered = all(t.target is None or len(t.free) == 1 for t in evaluator._terms)
        return cls(evaluator) if covered else None

    def __call__(self, qs: np.ndarray) -> np.ndarray:
        """Every term's margin (N, terms) at configurations `qs` (N, nq)."""
        qs = np.ascontiguousarray(qs, dtype=float)
        joint_rotation, joint_origin = self._kinematics.placements(qs)
        at = joint_rotation[:, self._joint_of]
        rotation = np.ascontiguousarray(at @ self._frame_rotation)
        position = np.ascontiguousarray(
            (at @ self._frame_translation[..., None])[..., 0] + joint_origin[:, self._joint_of]
        )
        kinds, rows = self._packed()
        out = np.empty((len(qs), len(kinds)))
        _term_margins(rotation, position, kinds, self._links, rows, out)
        return out

    def _packed(self) -> tuple[np.ndarray, np.ndarray]:
        """Per term: its kind (a shape code or TILT) and its TERM_ROW floats."""
        terms = self._evaluator._terms
        kinds, rows = np.empty(len(terms), dtype=np.int64), np.zeros((len(terms), G.TERM_ROW))
        for k, t in enumerate(terms):
            rows[k, G.FRAME_T : G.ORIGIN] = t.rf_t.reshape(9)
            rows[k, G.ORIGIN : G.DIMS] = t.origin
            if t.target is None:
                kinds[k], rows[k, G.DIMS : G.SIGN], rows[k, G.SIGN] = t.shape, t.dims, t.sign
                continue
            kinds[k], rows[k, G.DIMS : G.SIGN], rows[k, G.TOLERANCE] = G.TILT, t.axis_target, t.tolerance
            if t.gradient > 0.0 and t.bound.p_goal is not None:
                rows[k, G.GRADIENT], rows[k, G.GOAL : G.TERM_ROW] = t.gradient, t.bound.p_goal
        return kinds, rows
