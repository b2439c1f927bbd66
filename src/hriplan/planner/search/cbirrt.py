"""Plan inside tolerance bands and volumes: CBiRRT (Berenson et al. 2009), hriplan's own loop.

Two trees grow from the start and the goal. Each extension steps `delta` towards a target and,
only when the step leaves a band (a margin above -offset), projects it back by minimum-norm
Newton steps on the dead-zone rows max(margin + offset, 0). Inside a band nothing is projected,
so the tool may tilt within its tolerance and the link may move anywhere in its volume; states
are never rejected for leaving a band, they are moved back into it. OMPL's ProjectedStateSpace
does the same projection but samples and walks to far-away random states (see
benchmarks/REPORT-planner.md); this loop takes bounded steps and stops at the first blocked one.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from hriplan.planner.outcome import Status
from hriplan.planner.search.result import Counters, SearchResult
from hriplan.robots.spatial import norm

if TYPE_CHECKING:
    from hriplan.planner.search.band_kernels import BandWalker

Margins = Callable[[np.ndarray], np.ndarray]
Gradients = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]  # x -> (margins, a gradient row each)
Nearest = Callable[[np.ndarray, int, np.ndarray], int]  # (nodes, count, x) -> the nearest of nodes[:count]
NEWTON_ITERATIONS = 12
BLOCKED, REACHED, MORE, UNSURE, COLLIDED = 0, 1, 2, 3, 4  # how a compiled walk ended (band_kernels.walk)
LOCAL_SHARE, LOCAL_SPREAD = 0.8, 0.3  # rad: targets sampled near the tree
SHORTCUT_MIN_STEPS = 300
SETTLED_STATES = 40  # paths up to this many states are checked for a sub-path left to shorten


@dataclass
class BandProblem:
    """What one CBiRRT search needs: the margins with gradients, a collision check, joint bounds."""

    margins: Margins
    gradients: Gradients
    collision_free: Callable[[np.ndarray], bool]
    bounds: tuple[np.ndarray, np.ndarray]
    offset: float  # project to margin <= -offset ...
    accept: float  # ... and accept a projected state once margin <= -accept (< offset)
    delta: float
    constrained: bool = True  # False: no band at all, steps are never projected
    walker: BandWalker | None = None  # the compiled projection and walk (kernels on), else the Python loop
    # the collision certifier's arrays for states moving from x (CollisionChecker.compiled_verdict), or None
    certifier: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray] | None] = lambda x: None


def _min_norm_step(jac: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """The smallest dx with jac dx = rows (one or two rows, the usual cases, in closed form)."""
    if len(rows) == 1:
        g = jac[0]
        return g * (float(rows[0]) / max(float(g @ g), 1e-12))
    if len(rows) == 2:
        a, b = jac[0], jac[1]
        aa, ab, bb = float(a @ a) + 1e-9, float(a @ b), float(b @ b) + 1e-9
        det = aa * bb - ab * ab
        la = (bb * float(rows[0]) - ab * float(rows[1])) / det
        lb = (aa * float(rows[1]) - ab * float(rows[0])) / det
        return la * a + lb * b
    return jac.T @ np.linalg.solve(jac @ jac.T + 1e-9 * np.eye(len(rows)), rows)


class _Tree:
    """Nodes in a growing array (nearest neighbour by one numpy pass) with parent links."""

    def __init__(self, root: np.ndarray, capacity: int = 4096, nearest: Nearest | None = None) -> None:
        self.nodes = np.empty((capacity, len(root)))
        self.nodes[0] = root
        self.parents = [-1]
        self._nearest = nearest

    def __len__(self) -> int:
        return len(self.parents)

    def nearest(self, x: np.ndarray) -> int:
        if self._nearest is not None:
            return self._nearest(self.nodes, len(self), x)
        diff = self.nodes[: len(self)] - x
        return int(np.argmin(np.einsum("ij,ij->i", diff, diff)))

    def add(self, x: np.ndarray, parent: int) -> int:
        if len(self) == len(self.nodes):
            self.nodes = np.concatenate([self.nodes, np.empty_like(self.nodes)])
        self.nodes[len(self)] = x
        self.parents.append(parent)
        return len(self) - 1

    def add_chain(self, xs: np.ndarray, parent: int) -> int:
        """Add `xs` (N, n), each the child of the one before, the first of `parent`: the last's index."""
        first = len(self)
        while first + len(xs) > len(self.nodes):
            self.nodes = np.concatenate([self.nodes, np.empty_like(self.nodes)])
        self.nodes[first : first + len(xs)] = xs
        self.parents += [parent, *range(first, first + len(xs) - 1)][: len(xs)]
        return len(self) - 1 if len(xs) else parent

    def branch(self, index: int) -> list[np.ndarray]:
        """States from the root to node `index`."""
        out = []
        while index >= 0:
            out.append(self.nodes[index].copy())
            index = self.parents[index]
        return out[::-1]


class _Search:
    def __init__(self, problem: BandProblem, counters: Counters) -> None:
        self.p, self._counters = problem, counters
        self.low, self.high = problem.bounds
        if problem.walker is not None:
            problem.walker.counts[:] = 0  # none left from a search that ended in an error

    @property
    def counters(self) -> Counters:
        """The calls counted, the compiled walker's too (moved in when asked: ~1.5 us a move)."""
        self._tally()
        return self._counters

    def project(self, x: np.ndarray) -> np.ndarray | None:
        """x moved into every band (margin <= -accept), or None if Newton does not get there."""
        p = self.p
        if not p.constrained:
            return x
        if p.walker is not None:
            return p.walker.project(x, p.offset, p.accept)
        self._counters.function += 1
        margins = p.margins(x)
        for _ in range(NEWTON_ITERATIONS):
            if max(margins.tolist()) <= -p.accept:  # a Python max: numpy's costs ~2 us on a few rows
                return x
            self._counters.jacobian += 1
            margins, grads = p.gradients(x)
            # Rows near their boundary join the step too, so that fixing one does not push
            # another out (no zig-zag between two bands).
            active = margins > -p.offset
            x = x - _min_norm_step(grads[active], margins[active] + p.offset)
            if not ((x >= self.low).all() and (x <= self.high).all()):  # the methods: np.all costs ~2 us more
                return None
            self._counters.function += 1
            margins = p.margins(x)
        return None

    def sample(self, rng: np.random.Generator, tree: _Tree) -> np.ndarray:
        """A random target inside the bands where Newton gets one there: extensions towards it
        then slide along the bands instead of stopping where a band turns away. Most targets
        (LOCAL_SHARE) are near a node of the tree, in the IK branch it explores; uniform
        targets in the joint box mostly lie in other branches, where extensions stall."""
        if rng.random() < LOCAL_SHARE:
            x = tree.nodes[rng.integers(len(tree))] + rng.normal(0.0, LOCAL_SPREAD, len(self.low))
            np.minimum(np.maximum(x, self.low, out=x), self.high, out=x)  # np.clip's values, ~3 us sooner
        else:
            x = rng.uniform(self.low, self.high)
        inside = self.project(x)  # (a copy, or x untouched)
        return x if inside is None else inside

    def valid(self, x: np.ndarray) -> bool:
        """Collision free (projected states are inside every band already)."""
        self._counters.validity += 1
        return self.p.collision_free(x)

    def extend(self, tree: _Tree, index: int, target: np.ndarray, max_steps: int) -> tuple[int, bool]:
        """Constrained extension from node `index` towards `target`: (last node, reached)."""
        if self.p.walker is not None:
            return self._walked(tree, index, target, max_steps)
        return self._stepped(tree, index, target, max_steps)

    def _stepped(self, tree: _Tree, index: int, target: np.ndarray, max_steps: int) -> tuple[int, bool]:
        """`extend` in Python, a step at a time."""
        x = tree.nodes[index].copy()
        delta = self.p.delta
        ahead = target - x
        distance = norm(ahead)
        for _ in range(max_steps):
            if distance <= 1e-9:
                return index, True
            step = target if distance <= delta else x + ahead * (delta / distance)
            moved = self.project(step)
            if moved is None:
                return index, False
            ahead = target - moved
            new_distance = norm(ahead)
            # No progress, or projection threw the state far from the step: blocked. (A step
            # that needed no projection is the step itself, at most delta from x.)
            if new_distance >= distance - 1e-6 or (moved is not step and norm(moved - x) > 2.0 * delta):
                return index, False
            if not self.valid(moved):
                return index, False
            index = tree.add(moved, index)
            x, distance = moved, new_distance
            if distance <= 1e-6:
                return index, True
        return index, False

    def _walked(self, tree: _Tree, index: int, target: np.ndarray, max_steps: int) -> tuple[int, bool]:
        """`extend` by the compiled walk (band_kernels.walk), step for step the Python loop's:
        the states the certifier clears join the tree in one go, one it proves in collision
        ends the walk; a state it cannot clear is asked of the collision checker, as the loop
        asks every state, and the walk goes on from it if it is free. Where the checker has no
        compiled verdict, the Python loop."""
        p = self.p
        certifier = p.certifier(tree.nodes[index])
        if certifier is None:
            return self._stepped(tree, index, target, max_steps)
        bands = (p.offset, p.accept) if p.constrained else None
        while max_steps > 0:
            states, code, distance, unsure = p.walker.walk(
                tree.nodes[index], target, p.delta, max_steps, bands, certifier
            )
            self._counters.validity += len(states) + (code == COLLIDED)  # the collision, asked as `valid` asks
            index = tree.add_chain(states, index)
            if code != UNSURE:
                return index, code == REACHED
            max_steps -= len(states) + 1
            if not self.valid(unsure):
                return index, False
            index = tree.add(unsure, index)
            if distance <= 1e-6:
                return index, True
        return index, False

    def _tally(self) -> None:
        """Move the walker's counts of margins and gradients asked into the counters."""
        if self.p.walker is None:
            return
        counts = self.p.walker.counts
        self._counters.function += int(counts[0])
        self._counters.jacobian += int(counts[1])
        counts[:] = 0


def plan_in_bands(
    problem: BandProblem, start: np.ndarray, goal: np.ndarray, time_limit: float, seed: int | None, max_steps: int = 10
) -> SearchResult:
    """Bidirectional constrained search; the path's consecutive states are <= ~delta apart.
    With the compiled walker, the whole loop compiled (`loop_kernels.searched`), step for step this one."""
    if problem.walker is not None:
        from hriplan.planner.search.loop_kernels import searched

        result = searched(problem, start, goal, time_limit, seed, max_steps)
        if result is not None:
            return result
    rng = np.random.default_rng(seed)
    search = _Search(problem, Counters())
    started = time.perf_counter()
    nearest = None if problem.walker is None else problem.walker.nearest
    trees = tuple(_Tree(np.asarray(end, dtype=float), nearest=nearest) for end in (start, goal))
    a, b = trees
    # Try the direct connection first: many band problems are a short slide along the band.
    target = b.nodes[0]
    while time.perf_counter() - started < time_limit:
        size = len(a)
        reached_a, _ = search.extend(a, a.nearest(target), target, max_steps)
        target = search.sample(rng, b)
        if len(a) == size:
            a, b = b, a
            continue
        joint = a.nodes[reached_a]
        reached_b, connected = search.extend(b, b.nearest(joint), joint, 10 * max_steps)
        if connected:
            path_a, path_b = a.branch(reached_a), b.branch(reached_b)
            path = path_a + path_b[::-1][1:] if a is trees[0] else path_b + path_a[::-1][1:]
            # Shorten with as much work as the search took (at least SHORTCUT_MIN_STEPS steps):
            # a bounded share of the plan, counted in steps so that a seed gives one path.
            checked = search.counters.validity
            budget = checked + max(SHORTCUT_MIN_STEPS, checked)
            path = shortcut(search, path, rng, budget, deadline=started + time_limit)
            return searched_result(problem, path, search.counters)
        a, b = b, a
    return searched_result(problem, None, search.counters)


def searched_result(problem: BandProblem, path: list[np.ndarray] | None, counters: Counters) -> SearchResult:
    """A search's result, however it ran: SOLVED with `path`, or TIMEOUT where it found none."""
    space = "projected" if problem.constrained else "real_vector"
    if path is None:
        return SearchResult(Status.TIMEOUT, [], space, "no exact solution within the time limit", counters)
    return SearchResult(Status.SOLVED, path, space, "", counters)


def shortcut(
    search: _Search, path: list[np.ndarray], rng: np.random.Generator, budget: int, deadline: float, attempts: int = 60
) -> list[np.ndarray]:
    """Replace random sub-paths by constrained extensions between their ends while they shorten
    the path (each replacement is a chain of projected, valid states like the trees' edges),
    until `budget` collision checks have been spent.
    A sub-path already within 2 % of the straight line between its ends is not tried: no
    replacement can gain more, and trying costs a projected walk. Where no sub-path is left to
    try (`_settled`), the attempts stop: each would only draw its pair and go on (~8 us each, 60
    of them: most of a short plan's shortcut), and nothing draws from `rng` after them."""
    steps = _steps(path)
    settled = _settled(path, steps)
    for _ in range(attempts):
        if settled or len(path) < 3 or search.counters.validity >= budget or time.perf_counter() > deadline:
            break
        i, j = _pair(rng, len(path))
        if j - i < 2:
            continue
        old = float(steps[i:j].sum())  # _length(path[i : j + 1]), to the bit
        across = path[j] - path[i]
        if old <= 1.02 * norm(across) + 1e-3:  # np.linalg.norm's arithmetic
            continue
        tree = _Tree(path[i])
        end, reached = search.extend(tree, 0, path[j], max_steps=int(math.ceil(old / search.p.delta)) + 2)
        if not reached:
            continue
        middle = tree.nodes[: end + 1].copy()  # an extension from the root grows one chain, in order
        if _length(middle) < old - 1e-6:
            path = path[:i] + list(middle[:-1]) + path[j:]
            steps = _steps(path)
            settled = _settled(path, steps)
    return path


def _pair(rng: np.random.Generator, n: int) -> tuple[int, int]:
    """sorted(rng.choice(n, 2, replace=False)), the same draws (numpy's Floyd sampling, then its
    shuffle's one draw, which sorting undoes) at ~3 us instead of ~5.5 (60 a shortcut)."""
    i, j = int(rng.integers(0, n - 1)), int(rng.integers(0, n))
    rng.integers(0, 2)
    if j == i:
        j = n - 1
    return (i, j) if i < j else (j, i)


def _settled(path: list[np.ndarray], steps: np.ndarray) -> bool:
    """True if `shortcut` would try no sub-path of `path` (of two steps or more): each within 2 %
    (+1 mm) of the straight line between its ends, by a margin of 1e-9 over the rounding apart of
    these sums and norms from the loop's own. Asked of short paths only (pairs grow as n^2)."""
    if len(path) > SETTLED_STATES:
        return False
    states = np.asarray(path)
    lengths = np.concatenate([[0.0], np.cumsum(steps)])
    i, j = np.triu_indices(len(path), 2)
    across = np.sqrt(np.einsum("ij,ij->i", states[j] - states[i], states[j] - states[i]))
    return bool(np.all(lengths[j] - lengths[i] <= 1.02 * across + 1e-3 - 1e-9))


def _length(states: list[np.ndarray] | np.ndarray) -> float:
    return float(_steps(states).sum())


def _steps(states: list[np.ndarray] | np.ndarray) -> np.ndarray:
    """The length of each step between consecutive states: a step's is the same whichever
    sub-path it is measured in, so `shortcut` sums a sub-path's from its path's, made once a
    path, not at every attempt (60 a shortcut, ~15 us each)."""
    return np.linalg.norm(np.diff(np.array(states), axis=0), axis=1)
