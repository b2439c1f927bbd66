"""What the allowed-collision matrix costs and frees: per robot, the pairs by reason, the share
of random joint states that are collision free, and the cost of one self-collision check, with
the current rules and without the measured false-collision rule (acm.FALSE_SHARE, the rules
before it: a pair is checked on its meshes only if its fitted parts always touch or it is two
links apart), on the same states in the same run.

"all" is over every random state (a state in collision stops at its first colliding pair, so
freeing states makes the mean dearer); "free" is over the states free under both, where every
checked pair is checked.

Run: PYTHONPATH=src .venv/bin/python benchmarks/bench_acm.py [STATES]
The mesh-level check of every skipped pair is tests/robots/test_acm.py.
"""

from __future__ import annotations

import collections
import math
import sys
import time

import numpy as np

from hriplan.robots import acm
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.descriptions.registry import load_robot_file
from hriplan.robots.model import load_robot

# MADAR without hands, as Kautham's madar_dual_arm demo has it (a robot file).
MADAR_BARE = "examples/robots/madar_bare.yaml"
REPEATS = 5  # best of, the two rules taking turns (the machine's load varies)


def _checker(robot, false_share: float) -> CollisionChecker:
    saved = acm.FALSE_SHARE
    acm.FALSE_SHARE = false_share  # part of the cache key: each rule has its own cached matrix
    try:
        return CollisionChecker(robot)
    finally:
        acm.FALSE_SHARE = saved


def _us_per_check(checkers: dict[str, CollisionChecker], qs: list[np.ndarray]) -> dict[str, float]:
    best = dict.fromkeys(checkers, math.inf)
    for _ in range(REPEATS):
        for label, checker in checkers.items():
            start = time.perf_counter()
            for q in qs:
                checker.in_collision(q)
            best[label] = min(best[label], time.perf_counter() - start)
    return {label: t / max(len(qs), 1) * 1e6 for label, t in best.items()}


def main(states: int) -> None:
    print("| robot | rules | pairs by reason | free states | us per check, all | us per check, free under both |")
    print("|---|---|---|---|---|---|")
    for name in ("ur5", "madar", load_robot_file(MADAR_BARE).name):
        robot = load_robot(name)
        checkers = {"before": _checker(robot, math.inf), "current": _checker(robot, acm.FALSE_SHARE)}
        rng = np.random.default_rng(0)
        qs = [rng.uniform(robot.model.lowerPositionLimit, robot.model.upperPositionLimit) for _ in range(states)]
        free = {label: [not c.in_collision(q) for q in qs] for label, c in checkers.items()}
        both = [q for q, a, b in zip(qs, free["before"], free["current"]) if a and b]
        cost_all, cost_free = _us_per_check(checkers, qs), _us_per_check(checkers, both)
        for label, checker in checkers.items():
            reasons = collections.Counter(checker.acm.values())
            print(
                f"| {name} | {label} | {', '.join(f'{k} {n}' for k, n in sorted(reasons.items()))} "
                f"| {sum(free[label]) / states:.0%} | {cost_all[label]:.1f} "
                f"| {cost_free[label]:.1f} ({len(both)} states) |"
            )


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 5000)
