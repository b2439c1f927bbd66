"""CBiRRT's compiled inner loop (planner/search/band_kernels.py) against the Python loop it
replaces (cbirrt._Search's `_stepped` and `project` on the margins and `in_collision`): the
same projections, the same trees grown towards the same targets through scenes with
obstacles and a person, the same counts, to rounding; and its disk cache made again when a
file it calls into changes."""

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from hriplan.planner.search import cbirrt
from hriplan.planner.search.cbirrt import _min_norm_step, _Search, _Tree
from hriplan.planner.search.result import Counters

REPO_SRC = Path(__file__).parents[2] / "src"
# Rounding apart: three or more rows near their bands are solved by the normal equations, whose
# 1e-9 regularisation leaves them ill-conditioned (LAPACK's elimination against the kernel's
# differ by up to a few 1e-9 rad there); one or two rows agree to ~1e-15.
TO_ROUNDING = 1e-7


def _same_counts(a: _Search, b: _Search) -> None:
    assert (a.counters.function, a.counters.jacobian, a.counters.validity) == (
        b.counters.function,
        b.counters.jacobian,
        b.counters.validity,
    )


def test_the_compiled_projection_is_the_python_projection(searches, rng):
    python, compiled, start, (low, high), _, _ = searches
    if not python.p.constrained:
        pytest.skip("no band to project into")
    outcomes = {"inside": 0, "moved": 0, "none": 0}
    for k in range(300):
        x = np.clip(start + rng.normal(0.0, 0.6 if k % 2 else 0.01, len(start)), low, high)
        a, b = python.project(x.copy()), compiled.project(x.copy())
        assert (a is None) == (b is None)
        if a is not None:
            np.testing.assert_allclose(b, a, rtol=0, atol=TO_ROUNDING)
            outcomes["inside" if np.array_equal(a, x) else "moved"] += 1
        else:
            outcomes["none"] += 1
    _same_counts(python, compiled)
    assert min(outcomes.values()) > 0, outcomes  # each outcome occurred


def test_the_compiled_walk_grows_the_python_loops_tree(searches, rng, monkeypatch):
    """Random extensions from the tree's nodes towards random targets, the ends the Python loop
    reaches and the states it adds (each checked for collision before the next step)."""
    python, compiled, start, (low, high), _, _ = searches
    ended = []
    walk = compiled.p.walker.walk

    def counted(*args):
        out = walk(*args)
        ended.append(out[1])
        return out

    monkeypatch.setattr(compiled.p.walker, "walk", counted)
    trees = _Tree(start), _Tree(start)
    reached = 0
    for k in range(150):
        index = int(rng.integers(len(trees[0])))
        target = np.clip(trees[0].nodes[index] + rng.normal(0.0, 0.8, len(start)), low, high)
        if k % 3 == 0:
            target = _Search(python.p, Counters()).sample(np.random.default_rng(k), trees[0])
        steps = int(rng.choice([3, 10, 100]))
        a = python.extend(trees[0], index, target, steps)
        b = compiled.extend(trees[1], index, target, steps)
        assert a == b
        reached += a[1]
        assert trees[0].parents == trees[1].parents
        np.testing.assert_allclose(
            trees[1].nodes[: len(trees[1])], trees[0].nodes[: len(trees[0])], rtol=0, atol=TO_ROUNDING
        )
    _same_counts(python, compiled)
    assert 0 < reached < 150
    # each way a walk ends occurred: collision asked of the checker too, and proven by the
    # certifier (a capsule in a box); unconstrained, no step is blocked
    expected = {cbirrt.REACHED, cbirrt.UNSURE, cbirrt.MORE, cbirrt.COLLIDED}
    expected |= {cbirrt.BLOCKED} if python.p.constrained else set()
    assert expected <= set(ended), set(ended)


def test_a_state_the_walk_leaves_unsure_is_answered_by_its_kept_verdict(searches, rng, monkeypatch):
    """The checker's question about a state the compiled walk could not clear is answered by
    the verdict the walk kept (`certifier_kernels.verdict_one`): the state is the scratch's last,
    bit for bit, and the answer, pairs left included, is the verdict made anew there."""
    from hriplan.robots.certifier_kernels import verdict_one
    from hriplan.robots.free_certifier import FreeCertifier, _decoded

    _, compiled, start, (low, high), checker, _ = searches
    asked = []
    verdict = FreeCertifier.verdict

    def kept(self, q):
        nj = len(self._joint_rows)
        last = self._work[nj * 12 : nj * 12 + len(q)]
        floats, ints = self._floats.copy(), self._ints.copy()
        at = len(floats) - len(self._work) + nj * 12
        floats[at : at + nj * 2] = np.nan  # no state placed: the verdict made anew
        anew = _decoded(verdict_one(q, floats, ints), ints[ints[20] :])
        answer = verdict(self, q)
        asked.append((last.tobytes() == np.asarray(q, dtype=float).tobytes(), answer == anew))
        return answer

    monkeypatch.setattr(FreeCertifier, "verdict", kept)
    tree = _Tree(start)
    for _ in range(150):
        index = int(rng.integers(len(tree)))
        compiled.extend(tree, index, np.clip(tree.nodes[index] + rng.normal(0.0, 0.8, len(start)), low, high), 100)
    assert len(asked) >= 5 and all(last and same for last, same in asked)


def test_a_walk_that_reaches_its_target_on_its_last_step_has_reached_it(searches, rng):
    python, compiled, start, _, _, _ = searches
    if python.p.constrained:
        pytest.skip("a step into the bands may be moved")
    delta = python.p.delta
    for steps in (1, 3, 7):
        direction = rng.normal(size=len(start))
        target = start + direction / np.linalg.norm(direction) * (steps - 0.5) * delta
        assert python.extend(_Tree(start), 0, target, steps) == (steps, True)
        assert compiled.extend(_Tree(start), 0, target, steps) == (steps, True)
        assert compiled.extend(_Tree(start), 0, target, steps - 1) == (steps - 1, False)


def test_the_loop_is_kept_where_the_checker_has_no_compiled_verdict(searches, rng, monkeypatch):
    python, compiled, start, (low, high), _, _ = searches
    monkeypatch.setattr(compiled.p, "certifier", lambda x: None)
    monkeypatch.setattr(compiled.p.walker, "walk", lambda *args: pytest.fail("walked without a certifier"))
    tree = _Tree(start)
    target = np.clip(start + rng.normal(0.0, 0.8, len(start)), low, high)
    assert compiled.extend(tree, 0, target, 10) == python.extend(_Tree(start), 0, target, 10)


def test_a_pair_held_still_and_touching_leaves_no_compiled_verdict(searches, monkeypatch):
    """Every state collides where a still pair touches: the verdict of the moving pairs alone
    would call some free."""
    _, compiled, _, _, checker, _ = searches
    q = compiled.p.walker._terms.base_configuration()
    assert checker.compiled_verdict(q) is not None
    monkeypatch.setattr(type(checker), "_held_touch", lambda self, q: True)
    monkeypatch.setattr(checker, "_held", object())
    assert checker.compiled_verdict(q) is None


def test_the_compiled_nearest_node_is_numpys(rng):
    from hriplan.planner.search.band_kernels import BandWalker

    nodes = rng.normal(size=(300, 6))
    nodes[7] = nodes[3]  # equal nodes: the first is taken
    for count in (1, 2, 50, 300):
        for x in [*rng.normal(size=(40, 6)), nodes[3] + 1e-9]:
            expected = int(np.argmin(((nodes[:count] - x) ** 2).sum(axis=1)))
            assert BandWalker.nearest(nodes, count, x) == expected


@pytest.mark.parametrize("rows", [3, 4, 6])
def test_the_compiled_newton_step_is_the_minimum_norm_solution(rows, rng):
    from hriplan.planner.search.band_kernels import _min_norm_step as compiled_step

    n = 7
    grads, values = rng.normal(size=(rows + 2, n)), rng.normal(size=rows + 2)
    active = np.array([0, 2, 3, 4, 5, 6][:rows], dtype=np.int64)
    step, system = np.empty(n), np.full((rows + 2, rows + 3), np.nan)  # the scratch: every term's size
    compiled_step(grads, values, active, rows, step, system)
    np.testing.assert_allclose(grads[active] @ step, values[active], atol=1e-7)
    expected = _min_norm_step(grads[active], values[active])
    np.testing.assert_allclose(step, expected, rtol=0, atol=1e-9)
    lstsq = np.linalg.lstsq(grads[active], values[active], rcond=None)[0]  # numpy's minimum-norm solution
    np.testing.assert_allclose(step, lstsq, rtol=0, atol=1e-6)


def test_a_kernel_is_compiled_again_when_a_file_it_calls_into_changes(tmp_path):
    """numba alone would load the caller's cached code, with the callee's old body, after the
    callee's file changed (only the caller's own file keys its cache)."""
    _value_module(tmp_path, "callee", 1)
    (tmp_path / "caller.py").write_text(
        textwrap.dedent(
            """
            import callee
            from hriplan.robots.kernel_cache import njit_keyed

            @njit_keyed(callee)
            def keyed():
                return callee.value()
            """
        )
    )
    assert _keyed_value(tmp_path, "caller") == "1"
    assert list((tmp_path / "cache").rglob("*caller*keyed*.nbi"))  # cached
    _value_module(tmp_path, "callee", 2)
    assert _keyed_value(tmp_path, "caller") == "2"


def _value_module(tmp_path, name: str, value: int) -> None:
    """A module `name` whose cached kernel `value()` returns `value`."""
    (tmp_path / f"{name}.py").write_text(
        f"from numba import njit\n\n@njit(cache=True)\ndef value():\n    return {value}\n"
    )


def _keyed_value(tmp_path, module: str) -> str:
    """What `module.keyed()` prints in a fresh process caching in tmp_path/cache (no .pyc: a
    file rewritten within the same second at the same size would load its old bytecode)."""
    run = [sys.executable, "-c", f"import {module}; print({module}.keyed())"]
    env = {
        "PYTHONPATH": f"{tmp_path}:{REPO_SRC}",
        "NUMBA_CACHE_DIR": str(tmp_path / "cache"),
        "PATH": "/usr/bin",
        "PYTHONDONTWRITEBYTECODE": "1",
    }
    return subprocess.run(run, env=env, capture_output=True, text=True, check=True).stdout.strip()


def test_a_kernel_keyed_by_a_module_is_keyed_by_what_that_module_is_keyed_by(tmp_path):
    """The certifier's kernels call the mesh pairs' walk (its KEYED_BY): a kernel keyed by the
    certifier only is compiled again when the walk's file changes, two calls down."""
    _value_module(tmp_path, "leaf", 1)
    (tmp_path / "middle.py").write_text(
        textwrap.dedent(
            """
            import leaf
            from hriplan.robots.kernel_cache import njit_keyed

            KEYED_BY = (leaf,)

            @njit_keyed(leaf)
            def passed():
                return leaf.value()
            """
        )
    )
    (tmp_path / "top.py").write_text(
        textwrap.dedent(
            """
            import middle
            from hriplan.robots.kernel_cache import njit_keyed

            @njit_keyed(middle)
            def keyed():
                return middle.passed()
            """
        )
    )
    assert _keyed_value(tmp_path, "top") == "1"
    assert list((tmp_path / "cache").rglob("*top*keyed*.nbi"))  # cached
    _value_module(tmp_path, "leaf", 2)
    assert _keyed_value(tmp_path, "top") == "2"
