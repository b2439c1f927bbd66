"""cbirrt.shortcut sums a sub-path's length from its path's step lengths, made again whenever a
replacement changes the path: it shortens a path as measuring every sub-path afresh did, to the bit."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from hriplan.planner.search.cbirrt import _length, _Tree, shortcut
from hriplan.planner.search.result import Counters


class _Straight:
    """A search whose extensions walk straight to their target, `delta` a step, every state valid."""

    def __init__(self, delta: float) -> None:
        self.p, self.counters = SimpleNamespace(delta=delta), Counters()

    def extend(self, tree: _Tree, index: int, target: np.ndarray, max_steps: int) -> tuple[int, bool]:
        x = tree.nodes[index].copy()
        for _ in range(max_steps):
            self.counters.validity += 1
            ahead = target - x
            distance = float(np.linalg.norm(ahead))
            x = target if distance <= self.p.delta else x + ahead * (self.p.delta / distance)
            index = tree.add(x, index)
            if distance <= self.p.delta:
                return index, True
        return index, False


def _measured_afresh(search, path, rng, attempts=60):
    """The shortcut as it was before step lengths were kept: every sub-path measured when drawn."""
    for _ in range(attempts):
        if len(path) < 3:
            break
        i, j = sorted(rng.choice(len(path), size=2, replace=False))
        old = _length(path[i : j + 1])
        if j - i < 2 or old <= 1.02 * float(np.linalg.norm(path[j] - path[i])) + 1e-3:
            continue
        tree = _Tree(path[i])
        end, reached = search.extend(tree, 0, path[j], max_steps=int(math.ceil(old / search.p.delta)) + 2)
        if not reached:
            continue
        middle = tree.branch(end)
        if _length(middle) < old - 1e-6:
            path = path[:i] + middle[:-1] + path[j:]
    return path


@pytest.mark.parametrize("seed", range(6))
def test_a_shortened_path_is_the_one_measuring_every_sub_path_afresh_gives(seed):
    rng = np.random.default_rng(seed)
    path = list(np.cumsum(rng.normal(0.0, 0.1, (40, 6)), axis=0))
    kept = shortcut(_Straight(0.05), path, np.random.default_rng(seed), 10**9, math.inf)
    afresh = _measured_afresh(_Straight(0.05), path, np.random.default_rng(seed))
    assert _length(kept) < _length(path) and len(kept) == len(afresh)
    assert all(np.array_equal(a, b) for a, b in zip(kept, afresh))
