"""Sweep benchmark: throughput with 1 and 2 workers, per-variant overhead over a direct plan,
a handover sweep over person positions, and the Ray driver's dispatch ceiling.

Run: PYTHONPATH=src python benchmarks/bench_sweeps.py [--variants 8] [--handover 500] [--noop 2000]
     [--out out/bench_sweeps]   (--handover 0 / --noop 0 skip those parts)
REPORT-sweeps.md records a run and what it means.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))  # noop() must be importable by spawned workers and Ray actors

from hriplan.sweeps.engines import LocalEngine, RayEngine  # noqa: E402
from hriplan.sweeps.results import ResultStore  # noqa: E402
from hriplan.sweeps.run import run_sweep  # noqa: E402
from hriplan.sweeps.variants import expand, parse_vary  # noqa: E402

GIVE = HERE.parent / "examples" / "handover_full_can_receiver.yaml"


def noop(variant, plan):
    """A worker that does nothing: what is left is the engine's own cost per variant."""
    return [{"key": variant.key, "step_index": 0, "status": "derived"}]


def timed_run(engine, variants, directory: Path, work=None) -> tuple[list[float], list[dict]]:
    """Run through the engine directly, recording each delivery's time (rows stored as a sweep does)."""
    store, stamps, rows = ResultStore(directory), [], []

    def deliver(variant, delivered):
        stamps.append(time.perf_counter())
        rows.extend(delivered)
        store.add(delivered)

    began = time.perf_counter()
    engine.run(variants, True, deliver, **({"work": work} if work else {}))
    store.compact()
    return [began, *stamps], rows


def steady_rate(stamps: list[float]) -> float:
    """Variants per second between the first and the last delivery (worker start-up excluded)."""
    return (len(stamps) - 2) / (stamps[-1] - stamps[1])


def warm(rows: list[dict]) -> list[dict]:
    """Rows after each worker's first (which includes loading the robot)."""
    seen, kept = set(), []
    for row in rows:
        if row["worker"] in seen:
            kept.append(row)
        seen.add(row["worker"])
    return kept


def direct_times(variants) -> list[float]:
    """The same variants planned in this process on one warm session: the plain cost of a plan."""
    from hriplan.planner.session import PlanningSession
    from hriplan.tasks.pipeline import TaskRunner

    session, times = PlanningSession(variants[0].task.robot, hands=variants[0].task.hands or None), []
    TaskRunner(variants[0].task, session=session).run(plan=True)  # warm the reasoning cache
    for v in variants:
        began = time.perf_counter()
        TaskRunner(v.task, session=session).run(plan=True)
        times.append(time.perf_counter() - began)
    return times


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--variants", type=int, default=8)
    parser.add_argument("--handover", type=int, default=500)
    parser.add_argument("--noop", type=int, default=2000)
    parser.add_argument("--noop-actors", default="2,8", help="Actor counts for the dispatch ceiling.")
    parser.add_argument("--out", type=Path, default=Path("out/bench_sweeps"))
    args = parser.parse_args()
    out, result = args.out, {}
    variants = expand(GIVE, [parse_vary(f"planning.seed=1:{args.variants}:1"), parse_vary("planning.time_limit=60")])

    # 1. throughput, 1 worker vs 2, and the per-variant overhead (1 worker) over a direct plan
    one, one_rows = timed_run(LocalEngine(1), variants, out / "w1")
    two, two_rows = timed_run(LocalEngine(2), variants, out / "w2")
    intervals = [b - a for a, b in zip(one[1:], one[2:])]
    worker_times = [r["wall_time"] for r in one_rows][1:]
    direct = direct_times(variants[1:])
    result["throughput"] = {
        "variants": len(variants),
        "wall_1": one[-1] - one[0],
        "wall_2": two[-1] - two[0],
        "rate_1": steady_rate(one),
        "rate_2": steady_rate(two),
        "speedup": steady_rate(two) / steady_rate(one),
        "speedup_wall": (one[-1] - one[0]) / (two[-1] - two[0]),
        # CPU seconds per variant (after each worker's first): equal means the workers do not
        # contend inside hriplan, so throughput scales with the cores actually free
        "cpu_per_variant_1": statistics.mean(r["cpu_time"] for r in warm(one_rows)),
        "cpu_per_variant_2": statistics.mean(r["cpu_time"] for r in warm(two_rows)),
        "load_average": os.getloadavg(),
    }
    result["overhead"] = {
        "mean_interval_1_worker": statistics.mean(intervals),
        "mean_worker_run": statistics.mean(worker_times),
        "mean_direct_plan": statistics.mean(direct),
        "overhead_per_variant_ms": 1000 * statistics.mean(i - w for i, w in zip(intervals, worker_times)),
    }
    print(json.dumps(result, indent=1), flush=True)

    # 2. the Ray driver's ceiling: variants that cost nothing, with few and with many actors
    if args.noop:
        light = expand(GIVE, [parse_vary(f"planning.seed=1:{args.noop}:1")])
        result["ray_noop"] = []
        for actors in (int(a) for a in args.noop_actors.split(",")):
            stamps, _ = timed_run(RayEngine(actors), light, out / f"noop{actors}", work=noop)
            result["ray_noop"].append(
                {"actors": actors, "variants": len(light), "wall": stamps[-1] - stamps[0], "rate": steady_rate(stamps)}
            )
            print(json.dumps(result["ray_noop"][-1]), flush=True)

    # 3. the handover sweep over where the person stands (grid of about --handover positions)
    if args.handover:
        side = max(2, round(args.handover**0.5))
        xs, ys = f"-0.5:0.5:{1.0 / (side - 1):.6f}", f"1.1:2.0:{0.9 / (side - 1):.6f}"
        positions = expand(GIVE, [parse_vary(f"humans.bob.position=[{xs}, {ys}]")])
        summary = run_sweep(positions, out / "handover", LocalEngine(2))
        from hriplan.sweeps.report import write_report

        result["handover"] = summary.model_dump() | {"report": str(write_report(out / "handover"))}
        print(summary.text(), flush=True)
    (out / "bench.json").write_text(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
