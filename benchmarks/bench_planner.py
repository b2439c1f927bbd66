"""Planner benchmark: scenarios x constrained spaces x planners x seeds.

Run: .venv/bin/python benchmarks/bench_planner.py [--seeds 50] [--scenarios a,b] [--methods default] [--out results.json]
     .venv/bin/python benchmarks/bench_planner.py --bands --seeds 20 --baseline-seeds 5  (a-h, the band methods)
Each run plans one scenario (benchmarks/scenarios/*.json, plus `a_ur5_unconstrained`: scenario
a without its constraints) through a PlanningSession in a worker process and times it; a run
counts as solved only if its path passed dense validation within the scenario's time limit AND
its timed trajectory passed re-validation. Seconds are the wall time of `PlanningSession.plan`
(planning, validation, timing, re-validation; timed without the ISO/TS 15066 limits the session
applies by default, as recorded); path is the validated path's joint-space length against the
straight joint line from start to goal.
Prints a markdown table; REPORT-planner.md records a run and what it means.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

SCENARIOS = Path(__file__).parent / "scenarios"
TIME_LIMITS = {
    "a_ur5_upright_box": 5.0,
    "b_madar_handover": 2.0,
    "c_madar_peg_in_hole": 5.0,
    "g_madar_left_arm": 5.0,
    "i_madar_one_arm_holds": 5.0,
    "a_ur5_unconstrained": 5.0,
}
# Families that are another scenario with its constraints dropped.
UNCONSTRAINED = {"a_ur5_unconstrained": "a_ur5_upright_box"}
# (space, formulation): the hybrid on every space, the dead-zone rows on the projected space,
# and the seed framework's rejection sampling as the baseline.
METHODS = [
    ("atlas", "hybrid"),
    ("tangent_bundle", "hybrid"),
    ("projected", "hybrid"),
    ("projected", "deadzone"),
    ("rejection", "hybrid"),
]
PLANNERS = ["RRTConnect", "BKPIECE1", "KPIECE1", "PRM"]
# The band families (REPORT-planner.md, "Planning inside the bands"): every scenario, each method.
BAND_TIME_LIMITS = {
    "d_ur5_tilt_past_post_static": 5.0,
    "d_ur5_tilt_past_post_dynamic": 5.0,
    "e_ur5_tilted_start": 5.0,
    "f_madar_volumes_only": 5.0,
    "h_ur5_cluttered_cabinet": 5.0,
}
BAND_METHODS = [
    ("projected", "deadzone", "CBiRRT"),
    ("atlas", "hybrid", "RRTConnect"),
    ("atlas", "slack", "RRTConnect"),
    ("rejection", "hybrid", "RRTConnect"),
]
_sessions: dict = {}


def _run(job: tuple[str, str, str, str, int]) -> dict:
    from hriplan.planner.problem import load_problem
    from hriplan.planner.session import PlanningSession

    scenario, space, formulation, planner, seed = job
    if scenario not in _sessions:
        problem = load_problem(SCENARIOS / f"{UNCONSTRAINED.get(scenario, scenario)}.json")
        session = PlanningSession(problem.robot, problem.scene, problem.hands or None)
        session.set_constraints([] if scenario in UNCONSTRAINED else problem.constraints)
        _sessions[scenario] = (problem, session)
    problem, session = _sessions[scenario]
    options = problem.options.model_copy(
        update={
            "space": space,
            "formulation": formulation,
            "planner": planner,
            "seed": seed,
            "time_limit": TIME_LIMITS.get(scenario) or BAND_TIME_LIMITS[scenario],
        }
    )
    start = time.perf_counter()
    result = session.plan(problem.start, problem.goal, options, problem.group, safety=None)
    seconds = time.perf_counter() - start
    path = np.array(result.motion.path) if result.motion.path else np.zeros((2, 1))
    return {
        "scenario": scenario,
        "space": space,
        "formulation": formulation,
        "planner": planner,
        "seed": seed,
        "status": result.status,
        "seconds": seconds,
        "calls": result.motion.calls,
        "path": float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum()),
        "straight": float(np.linalg.norm(path[-1] - path[0])),
    }


def _jobs(
    seeds: int, baseline_seeds: int, planners: list[str], scenarios: list[str], methods: list[tuple[str, str]]
) -> list[tuple]:
    jobs = []
    for scenario in scenarios:
        for space, formulation in methods:
            for planner in planners:
                main = space in ("atlas", "tangent_bundle") and formulation == "hybrid"
                if planner != "RRTConnect" and not main:
                    continue  # other planners only on the spaces that work; keeps the run bounded
                n = seeds if main else baseline_seeds
                jobs += [(scenario, space, formulation, planner, s) for s in range(n)]
    return jobs


def _band_jobs(seeds: int, baseline_seeds: int) -> list[tuple]:
    """Every scenario (a-i and the band families) with each band method; the methods that fail
    by timing out (slack, rejection) get fewer seeds."""
    jobs = []
    for scenario in [*TIME_LIMITS, *BAND_TIME_LIMITS]:
        for space, formulation, planner in BAND_METHODS:
            n = seeds if formulation != "slack" and space != "rejection" else baseline_seeds
            jobs += [(scenario, space, formulation, planner, 1000 + s) for s in range(n)]
    return jobs


def _summary(runs: list[dict]) -> str:
    """Table cells for the runs of one method: solved, median and p95 s, path vs straight, calls."""
    solved = [r for r in runs if r["status"] == "solved"]
    times = [r["seconds"] for r in solved]
    med = lambda k: int(np.median([r["calls"].get(k, 0) for r in runs]))  # noqa: E731
    stats = f"{np.median(times):.3f} | {np.percentile(times, 95):.3f}" if times else "- | -"
    ratio = (
        f"{np.median([r['path'] for r in solved]):.2f} / {np.median([r['straight'] for r in solved]):.2f}"
        if solved
        else "-"
    )
    return f"{len(solved)}/{len(runs)} | {stats} | {ratio} | {med('function')} / {med('jacobian')} / {med('validity')}"


def _runs_by_method(rows: list[dict], order) -> list[tuple[tuple, list[dict]]]:
    method = lambda r: (r["scenario"], r["space"], r["formulation"], r["planner"])  # noqa: E731
    return [(key, [r for r in rows if method(r) == key]) for key in sorted({method(r) for r in rows}, key=order)]


def _band_table(rows: list[dict]) -> str:
    lines = [
        "| scenario | method | solved | median s | p95 s | path / straight (median) | median calls (f / J / valid) |",
        "|---|---|---|---|---|---|---|",
    ]
    scenarios = [*TIME_LIMITS, *BAND_TIME_LIMITS]
    for key, runs in _runs_by_method(rows, lambda k: (scenarios.index(k[0]), BAND_METHODS.index(k[1:]))):
        lines.append(f"| {key[0]} | {key[3]} {key[1]} {key[2]} | {_summary(runs)} |")
    return "\n".join(lines)


def _table(rows: list[dict]) -> str:
    lines = [
        "| scenario | space | formulation | planner | solved | median s | p95 s | median path / straight rad | median calls (f / J / valid) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for key, runs in _runs_by_method(rows, lambda k: (k[0], METHODS.index(k[1:3]), k[3])):
        lines.append(f"| {key[0]} | {key[1]} | {key[2]} | {key[3]} | {_summary(runs)} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=50, help="seeds for the main spaces (atlas, tangent bundle)")
    parser.add_argument(
        "--baseline-seeds", type=int, default=20, help="seeds for projected and rejection (slow when they fail)"
    )
    parser.add_argument("--planners", default=",".join(PLANNERS))
    parser.add_argument(
        "--scenarios", default=",".join(TIME_LIMITS), help="comma-separated scenario names (prefixes work)"
    )
    parser.add_argument("--methods", choices=("all", "default"), default="all", help="default: atlas + hybrid only")
    parser.add_argument("--bands", action="store_true", help="the band methods on every scenario (a-i and d-h) instead")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=None, help="write every run as JSON")
    args = parser.parse_args()
    os.environ["OPENBLAS_NUM_THREADS"] = "1"  # or the worker pool is slower than one process
    scenarios = [name for prefix in args.scenarios.split(",") for name in TIME_LIMITS if name.startswith(prefix)]
    methods = METHODS if args.methods == "all" else METHODS[:1]
    jobs = (
        _band_jobs(args.seeds, args.baseline_seeds)
        if args.bands
        else _jobs(args.seeds, args.baseline_seeds, args.planners.split(","), scenarios, methods)
    )
    started = time.perf_counter()
    with ProcessPoolExecutor(args.workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        rows = list(pool.map(_run, jobs, chunksize=4))
    if args.out:
        args.out.write_text(json.dumps(rows, indent=0))
    print(f"{len(rows)} runs in {time.perf_counter() - started:.0f} s with {args.workers} workers")
    print(_band_table(rows) if args.bands else _table(rows))


if __name__ == "__main__":
    main()
