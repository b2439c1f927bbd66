"""What the allowed-collision matrix costs and frees: per robot, the pairs by reason, the share
of random joint states that are collision free, and the cost of one self-collision check.

Run: PYTHONPATH=src .venv/bin/python benchmarks/bench_acm.py [STATES]
The mesh-level check of every skipped pair is tests/robots/test_acm.py.
"""

from __future__ import annotations

import collections
import sys
import time

import numpy as np

from hriplan.robots.collision import CollisionChecker
from hriplan.robots.model import load_robot


def main(states: int) -> None:
    print("| robot | pairs by reason | free states | us per check |")
    print("|---|---|---|---|")
    for name in ("ur5", "madar"):
        robot = load_robot(name)
        checker = CollisionChecker(robot)
        reasons = collections.Counter(checker.acm.values())
        rng = np.random.default_rng(0)
        qs = [rng.uniform(robot.model.lowerPositionLimit, robot.model.upperPositionLimit) for _ in range(states)]
        start = time.perf_counter()
        free = sum(not checker.in_collision(q) for q in qs)
        cost = (time.perf_counter() - start) / states * 1e6
        print(
            f"| {name} | {', '.join(f'{k} {n}' for k, n in sorted(reasons.items()))} | {free / states:.0%} | {cost:.1f} |"
        )


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 5000)
