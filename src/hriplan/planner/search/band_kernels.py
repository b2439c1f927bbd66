"""CBiRRT's inner loop compiled (numba): the projection into the bands and an extension's walk.

Why: an extension step in Python (`cbirrt._Search.extend`) costs ~15-20 us of loop around ~3 us
of compiled margins, gradients and collision verdicts (benchmarks/REPORT-kernels.md). Here one
call walks up to a chunk of steps, each projected by the same minimum-norm Newton steps, with
the constraint terms compiled from geometry.py's source (`constraints/compiled.py`) and the
joints placed by the certifier's kinematics; the caller then asks the collision checker about
the walked states at once and keeps those before the first in collision, which is where the
Python loop would have stopped. Only collision is left to Python (coal, held objects).

The arithmetic is the Python loop's, written in scalars: its sums run in another order than
numpy's, so the states agree to ~1e-15 and a seed can end on another (equally validated) path
than with the kernels off, as with the compiled margins.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from hriplan.planner.constraints import compiled, geometry
from hriplan.planner.constraints.compiled import rows_gradients, term_margins
from hriplan.planner.search.cbirrt import BLOCKED, COLLIDED, MORE, NEWTON_ITERATIONS, REACHED, UNSURE
from hriplan.robots import certifier_kernels
from hriplan.robots.certifier_kernels import TOUCHING, place_joints, same_joints, verdict_of, verdict_views
from hriplan.robots.kernel_cache import njit_keyed

if TYPE_CHECKING:
    from hriplan.planner.constraints.compiled import CompiledTerms
    from hriplan.planner.constraints.evaluator import ConstraintEvaluator

_keyed = njit_keyed(geometry, compiled, certifier_kernels)


@_keyed
def _placed(x, q, slots, joint_rows, joint_ints, rotation, origin) -> None:
    """The joints' world frames at the full configuration: `q` with the planned joints at `x`."""
    for c in range(slots.shape[0]):
        q[slots[c]] = x[c]
    place_joints(q, joint_rows, joint_ints, rotation[0], origin[0])


@_keyed
def _min_norm_step(grads, rows, active, count, step, system) -> None:
    """step = the smallest dx with grads[a] dx = rows[a] over the `count` active rows `a`: one or
    two rows in closed form (cbirrt._min_norm_step's), more by the normal equations
    (grads grads^T + 1e-9 I) l = rows, solved by elimination with partial pivoting in the
    scratch `system` (at least count x count + 1)."""
    n = step.shape[0]
    if count == 1:
        a = active[0]
        gg = 0.0
        for c in range(n):
            gg += grads[a, c] * grads[a, c]
        scale = rows[a] / max(gg, 1e-12)
        for c in range(n):
            step[c] = grads[a, c] * scale
        return
    if count == 2:
        a, b = active[0], active[1]
        aa, ab, bb = 0.0, 0.0, 0.0
        for c in range(n):
            aa += grads[a, c] * grads[a, c]
            ab += grads[a, c] * grads[b, c]
            bb += grads[b, c] * grads[b, c]
        aa, bb = aa + 1e-9, bb + 1e-9
        det = aa * bb - ab * ab
        la = (bb * rows[a] - ab * rows[b]) / det
        lb = (aa * rows[b] - ab * rows[a]) / det
        for c in range(n):
            step[c] = la * grads[a, c] + lb * grads[b, c]
        return
    for i in range(count):
        for j in range(count):
            s = 0.0
            for c in range(n):
                s += grads[active[i], c] * grads[active[j], c]
            system[i, j] = s + (1e-9 if i == j else 0.0)
        system[i, count] = rows[active[i]]
    for i in range(count):
        pivot = i
        for r in range(i + 1, count):
            if abs(system[r, i]) > abs(system[pivot, i]):
                pivot = r
        for j in range(count + 1):
            system[i, j], system[pivot, j] = system[pivot, j], system[i, j]
        for r in range(i + 1, count):
            f = system[r, i] / system[i, i]
            for j in range(i, count + 1):
                system[r, j] -= f * system[i, j]
    for i in range(count - 1, -1, -1):
        s = system[i, count]
        for j in range(i + 1, count):
            s -= system[i, j] * system[j, count]
        system[i, count] = s / system[i, i]
    for c in range(n):
        s = 0.0
        for i in range(count):
            s += grads[active[i], c] * system[i, count]
        step[c] = s


@_keyed
def project(x, low, high, offset, accept, q, slots, joints, terms, work, counts) -> bool:
    """Move `x` in place into every band (each margin <= -accept) by minimum-norm Newton steps on
    the rows within `offset` of their band, as `cbirrt._Search.project`: False where it leaves
    the joint bounds or is not inside after NEWTON_ITERATIONS.
    joints: (rows, ints, rotation, origin) of `place_joints`; terms: (ints, floats, columns,
    axes, carries) of `term_gradients`; work: (margins (1, K), gradients (K, n), active (K,),
    step (n,), the normal equations (K, K + 1)); counts[0] margins asked, counts[1] gradients."""
    joint_rows, joint_ints, rotation, origin = joints
    ints, floats, columns, axes, carries = terms
    margins, grads, active, step, system = work
    counts[0] += 1
    _placed(x, q, slots, joint_rows, joint_ints, rotation, origin)
    term_margins(rotation, origin, ints, floats, margins)
    for _ in range(NEWTON_ITERATIONS):
        worst = -math.inf
        for k in range(margins.shape[1]):
            worst = max(worst, margins[0, k])
        if worst <= -accept:
            return True
        counts[1] += 1
        count = 0
        for k in range(margins.shape[1]):
            if margins[0, k] > -offset:
                active[count] = k
                count += 1
                margins[0, k] += offset
        # The margins are those of the joints just placed: the gradients of the active rows only.
        rows_gradients(rotation[0], origin[0], ints, floats, columns, axes, carries, active, count, grads)
        _min_norm_step(grads, margins[0], active, count, step, system)
        inside = True
        for c in range(x.shape[0]):
            x[c] -= step[c]
            inside = inside and low[c] <= x[c] <= high[c]
        if not inside:
            return False
        counts[0] += 1
        _placed(x, q, slots, joint_rows, joint_ints, rotation, origin)
        term_margins(rotation, origin, ints, floats, margins)
    return False


@_keyed
def walk(
    start, target, delta, constrained, bounds, offset, accept, q, slots, joints, terms, work, counts, certifier, out
):
    """Steps of `delta` from `start` towards `target`, as `cbirrt._Search.extend` takes them:
    each projected into the bands (when `constrained`) and certified collision free
    (`certifier_kernels.verdict_of` on the certifier's arrays `certifier`) goes to out[count].
    Returns (count, how it ended, the distance left from the last state to the target): REACHED
    at the target, BLOCKED where a step cannot be projected, makes no progress or is thrown more
    than 2 delta, COLLIDED where the certifier proves a step in collision (as the checker would
    find it), MORE after out.shape[0] steps, UNSURE where the certifier cannot clear a step:
    that state is out[count], for the caller to ask the collision checker."""
    low, high = bounds
    floats, ints = certifier
    joint_rows, joint_ints, rotation, origin = joints
    # A projected step's joints are placed (its margins): the verdict takes their frames.
    placed = constrained and same_joints(floats, ints, joint_rows, joint_ints)
    # The certifier's arrays unpacked once for the walk's steps (~0.35 us a step otherwise).
    parts, scratch, left = verdict_views(floats, ints)
    n = start.shape[0]
    x = start.copy()
    distance = 0.0
    for c in range(n):
        distance += (target[c] - x[c]) ** 2
    distance = math.sqrt(distance)
    for count in range(out.shape[0]):
        if distance <= 1e-9:
            return count, REACHED, distance
        step = out[count]
        if distance <= delta:
            step[:] = target
        else:
            scale = delta / distance
            for c in range(n):
                step[c] = x[c] + (target[c] - x[c]) * scale
        if constrained and not project(step, low, high, offset, accept, q, slots, joints, terms, work, counts):
            return count, BLOCKED, distance
        new_distance, jump = 0.0, 0.0
        for c in range(n):
            new_distance += (target[c] - step[c]) ** 2
            jump += (step[c] - x[c]) ** 2
        new_distance = math.sqrt(new_distance)
        # (a step not projected is at most delta from x: the Python loop skips its jump test)
        if new_distance >= distance - 1e-6 or math.sqrt(jump) > 2.0 * delta:
            return count, BLOCKED, distance
        for c in range(n):
            q[slots[c]] = step[c]
        if placed:
            verdict = verdict_of(q, floats, ints, parts, scratch, left, (rotation[0], origin[0]))
        else:
            verdict = verdict_of(q, floats, ints, parts, scratch, left, None)
        if verdict == TOUCHING:
            return count, COLLIDED, distance
        if verdict != 0:
            return count, UNSURE, new_distance
        x[:] = step
        distance = new_distance
        if distance <= 1e-6:
            return count + 1, REACHED, distance
    return out.shape[0], MORE, distance


@_keyed
def nearest(nodes, count, x) -> int:
    """The index of the node among nodes[:count] nearest `x` (the first of equals)."""
    best, index = math.inf, 0
    for i in range(count):
        d = 0.0
        for c in range(x.shape[0]):
            d += (nodes[i, c] - x[c]) ** 2
        if d < best:
            best, index = d, i
    return index


class BandWalker:
    """The compiled projection and walk for one search: the evaluator's packed terms (none for
    a search without bands), its configuration for the joints not planned, the joint bounds.
    `counts` holds the margins and gradients asked since the caller last read them."""

    def __init__(self, terms: CompiledTerms, slots: np.ndarray, bounds: tuple[np.ndarray, np.ndarray]) -> None:
        self._terms, self._slots = terms, slots
        self._q = terms.base_configuration()
        self._bounds = tuple(np.ascontiguousarray(b, dtype=float) for b in bounds)
        k, n = terms.count, len(slots)
        self._work = (
            np.empty((1, k)),
            np.empty((k, n)),
            np.empty(k, dtype=np.int64),
            np.empty(n),
            np.empty((k, k + 1)),
        )
        self.counts = np.zeros(2, dtype=np.int64)

    @classmethod
    def of(cls, evaluator: ConstraintEvaluator, bounds: tuple[np.ndarray, np.ndarray]) -> BandWalker | None:
        """The walker of `evaluator`'s planned joints, or None where its terms or joints are not compiled."""
        terms = evaluator.compiled_terms()
        return None if terms is None else cls(terms, np.asarray(evaluator.idx, dtype=np.int64), bounds)

    def arguments(
        self, delta: float, constrained: bool, offset: float, accept: float, certifier: tuple[np.ndarray, np.ndarray]
    ) -> tuple:
        """What the compiled loop passes its walks and projections (`loop_kernels`), in `walk`'s order."""
        joints, terms = self._terms.kernel_arguments()
        q, slots, bounds, work, counts = self._q, self._slots, self._bounds, self._work, self.counts
        return (delta, constrained, bounds, offset, accept, q, slots, joints, terms, work, counts, certifier)

    @staticmethod
    def nearest(nodes: np.ndarray, count: int, x: np.ndarray) -> int:
        """The index of the node of nodes[:count] nearest `x` (`nearest`)."""
        return nearest(nodes, count, x)

    def project(self, x: np.ndarray, offset: float, accept: float) -> np.ndarray | None:
        """A copy of `x` moved into every band, or None (`project`)."""
        x = np.array(x, dtype=float)
        joints, terms = self._terms.kernel_arguments()
        low, high = self._bounds
        inside = project(x, low, high, offset, accept, self._q, self._slots, joints, terms, self._work, self.counts)
        return x if inside else None

    def walk(
        self,
        start: np.ndarray,
        target: np.ndarray,
        delta: float,
        steps: int,
        bands: tuple[float, float] | None,
        certifier: tuple[np.ndarray, np.ndarray],
    ) -> tuple[np.ndarray, int, float, np.ndarray]:
        """(the states walked, how the walk ended, the distance left, the state the certifier
        could not clear when UNSURE) from `start` towards `target`, at most `steps`, projected
        into the bands (offset, accept) unless `bands` is None (`walk`)."""
        out = np.empty((steps, len(self._slots)))
        joints, terms = self._terms.kernel_arguments()
        offset, accept = bands or (0.0, 0.0)
        count, code, distance = walk(
            np.ascontiguousarray(start, dtype=float),
            np.ascontiguousarray(target, dtype=float),
            delta,
            bands is not None,
            self._bounds,
            offset,
            accept,
            self._q,
            self._slots,
            joints,
            terms,
            self._work,
            self.counts,
            certifier,
            out,
        )
        return out[:count], code, distance, out[count] if code == UNSURE else out[:0]
