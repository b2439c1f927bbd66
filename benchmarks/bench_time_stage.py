"""The timing stage without people: `PlanningSession.time` (TOPP-RA, dense validation of the timed
samples, the trajectory file) on planned motions, this checkout against another tree's code.

Run: HRIPLAN_KERNELS=1 PYTHONPATH=src .venv/bin/python benchmarks/bench_time_stage.py [--src /tmp/base/src] [--rounds 5]
Each scenario (benchmarks/scenarios, `bench_collision.scenario_plans`: a, a unconstrained and b
12 seeds, c 4) is planned once a seed; then `time(motion, options, safety=None)` runs on those
motions PASSES times with the collector off: CPU ms a timing, the median of the passes, and a
digest of the trajectories (planning times left out) that must match between the trees. With
--src each round runs both trees in turn in fresh processes, and the table gives the medians of
the rounds and their ratio.
"""

from __future__ import annotations

import gc
import hashlib
import statistics
import time

from bench_collision import scenario_plans
from trees import runs_by_tree

SEEDS = {"a_ur5_upright_box": 12, "a_ur5_unconstrained": 12, "b_madar_handover": 12, "c_madar_peg_in_hole": 4}
PASSES = 8


def measure() -> dict:
    """One tree's numbers (the code on sys.path)."""
    out: dict = {}
    for scenario, seeds in SEEDS.items():
        session, _, _, _, results, problem = scenario_plans(scenario, seeds)
        motions = [r.motion for r in results if r.motion is not None and r.motion.solved]
        digest = hashlib.sha256()
        for motion in motions:
            timed = session.time(motion, problem.options, safety=None)
            digest.update(timed.trajectory.model_dump_json(exclude={"report": {"planning_time"}}).encode())
        passes = []
        gc.disable()
        try:
            for _ in range(PASSES):
                started = time.process_time()
                for motion in motions:
                    session.time(motion, problem.options, safety=None)
                passes.append((time.process_time() - started) / len(motions))
        finally:
            gc.enable()
        out[f"{scenario} time (ms)"] = 1e3 * statistics.median(passes)
        out[f"{scenario} digest"] = digest.hexdigest()[:16]
    return out


def main() -> None:
    runs, compared = runs_by_tree(__doc__.splitlines()[0], __file__, measure)
    print("| measure | this checkout |" + (" other | ratio |" if compared else ""))
    print("|---|---|" + ("---|---|" if compared else ""))
    for key in runs["this checkout"][0]:
        if key.endswith("digest"):
            mine = {r[key] for r in runs["this checkout"]}
            theirs = {r[key] for r in runs["other"]} if compared else set()
            same = "" if not compared else (" same |" if mine == theirs else " DIFFERENT |")
            print(
                f"| {key} | {', '.join(sorted(mine))} |" + (f" {', '.join(sorted(theirs))} |{same}" if compared else "")
            )
            continue
        mine = statistics.median(r[key] for r in runs["this checkout"])
        row = f"| {key} | {mine:.2f} |"
        if compared:
            other = statistics.median(r[key] for r in runs["other"])
            row += f" {other:.2f} | {mine / other:.3f} |"
        print(row)


if __name__ == "__main__":
    main()
