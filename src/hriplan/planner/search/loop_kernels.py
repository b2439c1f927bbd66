"""CBiRRT's whole search compiled (numba): the trees, the targets drawn, the extensions and the
shortcut, `cbirrt.plan_in_bands`'s loop step for step, in one call.

Why: with each extension walked in one call (`band_kernels.walk`), the loop around the walks
cost more than they did: ~4 ms of Python in the UR5 upright-and-box plan's ~7 ms search (a
walk's call ~4 us of dispatch and bookkeeping, ~200 a plan; a target ~10 us, the shortcut's
attempts ~10 us each). The loop here draws from the same numpy generator (numba's port of its
algorithms: the same numbers for `random`, `integers`, `normal`, `uniform`; passing it costs
~7 us, once a search) and does the loop's arithmetic in its order, numpy's pairwise sums
included, so a seed grows the same trees and returns the same path as the Python loop with the
compiled walk (tests/planner/test_loop_kernels.py).

Python is asked back (numba's object mode, ~1.5 us) for what only it can do: the clock, once an
iteration and an attempt of the shortcut, and coal, about a state the certifier can neither
clear nor prove in collision (`band_kernels.walk`'s UNSURE; ~15 a UR5 plan, ~330 a peg-in-hole
plan): `collision_free` of the calling thread's search (`asking`), whose certifier gives the
verdict the walk kept for that state (`certifier_kernels.verdict_one`) rather than making it
again.
"""

from __future__ import annotations

import contextlib
import math
import threading
import time
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING

import numpy as np
from numba import objmode

from hriplan.planner.constraints import compiled, geometry
from hriplan.planner.search import band_kernels, tree_kernels
from hriplan.planner.search.band_kernels import project, walk
from hriplan.planner.search.cbirrt import (
    COLLIDED,
    LOCAL_SHARE,
    LOCAL_SPREAD,
    REACHED,
    SETTLED_STATES,
    SHORTCUT_MIN_STEPS,
    UNSURE,
    searched_result,
)
from hriplan.planner.search.result import Counters, SearchResult
from hriplan.planner.search.tree_kernels import BLOCK, boxed, boxes_room, nearest_boxed
from hriplan.robots import certifier_kernels, pairwise_sums
from hriplan.robots.kernel_cache import njit_keyed
from hriplan.robots.pairwise_sums import pairwise_sum

if TYPE_CHECKING:
    from hriplan.planner.search.cbirrt import BandProblem

_keyed = njit_keyed(
    band_kernels, tree_kernels, geometry, compiled, certifier_kernels, pairwise_sums, nogil=False
)  # it asks Python back
SOLVED, TIMEOUT = 0, 1
_CAPACITY = 4096  # a tree's first rows (doubled when full), as cbirrt._Tree's
_ATTEMPTS = 60  # cbirrt.shortcut's
_asked = threading.local()


@contextlib.contextmanager
def asking(collision_free: Callable[[np.ndarray], bool]) -> Iterator[None]:
    """`collision_free` answers the compiled search's questions in this thread while it runs."""
    before = getattr(_asked, "collision_free", None)
    _asked.collision_free = collision_free
    try:
        yield
    finally:
        _asked.collision_free = before


def _free(x: np.ndarray) -> bool:
    return bool(_asked.collision_free(x))


def _now() -> float:
    return time.perf_counter()


@_keyed
def _asked_free(x) -> bool:
    with objmode(free="boolean"):
        free = _free(x)
    return free


@_keyed
def _clock() -> float:
    with objmode(now="float64"):
        now = _now()
    return now


def load_callbacks() -> None:
    """Compile the blocks where the compiled search asks Python (numba compiles an object-mode
    block at its first run in each process, ~30 ms, and caches none): at load, not in the first
    plan that asks about a state (`planner/kernels.py`)."""
    with asking(lambda x: True):
        _asked_free(np.zeros(1))
    _clock()


@_keyed
def steps_of(states):
    """The length of each step between consecutive rows of `states`, as `cbirrt._steps`."""
    out = np.empty(max(states.shape[0] - 1, 0))
    for r in range(out.shape[0]):
        s = 0.0
        for c in range(states.shape[1]):
            d = states[r + 1, c] - states[r, c]
            s += d * d
        out[r] = math.sqrt(s)
    return out


@_keyed
def _distance(a, b) -> float:
    s = 0.0
    for c in range(a.shape[0]):
        d = b[c] - a[c]
        s += d * d
    return math.sqrt(s)


@_keyed
def settled(path, steps) -> bool:
    """`cbirrt._settled`: every sub-path of two steps or more within 2 % (+1 mm) of its chord,
    by a 1e-9 margin; paths of more than SETTLED_STATES states are not asked."""
    n = path.shape[0]
    if n > SETTLED_STATES:
        return False
    lengths = np.zeros(n)
    for k in range(1, n):
        lengths[k] = lengths[k - 1] + steps[k - 1]
    for i in range(n):
        for j in range(i + 2, n):
            if not lengths[j] - lengths[i] <= 1.02 * _distance(path[i], path[j]) + 1e-3 - 1e-9:
                return False
    return True


@_keyed
def pair(rng, n):
    """`cbirrt._pair`: sorted(rng.choice(n, 2, replace=False)), the same draws."""
    i = rng.integers(0, n - 1)
    j = rng.integers(0, n)
    rng.integers(0, 2)
    if j == i:
        j = n - 1
    return (i, j) if i < j else (j, i)


@_keyed
def _room(nodes, parents, count, more):
    """The tree's arrays with room for `more` rows after `count` (doubled as often as needed)."""
    size = nodes.shape[0]
    if count + more <= size:
        return nodes, parents
    while count + more > size:
        size *= 2
    grown, linked = np.empty((size, nodes.shape[1])), np.empty(size, dtype=np.int64)
    grown[:count] = nodes[:count]
    linked[:count] = parents[:count]
    return grown, linked


@_keyed
def _extend(nodes, parents, count, index, target, max_steps, walker, tally):
    """`cbirrt._Search._walked` on a tree held as (nodes, parents, count): the walked states
    join as a chain, a state the certifier leaves is asked of `collision_free` (tally[0]: the
    states checked). Returns the tree's arrays and count, the last node, reached."""
    delta, constrained, bounds, offset, accept, q, slots, joints, terms, work, counts, certifier = walker
    while max_steps > 0:
        nodes, parents = _room(nodes, parents, count, max_steps + 1)
        walked, code, distance = walk(
            nodes[index], target, delta, constrained, bounds, offset, accept, q, slots, joints, terms, work, counts,
            certifier, nodes[count : count + max_steps],
        )  # fmt: skip
        tally[0] += walked + (1 if code == COLLIDED else 0)
        if walked > 0:
            parents[count] = index
            for k in range(1, walked):
                parents[count + k] = count + k - 1
            index = count + walked - 1
            count += walked
        if code != UNSURE:
            return nodes, parents, count, index, code == REACHED
        max_steps -= walked + 1
        tally[0] += 1
        if not _asked_free(nodes[count]):  # the state the walk could not clear, written there
            return nodes, parents, count, index, False
        parents[count] = index
        index = count
        count += 1
        if distance <= 1e-6:
            return nodes, parents, count, index, True
    return nodes, parents, count, index, False


@_keyed
def _sample(rng, nodes, count, walker):
    """`cbirrt._Search.sample`: a target near a node of the tree (LOCAL_SHARE) or anywhere in
    the joint box, projected into the bands where Newton gets it there."""
    delta, constrained, bounds, offset, accept, q, slots, joints, terms, work, counts, certifier = walker
    low, high = bounds
    x = np.empty(low.shape[0])
    if rng.random() < LOCAL_SHARE:
        node = rng.integers(0, count)
        for c in range(x.shape[0]):
            x[c] = nodes[node, c] + rng.normal(0.0, LOCAL_SPREAD)
        for c in range(x.shape[0]):
            x[c] = min(max(x[c], low[c]), high[c])
    else:
        for c in range(x.shape[0]):
            x[c] = rng.uniform(low[c], high[c])
    if constrained:
        inside = x.copy()
        if project(inside, low, high, offset, accept, q, slots, joints, terms, work, counts):
            return inside
    return x


@_keyed
def _branch(nodes, parents, index):
    """The states from the root to node `index`, as `cbirrt._Tree.branch`."""
    count, k = 0, index
    while k >= 0:
        count += 1
        k = parents[k]
    out = np.empty((count, nodes.shape[1]))
    k = index
    for r in range(count - 1, -1, -1):
        out[r] = nodes[k]
        k = parents[k]
    return out


@_keyed
def _joined(first, second):
    """`first` then `second` reversed without its last state (the connection, `first`'s last)."""
    out = np.empty((first.shape[0] + second.shape[0] - 1, first.shape[1]))
    out[: first.shape[0]] = first
    for r in range(second.shape[0] - 1):
        out[first.shape[0] + r] = second[second.shape[0] - 2 - r]
    return out


@_keyed
def shortcut(path, rng, budget, deadline, walker, tally):
    """`cbirrt.shortcut` with the compiled extension: random sub-paths replaced by walks between
    their ends while they shorten the path, until `budget` states checked or `deadline`."""
    delta = walker[0]
    steps = steps_of(path)
    done = settled(path, steps)
    for _ in range(_ATTEMPTS):
        now = _clock()
        if done or path.shape[0] < 3 or tally[0] >= budget or now > deadline:
            break
        i, j = pair(rng, path.shape[0])
        if j - i < 2:
            continue
        old = pairwise_sum(steps, i, j - i)
        if old <= 1.02 * _distance(path[i], path[j]) + 1e-3:
            continue
        nodes, parents = np.empty((_CAPACITY, path.shape[1])), np.empty(_CAPACITY, dtype=np.int64)
        nodes[0], parents[0] = path[i], -1
        reach = int(math.ceil(old / delta)) + 2
        nodes, parents, _, end, reached = _extend(nodes, parents, 1, 0, path[j].copy(), reach, walker, tally)
        if not reached:
            continue
        middle = nodes[: end + 1]  # an extension from the root grows one chain, in order
        middle_steps = steps_of(middle)
        if pairwise_sum(middle_steps, 0, middle_steps.shape[0]) < old - 1e-6:
            shorter = np.empty((i + end + path.shape[0] - j, path.shape[1]))
            shorter[:i] = path[:i]
            shorter[i : i + end] = middle[:end]
            shorter[i + end :] = path[j:]
            path = shorter
            steps = steps_of(path)
            done = settled(path, steps)
    return path


@_keyed
def search(start, goal, rng, time_limit, max_steps, walker, tally):
    """`cbirrt.plan_in_bands`'s loop: (SOLVED, the shortened path) or (TIMEOUT, no states).
    Each tree keeps its runs' boxes for its nearest node (`tree_kernels`). Its clock starts
    here, once the code is loaded: a first call that compiles it (a cache made stale) would
    otherwise spend the time limit compiling and plan differently."""
    started = _clock()
    n = start.shape[0]
    a_nodes, a_parents = np.empty((_CAPACITY, n)), np.empty(_CAPACITY, dtype=np.int64)
    b_nodes, b_parents = np.empty((_CAPACITY, n)), np.empty(_CAPACITY, dtype=np.int64)
    a_nodes[0], a_parents[0], b_nodes[0], b_parents[0] = start, -1, goal, -1
    a_low, a_high = np.empty((n, _CAPACITY // BLOCK)), np.empty((n, _CAPACITY // BLOCK))
    b_low, b_high = np.empty((n, _CAPACITY // BLOCK)), np.empty((n, _CAPACITY // BLOCK))
    boxed(a_nodes, 0, 1, a_low, a_high)
    boxed(b_nodes, 0, 1, b_low, b_high)
    a_count, b_count, a_first = 1, 1, True
    target = goal.copy()
    while _clock() - started < time_limit:
        size = a_count
        near = nearest_boxed(a_nodes, a_count, target, a_low, a_high)
        a_nodes, a_parents, a_count, reached_a, _ = _extend(
            a_nodes, a_parents, a_count, near, target, max_steps, walker, tally
        )
        a_low, a_high = boxes_room(a_low, a_high, a_count)
        boxed(a_nodes, size, a_count, a_low, a_high)
        target = _sample(rng, b_nodes, b_count, walker)
        if a_count != size:
            joint = a_nodes[reached_a].copy()
            near = nearest_boxed(b_nodes, b_count, joint, b_low, b_high)
            grown = b_count
            b_nodes, b_parents, b_count, reached_b, connected = _extend(
                b_nodes, b_parents, b_count, near, joint, 10 * max_steps, walker, tally
            )
            b_low, b_high = boxes_room(b_low, b_high, b_count)
            boxed(b_nodes, grown, b_count, b_low, b_high)
            if connected:
                path_a, path_b = _branch(a_nodes, a_parents, reached_a), _branch(b_nodes, b_parents, reached_b)
                path = _joined(path_a, path_b) if a_first else _joined(path_b, path_a)
                checked = tally[0]
                budget = checked + max(SHORTCUT_MIN_STEPS, checked)
                return SOLVED, shortcut(path, rng, budget, started + time_limit, walker, tally)
        a_nodes, a_parents, a_count, b_nodes, b_parents, b_count = (
            b_nodes, b_parents, b_count, a_nodes, a_parents, a_count
        )  # fmt: skip
        a_low, a_high, b_low, b_high = b_low, b_high, a_low, a_high
        a_first = not a_first
    return TIMEOUT, np.empty((0, n))


def searched(
    problem: BandProblem, start: np.ndarray, goal: np.ndarray, time_limit: float, seed: int | None, max_steps: int
) -> SearchResult | None:
    """`cbirrt.plan_in_bands` by the compiled loop, or None where it must stay in Python: no
    compiled walker, or no compiled verdict from the checker (a pair held still touching)."""
    certifier = problem.certifier(start) if problem.walker is not None else None
    if certifier is None:
        return None
    rng = np.random.default_rng(seed)
    walker = problem.walker.arguments(problem.delta, problem.constrained, problem.offset, problem.accept, certifier)
    problem.walker.counts[:] = 0
    tally = np.zeros(1, dtype=np.int64)
    with asking(problem.collision_free):
        code, path = search(
            np.ascontiguousarray(start, dtype=float),
            np.ascontiguousarray(goal, dtype=float),
            rng,
            float(time_limit),
            max_steps,
            walker,
            tally,
        )
    counts = problem.walker.counts
    counters = Counters(int(counts[0]), int(counts[1]), int(tally[0]))
    counts[:] = 0
    return searched_result(problem, list(path) if code == SOLVED else None, counters)
