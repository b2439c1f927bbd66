"""Constraint margins and gradients compiled (numba), from the Python route's own source:
geometry.py's scalar functions (`geometry.COMPILED`), compiled unchanged.

Why: the planner asks the margins of one state thousands of times a plan (~6-10 us each in
Python) and their gradients hundreds of times (~11-25 us); dense validation asks the margins of
hundreds of states at once. Compiled, with the robot's joints placed by the certifier's compiled
forward kinematics (`certifier_kernels.place_joints`), a state costs ~2 us. Why the same source:
a second copy of every formula would drift from the first. Each function is re-made with
globals in which its callees are their compiled versions, then handed to numba, which caches
them on disk keyed by geometry.py, the one file they all come from (its cache is keyed by a
function's own file, not by its callees'), so an edit there recompiles.

Covered: every volume kind, inside and outside, and orientations with one free axis, with or
without a tolerance gradient (everything the rules derive), on robots of one-axis joints. An
evaluator holding an orientation with no or two free axes (Kautham files, hand-written problems)
gets None and keeps the Python route. The numbers are the Python route's to ~1e-15 (the
kinematics round differently from pinocchio's), which can be enough for a projection's stopping
test to fall the other way: a seed then plans another (equally validated) path than with the
kernels off, and reproduces a plan only with the same switch.
"""

from __future__ import annotations

import types
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from numba import njit

from hriplan.planner.constraints import geometry as G
from hriplan.robots import certifier_kernels
from hriplan.robots.certifier_kernels import PRISMATIC, place_joints
from hriplan.robots.kernel_cache import njit_keyed
from hriplan.robots.kernel_fk import joint_tables

if TYPE_CHECKING:
    from hriplan.planner.constraints.evaluator import ConstraintEvaluator


def _compiled(names: tuple[str, ...]) -> dict[str, Callable]:
    """geometry.py's functions `names`, compiled, each calling the others' compiled versions."""
    scope = dict(vars(G))
    for name in names:
        source = vars(G)[name]
        remade = types.FunctionType(source.__code__, scope, name, source.__defaults__)
        remade.__qualname__ = source.__qualname__
        scope[name] = njit(cache=True, nogil=True)(remade)
    return scope


_KERNELS = _compiled(G.COMPILED)
term_margins, term_gradients = _KERNELS["term_margins"], _KERNELS["term_gradients"]
rows_gradients = _KERNELS["rows_gradients"]


@njit_keyed(G, certifier_kernels)
def states_margins(qs, joint_rows, joint_ints, rotation, origin, ints, floats, out) -> None:
    """out[n, k]: term k's margin at configuration qs[n], the joints placed state by state in
    the scratch rotation[0], origin[0] (a call from Python per state cost ~1 us more)."""
    for n in range(qs.shape[0]):
        place_joints(qs[n], joint_rows, joint_ints, rotation[0], origin[0])
        term_margins(rotation, origin, ints, floats, out[n : n + 1])


class CompiledTerms:
    """An evaluator's terms packed for geometry's `term_margins` and `term_gradients`. A dynamic
    tolerance's goal is read again whenever its constraint's `p_goal` is replaced (it is set
    after the evaluator is made)."""

    def __init__(self, evaluator: ConstraintEvaluator, tables: tuple[np.ndarray, np.ndarray]) -> None:
        model, terms = evaluator.model, evaluator.terms
        self._evaluator, (self._joint_rows, self._joint_ints) = evaluator, tables
        frames = [model.frames[t.link] for t in terms]
        self._ints = np.array(
            [(_kind(t), frame.parentJoint, t.free[0] if t.free else 0) for t, frame in zip(terms, frames)],
            dtype=np.int64,
        ).reshape(-1, 3)
        self._floats = np.array([_floats(t, frame) for t, frame in zip(terms, frames)]).reshape(-1, G.TERM_ROW)
        self._dynamic = [k for k, t in enumerate(terms) if t.target is not None and t.gradient > 0.0]
        self._goals: list[object] = [None] * len(self._dynamic)
        joints = [model.getJointId(j) for j in evaluator.robot.group_joints(evaluator.group)]
        self._columns = np.array(
            [(j, int(self._joint_ints[j, 1] == PRISMATIC)) for j in joints], dtype=np.int64
        ).reshape(-1, 2)
        self._axes = np.ascontiguousarray(self._joint_rows[joints, 12:15]).reshape(-1, 3)
        parents = self._joint_ints[:, 0].tolist()
        chains = [_chain(parents, frame.parentJoint) for frame in frames]
        self._carries = np.array([[int(j in chain) for j in joints] for chain in chains], dtype=np.int64).reshape(
            len(terms), len(joints)
        )
        self._rotation, self._origin = np.empty((1, model.njoints, 3, 3)), np.empty((1, model.njoints, 3))

    @classmethod
    def of(cls, evaluator: ConstraintEvaluator) -> CompiledTerms | None:
        """The compiled route for `evaluator`, or None if one of its terms or joints is not covered."""
        if not all(t.target is None or len(t.free) == 1 for t in evaluator.terms):
            return None
        tables = joint_tables(evaluator.model)
        return None if tables is None else cls(evaluator, tables)

    @property
    def count(self) -> int:
        """How many terms."""
        return len(self._ints)

    def base_configuration(self) -> np.ndarray:
        """A copy of the evaluator's configuration (the joints it does not plan stay there)."""
        return self._evaluator.q.copy()

    def kernel_arguments(self) -> tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]]:
        """What the compiled kernels take: (the joints' tables and frames' scratch for
        `place_joints`, the terms' arrays for `term_gradients` with the goals as they are now)."""
        joints = (self._joint_rows, self._joint_ints, self._rotation, self._origin)
        return joints, (self._ints, self._current(), self._columns, self._axes, self._carries)

    def margins(self, q: np.ndarray) -> np.ndarray:
        """Every term's margin at configuration `q`."""
        return self.margins_many(np.reshape(q, (1, -1)))[0]

    def margins_many(self, qs: np.ndarray) -> np.ndarray:
        """Every term's margin (N, terms) at configurations `qs` (N, nq), in one compiled call."""
        out = np.empty((len(qs), len(self._ints)))
        states_margins(
            np.ascontiguousarray(qs, dtype=float),
            self._joint_rows,
            self._joint_ints,
            self._rotation,
            self._origin,
            self._ints,
            self._current(),
            out,
        )
        return out

    def gradients(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(margins, one gradient row per margin w.r.t. the planned joints) at configuration `q`."""
        self._place(q)
        margins, rows = np.empty(len(self._ints)), np.empty((len(self._ints), len(self._columns)))
        floats = self._current()
        term_gradients(
            self._rotation[0],
            self._origin[0],
            self._ints,
            floats,
            self._columns,
            self._axes,
            self._carries,
            margins,
            rows,
        )
        return margins, rows

    def _place(self, q: np.ndarray) -> None:
        place_joints(
            np.ascontiguousarray(q, dtype=float), self._joint_rows, self._joint_ints, self._rotation[0], self._origin[0]
        )

    def _current(self) -> np.ndarray:
        """The terms' floats with every dynamic tolerance's goal as its constraint holds it now."""
        terms = self._evaluator.terms
        for n, k in enumerate(self._dynamic):
            goal = terms[k].bound.p_goal
            if goal is not self._goals[n]:
                self._goals[n] = goal
                self._floats[k, G.GRADIENT] = 0.0 if goal is None else terms[k].gradient
                self._floats[k, G.GOAL : G.LINK_R] = 0.0 if goal is None else goal
        return self._floats


def _chain(parents: list[int], joint: int) -> set[int]:
    """`joint` and the joints it hangs from, the world aside, by the tables' parents (the
    kernels' own tree): reading pinocchio's `supports` per term and joint cost ~15 us an evaluator."""
    chain = set()
    while joint > 0:
        chain.add(joint)
        joint = parents[joint]
    return chain


def _kind(term: object) -> int:
    return G.TILT if term.target is not None else term.shape


def _floats(term: object, frame: object) -> np.ndarray:
    """A term's TERM_ROW floats (a dynamic tolerance's gradient and goal left at 0: `_current`)."""
    row = np.zeros(G.TERM_ROW)
    row[G.FRAME : G.FRAME_T], row[G.FRAME_T : G.ORIGIN] = term.rf.reshape(9), term.rf_t.reshape(9)
    row[G.ORIGIN : G.DIMS] = term.origin
    if term.target is None:
        row[G.DIMS : G.SIGN], row[G.SIGN] = term.dims, term.sign
    else:
        row[G.DIMS : G.SIGN], row[G.TOLERANCE] = term.axis_target, term.tolerance
    row[G.LINK_R : G.LINK_T], row[G.LINK_T : G.TERM_ROW] = (
        frame.placement.rotation.reshape(9),
        frame.placement.translation,
    )
    return row
