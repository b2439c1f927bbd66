"""IK success rate and time per solve on random reachable poses: numeric IK (damped least squares
with restarts) on example-robot-data's Panda (7 joints) and UR10 (6), against the analytic UR10
solver. A target is the tool pose of a random configuration within the joint limits; a success
is a solution within the joint limits reaching it to 1e-6 m and 1e-6 rad (solve_ik's tolerance).

Run: PYTHONPATH=src .venv/bin/python benchmarks/bench_ik.py [POSES]
Results: benchmarks/REPORT-ik.md.
"""

from __future__ import annotations

import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from hriplan.robots.descriptions.registry import DESCRIPTIONS, load_robot_file
from hriplan.robots.ik import solve_ik
from hriplan.robots.model import load_robot

ROBOT_FILES = Path(__file__).parents[1] / "tests" / "data" / "robots"


def with_kind(name: str, kind: str) -> str:
    """The robot `name` with its arm solved by `kind`, registered as NAME_KIND."""
    description = DESCRIPTIONS[name]
    arms = {arm: replace(a, ik=kind) for arm, a in description.arms.items()}
    DESCRIPTIONS[f"{name}_{kind}"] = replace(description, name=f"{name}_{kind}", arms=arms)
    return f"{name}_{kind}"


def measure(name: str, poses: int) -> tuple[float, float, float, float]:
    """(success rate, median, mean and 95th percentile ms per solve)."""
    robot = load_robot(name)
    arm = next(iter(robot.arms))
    group = robot.arm_group(arm)
    rng = np.random.default_rng(0)
    lower, upper = robot.limits(group)
    targets = [robot.frame_pose(robot.tool_frame(arm), rng.uniform(lower, upper), group) for _ in range(poses)]
    solve_ik(robot, arm, targets[0])  # the analytic solver's frames are measured once, not timed
    times, successes = [], 0
    for target in targets:
        start = time.perf_counter()
        successes += solve_ik(robot, arm, target).success
        times.append((time.perf_counter() - start) * 1e3)
    return successes / poses, float(np.median(times)), float(np.mean(times)), float(np.percentile(times, 95))


def main(poses: int) -> None:
    for robot_file in ("panda.yaml", "ur10.yaml"):
        load_robot_file(ROBOT_FILES / robot_file)
    rows = [("Panda", "numeric", "panda"), ("UR10", "numeric", with_kind("ur10", "numeric"))]
    rows.append(("UR10", "ur10_analytic", "ur10"))
    print(f"{poses} random reachable poses per row")
    print("| arm | IK kind | success | median ms | mean ms | p95 ms |")
    print("|---|---|---|---|---|---|")
    for label, kind, name in rows:
        rate, median, mean, p95 = measure(name, poses)
        print(f"| {label} | {kind} | {rate:.1%} | {median:.2f} | {mean:.2f} | {p95:.2f} |")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 1000)
