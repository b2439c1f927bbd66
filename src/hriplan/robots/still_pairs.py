"""The pairs a motion of some joints holds still, for `CollisionChecker.moving`.

A plan moves one group (MADAR's right arm): every other joint stays where the plan started. A
checked pair neither of whose two geometries such a motion moves (the left arm against the torso,
the table or a person; the torso against a person) is placed the same at every state of it, so
its answer is its answer at that start: it is asked once there, and the per-state checks (coal's
broad phase, the compiled certifier, the clearance tables) leave it out. Still means still in the
world, not only relative to the other geometry: two geometries the motion carries together would
keep their relative placement too, but coal would see them placed anew, to the last bit, at
every state; the allowed-collision matrix leaves out such pairs anyway (a rigid body's parts touch
in every sampled state or in none).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from hriplan.robots.mesh_clearance import ClearanceTable

Tabled = list[tuple[ClearanceTable, list[int]]]  # clearance tables, each with the pair ids it stands for


@dataclass(eq=False)  # compared by identity: one per build and moved joints
class View:
    """What one build checks at every state while some joints move (all of it, when none is
    held), and what it holds still."""

    active: np.ndarray  # (ngeoms, ngeoms) bool, symmetric: the pairs the broad phase asks
    tabled: Tabled  # the clearance tables asked at every state
    still: list[int]  # pair ids held still (checked once, at the base)
    still_tables: Tabled  # clearance tables held still
    quiet: list[int]  # geometries with no pair left to ask: out of the broad phase
    broadphase: pin.BroadPhaseManager_NaiveCollisionManager | None = None  # made once applied
    certifier: object = None  # the compiled certifier of these pairs: None not made yet, False none
    placed: int = -1  # the checker's count of statics placings when the certifier last read them
    still_map: np.ndarray | None = None  # the still pairs as `active` has the others
    still_broadphase: pin.BroadPhaseManager_NaiveCollisionManager | None = None  # made when first asked
    # The still pairs' last answer at a base: (its fixed entries' bytes, `Motion.at_base`; where
    # everything on no joint stood, the checker's `_where` bytes; the answer).
    still_asked: tuple[bytes, bytes, bool] | None = None

    @property
    def holds(self) -> bool:
        return bool(self.still or self.still_tables)

    def still_touch(
        self,
        model: pin.Model,
        data: pin.Data,
        geom_model: pin.GeometryModel,
        geom_data: pin.GeometryData,
        q: np.ndarray,
    ) -> bool:
        """Does a still pair touch at `q`? Each asked as the full check asks it: a tabled one on
        its meshes only where its table does not certify `q`. The view's data asks them alone
        for one C++ call (a data of their own costs ~5 ms to make), then asks its own again."""
        objects = geom_model.geometryObjects
        for g in self.quiet:  # out of the per-state broad phase, not out of this one
            objects[g].disableCollision = False
        try:
            geom_data.setActiveCollisionPairs(geom_model, self.still_map, False)
            if self.still_broadphase is None:
                self.still_broadphase = pin.BroadPhaseManager_NaiveCollisionManager(model, geom_model, geom_data)
            if pin.computeCollisions(model, data, self.still_broadphase, q, True):
                return True
        finally:
            geom_data.setActiveCollisionPairs(geom_model, self.active, False)
            for g in self.quiet:
                objects[g].disableCollision = True
        values = q.tolist()
        return any(
            not table.certified(values) and any(pin.computeCollision(geom_model, geom_data, k) for k in ks)
            for table, ks in self.still_tables
        )


@dataclass(eq=False, slots=True)
class Held:
    """A view holding pairs still under a motion whose other entries stay at `at_base` (bytes of
    `Motion.at_base`), and whether its still pairs touch there (None: not asked yet)."""

    view: View
    at_base: bytes
    answer: bool | None = None


@dataclass(eq=False)
class Views:
    """One build's views by the joints that move (None: no motion declared; all pairs asked),
    and the one its pinocchio data has applied."""

    by_moved: dict[frozenset[int] | None, View]
    applied: View

    @classmethod
    def of(cls, pairs: np.ndarray, ngeoms: int, tabled_pairs: Sequence[int], tabled: Tabled) -> Views:
        """The full view of a build: every listed pair (`pairs` (k, 2) geometry indices) but the
        tabled ones, which the tables stand for."""
        asked = np.ones(len(pairs), dtype=bool)
        asked[list(tabled_pairs)] = False
        full = View(_pair_map(pairs, asked, ngeoms), tabled, [], [], [])
        return cls({None: full}, full)

    def held(self, moved: frozenset[int], pairs: np.ndarray, joints: Sequence[int]) -> View:
        """The view of a motion that moves the model joints `moved`: a pair of geometries on
        joints (`joints`, per geometry) it does not move is held still."""
        full = self.by_moved[None]
        still_geometry = ~np.isin(np.asarray(joints), list(moved))
        still_pair = still_geometry[pairs[:, 0]] & still_geometry[pairs[:, 1]]
        asked = full.active[pairs[:, 0], pairs[:, 1]]
        keep = asked & ~still_pair
        quiet = np.ones(len(joints), dtype=bool)
        quiet[pairs[keep].reshape(-1)] = False
        held_table = [all(still_pair[ks]) for _, ks in full.tabled]
        return View(
            _pair_map(pairs, keep, len(joints)),
            [t for t, held in zip(full.tabled, held_table) if not held],
            np.flatnonzero(asked & still_pair).tolist(),
            [t for t, held in zip(full.tabled, held_table) if held],
            np.flatnonzero(quiet).tolist(),
            still_map=_pair_map(pairs, asked & still_pair, len(joints)),
        )

    @contextmanager
    def every_pair(self, geom_model: pin.GeometryModel, geom_data: pin.GeometryData) -> Iterator[None]:
        """Within the block the build's data asks every pair but the tabled ones, as with no
        motion (`contacts` names every colliding pair), whatever view is applied."""
        held = self.applied
        if held is self.by_moved[None]:
            yield
            return
        self.apply(self.by_moved[None], geom_model, geom_data)
        try:
            yield
        finally:
            self.apply(held, geom_model, geom_data)

    def apply(self, view: View, geom_model: pin.GeometryModel, geom_data: pin.GeometryData) -> None:
        """Make `view` the one the build's data asks: its pairs active, its quiet geometries out."""
        if self.applied is view:
            return
        objects = geom_model.geometryObjects
        for g in self.applied.quiet:
            objects[g].disableCollision = False
        geom_data.setActiveCollisionPairs(geom_model, view.active, False)
        for g in view.quiet:
            objects[g].disableCollision = True
        self.applied = view


def _pair_map(pairs: np.ndarray, chosen: np.ndarray, ngeoms: int) -> np.ndarray:
    """The pairs `chosen` (a flag a pair) as the symmetric map of geometries pinocchio takes."""
    out = np.zeros((ngeoms, ngeoms), dtype=bool)
    out[pairs[chosen, 0], pairs[chosen, 1]] = out[pairs[chosen, 1], pairs[chosen, 0]] = True
    return out


@dataclass(frozen=True)
class Motion:
    """Which configuration entries a motion moves, and where the others stay."""

    moved: frozenset[int]  # model joints the moving entries move
    fixed: slice | np.ndarray | None  # the entries that stay (None: none, nothing to compare)
    base: np.ndarray  # the configuration they stay at
    at_base: bytes  # base[fixed], bit for bit

    @classmethod
    def of(cls, moves: np.ndarray, entries: Sequence[int], q_base: np.ndarray) -> Motion:
        """`moves` (nq, njoints): does entry i move joint j; `entries`: the entries that move."""
        entries = np.asarray(entries, dtype=int)
        moved = frozenset(np.flatnonzero(moves[entries].any(axis=0)).tolist())
        stays = np.ones(moves.shape[0], dtype=bool)
        stays[entries] = False
        fixed = np.flatnonzero(stays)
        if len(fixed) and fixed[-1] - fixed[0] == len(fixed) - 1:  # a slice: ~0.2 us less than indexing
            fixed = slice(int(fixed[0]), int(fixed[-1]) + 1)
        base = np.array(q_base, dtype=float)
        return cls(moved, fixed if len(base[fixed]) else None, base, base[fixed].tobytes())

    def stays_many(self, qs: np.ndarray) -> np.ndarray:
        """Per row of `qs` (N, nq): is every fixed entry the base's, bit for bit?"""
        if self.fixed is None:
            return np.ones(len(qs), dtype=bool)
        qs = np.asarray(qs, dtype=float).reshape(len(qs), -1)
        rows = np.ascontiguousarray(qs[:, self.fixed]).view(np.uint64)
        return (rows == np.frombuffer(self.at_base, dtype=np.uint64)).all(axis=1)
