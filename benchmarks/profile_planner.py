"""Profile planning one benchmark scenario (cProfile): where a plan's time goes.

Run: PYTHONPATH=src python benchmarks/profile_planner.py [scenario] [--runs 5] [--top 15]
       [--planner RRTConnect --space atlas --formulation hybrid]
Prints the wall time per plan, the callbacks per plan and the functions with most own time.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import pstats
import time
from pathlib import Path

from hriplan.planner.motion import plan_motion
from hriplan.planner.problem import load_problem
from hriplan.planner.session import PlanningSession

SCENARIOS = Path(__file__).parent / "scenarios"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario", nargs="?", default="a_ur5_upright_box")
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--top", type=int, default=15)
    parser.add_argument("--planner")
    parser.add_argument("--space")
    parser.add_argument("--formulation")
    args = parser.parse_args()
    problem = load_problem(SCENARIOS / f"{args.scenario}.json")
    session = PlanningSession(problem.robot, problem.scene, problem.hands or None)
    session.set_constraints(problem.constraints)
    chosen = {
        k: v for k, v in (("planner", args.planner), ("space", args.space), ("formulation", args.formulation)) if v
    }
    specs = list(session.constraints.values())
    profiler = cProfile.Profile()
    calls: dict[str, int] = {}
    started = time.perf_counter()
    for seed in range(1, args.runs + 1):
        options = problem.options.model_copy(update={"seed": seed, "time_limit": 10.0, **chosen})
        profiler.enable()
        result = plan_motion(session.robot, session.checker, specs, problem.start, problem.goal, options, problem.group)
        profiler.disable()
        for key, value in result.calls.items():
            calls[key] = calls.get(key, 0) + value
        print(f"seed {seed}: {result.status} in {result.planning_time:.3f} s")
    wall = (time.perf_counter() - started) / args.runs
    print(
        f"{args.runs} plans, {wall:.3f} s per plan (profiled), callbacks per plan:",
        {k: v // args.runs for k, v in calls.items()},
    )
    out = io.StringIO()
    stats = pstats.Stats(profiler, stream=out)
    print(f"function calls per plan: {stats.total_calls // args.runs}")
    stats.sort_stats("tottime").print_stats(args.top)
    print(out.getvalue().split("\n\n", 2)[-1])


if __name__ == "__main__":
    main()
