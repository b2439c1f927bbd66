"""CBiRRT's whole search compiled (planner/search/loop_kernels.py) against the Python loop it
replaces (cbirrt.plan_in_bands with the compiled walk): numpy's norms to the bit, the
generator's draws in step, the same targets, and on three scenarios the same paths, bit for bit,
with the same counts; coal asked about the states the certifier leaves, a timeout that ends it."""

import dataclasses

import numpy as np
import pytest

pytest.importorskip("numba")

from hriplan.planner.search import cbirrt, loop_kernels
from hriplan.planner.search.cbirrt import _pair, _settled, _steps, _Tree, plan_in_bands


def test_steps_and_settled_paths_are_the_loops(rng):
    """Step lengths to the bit; settled exactly where `cbirrt._settled` says, on paths with a
    detour about the threshold's size (both answers occur) and too long to be asked."""
    answers = set()
    for _ in range(400):
        n = int(rng.integers(2, 45))
        path = np.linspace(0.0, 1.0, n)[:, None] * rng.normal(size=6)
        path[int(rng.integers(0, n))] += rng.normal(0.0, 10 ** rng.uniform(-4, -1), 6)
        steps = loop_kernels.steps_of(path)
        assert steps.tobytes() == _steps(list(path)).tobytes()
        answer = loop_kernels.settled(path, steps)
        assert answer == _settled(list(path), steps)
        answers.add((answer, n > cbirrt.SETTLED_STATES))
    assert {(True, False), (False, False), (False, True)} <= answers


def test_pairs_and_the_generator_are_the_loops():
    """numba's port of the generator draws numpy's numbers: the same pairs, and the same state after."""
    for seed in range(200):
        compiled, numpys = np.random.default_rng(seed), np.random.default_rng(seed)
        for n in (3, 4, 17, 250, 4000):
            assert loop_kernels.pair(compiled, n) == _pair(numpys, n)
        assert compiled.bit_generator.state == numpys.bit_generator.state


def test_targets_are_the_loops(searches):
    """Targets near a tree's nodes or anywhere, projected where the scenario has bands: the same
    states to the bit, the generator in step (normal and uniform draws)."""
    python, compiled, start, _, checker, _ = searches
    p = compiled.p
    walker = p.walker.arguments(p.delta, p.constrained, p.offset, p.accept, p.certifier(start))
    tree = _Tree(start)
    for k in range(30):
        tree.add(start + 0.05 * k, 0)
    ours, theirs = np.random.default_rng(3), np.random.default_rng(3)
    for _ in range(200):
        target = loop_kernels._sample(ours, tree.nodes, len(tree), walker)
        assert target.tobytes() == compiled.sample(theirs, tree).tobytes()
    assert ours.bit_generator.state == theirs.bit_generator.state


def test_a_search_is_the_python_loops_bit_for_bit(searches, monkeypatch):
    """The scenario's searches, seeds 0-7: the same status, path and counts as the Python loop
    around the compiled walk, and coal asked about as many states the certifier left."""
    _, compiled, start, _, checker, goal = searches
    asked = []

    def free(x: np.ndarray) -> bool:
        asked.append(x.copy())
        return compiled.p.collision_free(x)

    problem = dataclasses.replace(compiled.p, collision_free=free)
    plan_in_bands(problem, start, goal, 600.0, 0)  # compiled now if not cached: no clock in the outcomes
    asked.clear()
    solved, questions = 0, 0
    for seed in range(8):
        result = plan_in_bands(problem, start, goal, 5.0, seed)
        by_compiled = len(asked)
        with monkeypatch.context() as patched:
            patched.setattr(loop_kernels, "searched", lambda *args: None)
            reference = plan_in_bands(problem, start, goal, 5.0, seed)
        assert result.status == reference.status and result.counters == reference.counters
        assert np.array(result.states).tobytes() == np.array(reference.states).tobytes()
        assert by_compiled == len(asked) - by_compiled
        solved, questions = solved + result.solved, questions + by_compiled
        asked.clear()
    assert solved == 8
    assert questions > 0 or checker.robot.name != "ur5"  # the UR5's searches leave states to coal


def test_a_search_out_of_time_ends_with_no_path(searches):
    _, compiled, start, (low, high), _, _ = searches
    far = np.where(start > (low + high) / 2, low, high)
    result = loop_kernels.searched(compiled.p, start, far, 0.0, 1, 10)
    assert result is not None and not result.solved and result.states == []
    assert result.message == "no exact solution within the time limit"


def test_the_question_goes_to_the_searchs_own_collision_check():
    """`asking` sets the calling thread's check for the search and puts the one before back."""
    first, second = (lambda x: True), (lambda x: False)
    with loop_kernels.asking(first):
        assert loop_kernels._asked_free(np.zeros(6))
        with loop_kernels.asking(second):
            assert not loop_kernels._asked_free(np.zeros(6))
        assert loop_kernels._asked_free(np.zeros(6))
    assert loop_kernels._asked.collision_free is None


def test_the_time_limit_counts_from_the_loops_start_not_from_its_loading(searches, monkeypatch):
    """Time spent before the compiled loop runs (its code loaded or compiled: ~20 s where a cache
    went stale) is not the search's: 10 s passing there leave a 5 s search its whole budget."""
    _, compiled, start, _, _, goal = searches
    now = [0.0]

    def clock() -> float:
        now[0] += 1e-6
        return now[0]

    loaded = loop_kernels.search

    def slow_to_load(*args):
        now[0] += 10.0
        return loaded(*args)

    monkeypatch.setattr(loop_kernels.time, "perf_counter", clock)  # every clock the search could read
    monkeypatch.setattr(loop_kernels, "search", slow_to_load)
    result = loop_kernels.searched(compiled.p, start, goal, 5.0, 0, 10)
    assert result is not None and result.solved and now[0] > 10.0
