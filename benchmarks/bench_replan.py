"""Re-plan after a perception update, through the plug-in API (issue "Reasoning at the speed of
perception"): the receiver of examples/handover_full_can_receiver.yaml moves 10 cm, and the
motion manager derives and plans the handover again on the same session.

Run: .venv/bin/python benchmarks/bench_replan.py [--updates 10]
Prints, per update, the wall time of `run_task` (derive + plan + time, warm session and
reasoner) and of its parts, then the medians. Times are wall seconds on this machine; compare
the parts with each other, in one run.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from hriplan.api import PlanningSession, load_task, run_task
from hriplan.planner.session import PlanningSession as Session

EXAMPLE = Path(__file__).parents[1] / "examples" / "handover_full_can_receiver.yaml"


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--updates", type=int, default=10)
    args = parser.parse_args()
    task = load_task(EXAMPLE)
    session = PlanningSession(task.robot, hands=task.hands)
    timing = {"time": 0.0}
    original_time = Session.time

    def timed_stage(self, *a, **k):  # noqa: ANN001, ANN002, ANN003, ANN202 - measure the timing stage alone
        started = time.perf_counter()
        try:
            return original_time(self, *a, **k)
        finally:
            timing["time"] += time.perf_counter() - started

    Session.time = timed_stage
    run_task(task, session)  # warm: robot, collision model, reasoner's schema
    totals, stages = [], []
    bob = task.humans[0]
    for k in range(args.updates):
        dx = 0.1 if k % 2 == 0 else -0.1
        reach = {side: (x + dx, y, z) for side, (x, y, z) in bob.reach.items()}  # the hand moves with her
        moved = bob.model_copy(update={"position": (bob.position[0] + dx, bob.position[1]), "reach": reach})
        variant = task.model_copy(update={"humans": [moved]})
        timing["time"] = 0.0
        started = time.perf_counter()
        outcome = run_task(variant, session)
        totals.append(time.perf_counter() - started)
        stages.append(timing["time"])
        print(f"update {k + 1}: {outcome.steps[-1].status:>8} in {totals[-1]:.3f} s (timing stage {stages[-1]:.3f} s)")
    print(f"median: {statistics.median(totals):.3f} s per re-plan, of which the timing stage {statistics.median(stages):.3f} s")


if __name__ == "__main__":
    main()
