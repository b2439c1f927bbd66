"""IK success rate and CPU time per success and per failure (random reachable poses, the same
from a reference, out of reach, turned: `measure`): numeric IK (damped least squares with restarts) on example-robot-data's Panda (7 joints), UR10 and UR5 (6), TALOS's and
TIAGo Pro's arms (7 each, two mirror-image arms), against the analytic UR10 solver. A target is
the tool pose of a random configuration within the joint limits; a success is a solution within
the joint limits reaching it to 1e-6 m and 1e-6 rad (solve_ik's tolerance). Then mirror-image
poses for TIAGo Pro's two arms (ahead, tool z forward and x up): solved by both, by neither, by
one only (mirror-image arms should agree).

Run: PYTHONPATH=src .venv/bin/python benchmarks/bench_ik.py [POSES]
Results: benchmarks/REPORT-ik.md.
"""

from __future__ import annotations

import itertools
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from hriplan.robots.descriptions.registry import DESCRIPTIONS, load_robot_file
from hriplan.robots.ik import solve_ik
from hriplan.robots.model import load_robot

ROBOT_FILES = Path(__file__).parents[1] / "tests" / "data" / "robots"
HALF_TURN_X = np.diag([1.0, -1.0, -1.0, 1.0])
FORWARD_X_UP = np.column_stack([[0.0, 0.0, 1.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])


def with_kind(name: str, kind: str) -> str:
    """The robot `name` with its arm solved by `kind`, registered as NAME_KIND."""
    description = DESCRIPTIONS[name]
    arms = {arm: replace(a, ik=kind) for arm, a in description.arms.items()}
    DESCRIPTIONS[f"{name}_{kind}"] = replace(description, name=f"{name}_{kind}", arms=arms)
    return f"{name}_{kind}"


def measure(name: str, poses: int, arm: str | None = None) -> tuple[list[tuple[bool, float]], ...]:
    """(success, CPU ms) per solve of four target sets: `poses` random reachable poses (the tool
    pose of a random configuration); `poses` // 5 of them solved from a reference (another random
    configuration, as a planner gives its start: the nearest of the first solutions is preferred);
    as many with the position moved along the ray from the shoulder to 1.1 times the farthest of
    them (out of reach: a failure that should be cheap); as many turned half a turn about the
    tool's x axis (reachable or not)."""
    robot = load_robot(name)
    arm = arm or next(iter(robot.arms))
    group, tool = robot.arm_group(arm), robot.tool_frame(arm)
    rng = np.random.default_rng(0)
    lower, upper = robot.limits(group)
    targets = [robot.frame_pose(tool, rng.uniform(lower, upper), group) for _ in range(poses)]
    solve_ik(robot, arm, targets[0])  # the analytic solver's frames are measured once, not timed
    shoulder = robot.frame_pose(robot.description.arms[arm].joints[0], robot.q_neutral)[:3, 3]
    farthest = max(float(np.linalg.norm(t[:3, 3] - shoulder)) for t in targets)
    beyond, turned = [], []
    for target in targets[: poses // 5]:
        out = target.copy()
        ray = out[:3, 3] - shoulder
        out[:3, 3] = shoulder + ray * (1.1 * farthest / np.linalg.norm(ray))
        beyond.append(out)
        turned.append(target @ HALF_TURN_X)
    references = [rng.uniform(lower, upper) for _ in range(poses // 5)]
    batches = [(targets, [None] * poses), (targets, references), (beyond, references), (turned, references)]
    results = []
    for batch, refs in batches:
        results.append([])
        for target, reference in zip(batch, refs):
            start = time.process_time()
            solved = solve_ik(robot, arm, target, reference=reference).success
            results[-1].append((solved, (time.process_time() - start) * 1e3))
    return tuple(results)


def summary(results: list[tuple[bool, float]]) -> str:
    """Success rate; mean CPU ms per success and per failure."""
    success = [ms for ok, ms in results if ok]
    failure = [ms for ok, ms in results if not ok]
    return f"{len(success) / len(results):.1%}, {_mean(success)}, {_mean(failure)} ({len(failure)})"


def _mean(times: list[float]) -> str:
    return f"{np.mean(times):.2f}" if times else "-"


def mirrored(name: str) -> tuple[int, int, int, int]:
    """Over a grid of mirror-image poses ahead of the robot: how many both arms solve, neither,
    the right only, the left only."""
    robot = load_robot(name)
    counts = [0, 0, 0, 0]
    for x, y, z in itertools.product((0.45, 0.5, 0.55, 0.6, 0.65), (0.1, 0.2, 0.3), (0.8, 0.85, 0.9, 0.95, 1.0, 1.1)):
        solved = []
        for arm, side in (("right", -1.0), ("left", 1.0)):
            target = np.eye(4)
            target[:3, :3], target[:3, 3] = FORWARD_X_UP, (x, side * y, z)
            solved.append(solve_ik(robot, arm, target).success)
        counts[{(True, True): 0, (False, False): 1, (True, False): 2, (False, True): 3}[tuple(solved)]] += 1
    return tuple(counts)


def main(poses: int) -> None:
    for robot_file in ("panda.yaml", "ur10.yaml"):
        load_robot_file(ROBOT_FILES / robot_file)
    # robots hriplan never named, as a new user's robot files give them (arms only: IK needs no more)
    talos, tiago_pro = (load_robot_file(ROBOT_FILES / f).name for f in ("talos_arms.yaml", "tiago_pro.yaml"))
    rows = [("Panda", "numeric", "panda", None), ("UR10", "numeric", with_kind("ur10", "numeric"), None)]
    rows.append(("UR5", "numeric", with_kind("ur5", "numeric"), None))
    rows += [(f"TALOS {arm}", "numeric", talos, arm) for arm in ("right", "left")]
    rows += [(f"TIAGo Pro {arm}", "numeric", tiago_pro, arm) for arm in ("right", "left")]
    rows.append(("UR10", "ur10_analytic", "ur10", None))
    print(f"{poses} random reachable poses per row; {poses // 5} from a reference, out of reach, turned")
    print("| arm | IK kind | reachable | from a reference | out of reach | turned |")
    print("|---|---|---|---|---|---|")
    for label, kind, name, arm in rows:
        print(f"| {label} | {kind} | {' | '.join(summary(r) for r in measure(name, poses, arm))} |")
    print("each cell: success, mean CPU ms per success, per failure (failures)")
    both, neither, right, left = mirrored(tiago_pro)
    print(
        f"TIAGo Pro, 90 mirror-image poses: both arms {both}, neither {neither}, right only {right}, left only {left}"
    )


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 1000)
