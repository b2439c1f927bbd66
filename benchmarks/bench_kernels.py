"""The compiled collision certifier (HRIPLAN_KERNELS=1) against another tree, in CPU time.

Run: HRIPLAN_KERNELS=1 PYTHONPATH=src .venv/bin/python benchmarks/bench_kernels.py --src /tmp/base0/src --rounds 3
Per scenario of benchmarks/scenarios (a without its constraints too): the median process CPU
seconds of `PlanningSession.plan` over seeds, the solved count and a digest of every planned
path (equal digests: the same paths, bit for bit); per robot and scene, the CPU microseconds of
`in_collision` on the states of the planned paths and on free states drawn uniformly, and the
share of those states the certifier passes without coal; "compiled walk step": a step of
CBiRRT's compiled walk (projected, margins and collision verdict in one numba call) along the
planned paths, 2 mm apart; "in its motion": the path's states asked
as the planner asks them, within `CollisionChecker.moving` of the planned group from the start
(the full check in a tree without it). Each round runs both trees in turn in
fresh processes (benchmarks/trees.py); the kernels' compilation is cached, and the first call's
load is made before timing.
"""

from __future__ import annotations

import hashlib
import os
import time

import numpy as np
from bench_collision import PLANS, _per_state_us, free_states, in_motion, median_row, scenario_plans
from trees import runs_by_tree


def _cpu_us(checker, states: np.ndarray) -> float:
    return _per_state_us(checker, states, time.process_time)


def _certified(checker, states: np.ndarray) -> float:
    """The share of `states` the certifier passes (nan without one)."""
    certifier = getattr(checker, "_free_certifier", lambda: None)()
    return float(certifier.free_many(states).mean()) if certifier else float("nan")


def _walk_step_us(session, problem, results) -> float:
    """CPU microseconds a step of CBiRRT's compiled walk (band_kernels: the step projected into
    the bands, its margins, its collision verdict) costs, walking 2 mm steps along the planned
    paths; nan in a tree without it."""
    try:
        from hriplan.planner.search.band_kernels import BandWalker
    except ImportError:
        return float("nan")
    from hriplan.planner.constraints.binding import bind
    from hriplan.planner.constraints.evaluator import ConstraintEvaluator
    from hriplan.planner.motion import BAND_OFFSET, PLANNING_MARGIN
    from hriplan.planner.search.cbirrt import UNSURE

    robot, checker = session.robot, session.checker
    group = problem.group or robot.default_group
    q0 = robot.configuration(problem.start)
    specs = list(session.constraints.values())
    evaluator = ConstraintEvaluator(robot, bind(specs, robot, checker), group, q0)
    walker = BandWalker.of(evaluator, robot.limits(group))
    bands = (BAND_OFFSET, PLANNING_MARGIN) if specs else None
    paths = [np.array(r.motion.path) for r in results if r.motion is not None and r.motion.solved]
    best = np.inf
    with in_motion(checker, session, problem):
        certifier = checker.compiled_verdict(evaluator.full(q0[evaluator.idx]))
        for _ in range(3):
            steps, started = 0, time.process_time()
            for path in paths:
                for a, b in zip(path, path[1:]):
                    states, code, _, _ = walker.walk(a, b, 0.002, 200, bands, certifier)
                    steps += len(states) + (code == UNSURE)  # an unsure state was verdicted too
            best = min(best, (time.process_time() - started) / max(steps, 1))
    return 1e6 * best


def measure() -> dict:
    """One tree's numbers (the code on sys.path)."""
    from hriplan.robots.collision import CollisionChecker
    from hriplan.robots.model import load_robot

    out: dict = {"kernels": os.environ.get("HRIPLAN_KERNELS", "")}
    rng = np.random.default_rng(0)
    for name in ("ur5", "madar"):
        checker = CollisionChecker(load_robot(name))
        free = free_states(checker, rng)
        out[f"{name} free state (us)"] = _cpu_us(checker, free)
        out[f"{name} free states certified"] = _certified(checker, free)
    for scenario, seeds in PLANS.items():
        session, states, seconds, solved, results, problem = scenario_plans(scenario, seeds, time.process_time)
        digest = hashlib.sha256()
        for result in results:
            if result.motion is not None:
                digest.update(np.ascontiguousarray(result.motion.path).tobytes())
        out[f"{scenario} plan median (s)"] = float(np.median(seconds))
        out[f"{scenario} solved"] = solved
        out[f"{scenario} paths"] = digest.hexdigest()[:12]
        out[f"{scenario} compiled walk step (us)"] = _walk_step_us(session, problem, results)
        if len(states):
            out[f"{scenario} path state (us)"] = _cpu_us(session.checker, states)
            out[f"{scenario} path states certified"] = _certified(session.checker, states)
            with in_motion(session.checker, session, problem):
                out[f"{scenario} path state in its motion (us)"] = _cpu_us(session.checker, states)
                out[f"{scenario} path states in its motion certified"] = _certified(session.checker, states)
    return out


def main() -> None:
    runs, compared = runs_by_tree(__doc__.splitlines()[0], __file__, measure)
    keys = list(runs["this checkout"][0])
    print("| measure | this checkout |" + (" other | ratio |" if compared else ""))
    print("|---|---|" + ("---|---|" if compared else ""))
    for key in keys:
        values = [r[key] for r in runs["this checkout"]]
        if isinstance(values[0], str):  # digests: the same in every round, or say so
            theirs = {r.get(key) for r in runs.get("other", [])}
            print(
                f"| {key} | {', '.join(sorted(set(values)))} |"
                + (f" {', '.join(sorted(theirs))} | |" if compared else "")
            )
            continue
        print(median_row(runs, key, compared))


if __name__ == "__main__":
    main()
