"""Dense validation alone, on the calls a re-plan makes (issue 21's re-plan, bench_replan.py's).

Run: PYTHONPATH=src .venv/bin/python benchmarks/bench_validate.py [--src /tmp/base/src] [--rounds 3]
The receiver of examples/handover_full_can_receiver.yaml moves (as in bench_replan.py) and every
`validate_path` call of the re-plans is kept with its checker's scene and zones; the calls of one
re-plan are then replayed (the scene set again, then `validate_path`), and the median CPU time of
a re-plan's calls over --passes passes printed, with the calls' dense states and results. With
--src, each round runs this checkout and the other in turn in fresh processes (alternating, so
both see the same load), and the results are compared: the same PathValidation, field for field.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "handover_full_can_receiver.yaml"


def measure(passes: int) -> dict:
    """This process's tree: the re-plan's calls, replayed `passes` times."""
    from hriplan.api import PlanningSession, load_task, run_task
    from hriplan.planner import motion, session
    from hriplan.planner import validate as validate_module

    calls, original = [], validate_module.validate_path

    def kept(evaluator, checker, states, step=0.01, human_distance=False):
        calls.append((evaluator, checker, np.array(states), step, human_distance, checker.scene, checker.zones))
        return original(evaluator, checker, states, step, human_distance)

    session.validate_path = motion.validate_path = kept
    task = load_task(EXAMPLE)
    planning = PlanningSession(task.robot, hands=task.hands)
    run_task(task, planning, advance=False)  # warm
    bob = task.humans[0]
    moved = bob.model_copy(update={"position": (bob.position[0] + 0.1, bob.position[1])})
    calls.clear()
    run_task(task.model_copy(update={"humans": [moved]}), planning, advance=False)

    def replay() -> list:
        found = []
        for evaluator, checker, states, step, human_distance, scene, zones in calls:
            checker.set_world(scene, zones)
            found.append(original(evaluator, checker, states, step, human_distance))
        return found

    results = replay()
    spent = []
    for _ in range(passes):
        started = time.process_time()
        replay()
        spent.append(time.process_time() - started)
    return {
        "cpu": statistics.median(spent),
        "states": [r.states_checked for r in results],
        "results": [r.model_dump() for r in results],
    }


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--src", help="another checkout's src, run in turn with this one")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--passes", type=int, default=15)
    parser.add_argument("--json", action="store_true", help=argparse.SUPPRESS)  # one tree, for --src
    args = parser.parse_args()
    if args.json:
        print(json.dumps(measure(args.passes)))
        return
    trees = {"this": str(ROOT / "src")} | ({"other": args.src} if args.src else {})
    seen: dict[str, list[dict]] = {name: [] for name in trees}
    for round_ in range(args.rounds):
        for name, src in trees.items():
            env = os.environ | {"PYTHONPATH": src}
            command = [sys.executable, __file__, "--json", "--passes", str(args.passes)]
            out = subprocess.run(command, env=env, capture_output=True, text=True, check=True).stdout
            seen[name].append(json.loads(out.splitlines()[-1]))
        print(
            f"round {round_ + 1}: "
            + ", ".join(f"{name} {1e3 * seen[name][-1]['cpu']:.1f} ms" for name in trees)
            + (f" (ratio {seen['this'][-1]['cpu'] / seen['other'][-1]['cpu']:.2f})" if args.src else "")
        )
    print(f"calls of a re-plan: {len(seen['this'][0]['states'])}, dense states {seen['this'][0]['states']}")
    for name in trees:
        print(
            f"{name}: median CPU of a re-plan's validate_path calls {1e3 * statistics.median(r['cpu'] for r in seen[name]):.1f} ms"
        )
    if args.src:
        same = all(a["results"] == b["results"] for a, b in zip(seen["this"], seen["other"]))
        print("results: " + ("the same PathValidation, field for field" if same else "DIFFER"))


if __name__ == "__main__":
    main()
