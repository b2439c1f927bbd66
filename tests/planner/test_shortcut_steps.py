"""cbirrt.shortcut sums a sub-path's length from its path's step lengths, made again whenever a
replacement changes the path: it shortens a path as measuring every sub-path afresh did, to the bit."""

import math
from types import SimpleNamespace
from unittest import mock

import numpy as np
import pytest

from hriplan.planner.search import cbirrt
from hriplan.planner.search.cbirrt import SETTLED_STATES, _length, _pair, _settled, _steps, _Tree, shortcut
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


def _short_path_both_ways(seed: int) -> int:
    """A short path, nearly straight or not, shortened by `shortcut` and by the reference: the
    same path and the same walks made; how many pairs `shortcut` drew."""
    rng = np.random.default_rng(seed)
    line = np.linspace(0.0, 1.0, 3 + seed)[:, None] * rng.normal(size=6)
    path = list(line + rng.normal(0.0, 0.002 if seed % 2 else 0.05, line.shape))
    kept, afresh = _Straight(0.05), _Straight(0.05)
    draws = []
    with mock.patch.object(cbirrt, "_pair", side_effect=lambda rng, n: draws.append(n) or _pair(rng, n)):
        shortened = shortcut(kept, path, np.random.default_rng(seed), 10**9, math.inf)
    reference = _measured_afresh(afresh, path, np.random.default_rng(seed))
    assert len(shortened) == len(reference) and all(np.array_equal(a, b) for a, b in zip(shortened, reference))
    assert kept.counters.validity == afresh.counters.validity
    return len(draws)


@pytest.mark.parametrize("seed", range(12))
def test_a_short_path_left_with_nothing_to_shorten_stops_as_the_attempts_would_have_ended(seed):
    """The attempts stop once no sub-path is left to try; the path and the walks made are those
    of all 60 attempts."""
    _short_path_both_ways(seed)


def test_a_pair_is_the_one_numpys_choice_draws_and_leaves_the_generator_as_it_does():
    """Pairs of 3 to 5000 states, between other draws (numpy keeps half of a 64-bit draw for the
    next 32-bit one): the same pair as sorted(choice(n, 2, replace=False)), the same state after."""
    for seed in range(200):
        ours, numpys = np.random.default_rng(seed), np.random.default_rng(seed)
        for k in range(25):
            n = 3 + k
            if k % 2:
                n = int(numpys.integers(3, 5000))
                assert ours.integers(3, 5000) == n
            if k % 3 == 0:
                assert ours.integers(0, 7) == numpys.integers(0, 7)
            assert _pair(ours, n) == tuple(int(x) for x in sorted(numpys.choice(n, size=2, replace=False)))
        assert ours.bit_generator.state == numpys.bit_generator.state


def test_the_attempts_stop_once_a_path_is_settled():
    """Short paths settled from the start (seed 1) or after one or more replacements (0, 2, 10):
    fewer than the 60 attempts are drawn."""
    assert [_short_path_both_ways(seed) < 60 for seed in (0, 1, 2, 10)] == [True] * 4


def test_a_sub_path_just_past_the_threshold_is_not_settled():
    """Three states whose middle makes the path 5e-7 m longer than the loop passes over: it
    would try that sub-path, so the path is not settled."""
    length = 0.5
    half = (1.02 * length + 1e-3 + 5e-7) / 2.0
    path = [np.zeros(6), np.array([length / 2, math.sqrt(half**2 - (length / 2) ** 2), 0, 0, 0, 0]), np.zeros(6)]
    path[2][0] = length
    steps = _steps(path)
    assert float(steps.sum()) > 1.02 * float(np.linalg.norm(path[2] - path[0])) + 1e-3  # the loop tries it
    assert not _settled(path, steps)


def test_settled_means_every_sub_path_would_be_passed_over(rng):
    """`_settled` against the loop's own test, sub-path by sub-path, on paths with one detour of
    a size around the test's threshold (so that both answers occur)."""
    answers = set()
    for _ in range(400):
        n = int(rng.integers(3, 12))
        path = list(np.linspace(0.0, 1.0, n)[:, None] * rng.normal(size=6))
        at = int(rng.integers(1, n - 1))
        path[at] = path[at] + rng.normal(0.0, 10 ** rng.uniform(-4, -1), 6)
        steps = _steps(path)
        passed_over = all(
            float(steps[i:j].sum()) <= 1.02 * float(np.linalg.norm(path[j] - path[i])) + 1e-3
            for i in range(n)
            for j in range(i + 2, n)
        )
        settled = _settled(path, steps)
        assert passed_over or not settled
        answers.add((settled, passed_over))
    assert {(True, True), (False, False)} <= answers
    assert not _settled([np.zeros(6)] * (SETTLED_STATES + 1), np.zeros(SETTLED_STATES))  # too long: not asked
