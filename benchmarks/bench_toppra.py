"""TOPP-RA as hriplan drives it (`planner/timing.py`: `_TOPPRA`, `_ConstantAcceleration`) against
toppra's own classes (`TOPPRA`, `ParametrizeConstAccel`), on the TOPP-RA problems that planning
the benchmark scenarios a, b and c poses (3 seeds each), in one process, interleaved.

Run: PYTHONPATH=src .venv/bin/python benchmarks/bench_toppra.py [--rounds 7]
Per scenario: the median CPU milliseconds of one solve and the evaluation of its trajectory at
every 10 ms sample (positions, velocities, accelerations, as `time_parameterize` asks), for each
route, their ratio, and whether every sample is the same, bit for bit.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from hriplan.blas_threads import single_threaded_blas

single_threaded_blas()  # before numpy, as the command line: toppra's set-up multiplies (N x 2n) by (2n x 4n)

import numpy as np  # noqa: E402

from hriplan.planner import timing  # noqa: E402
from hriplan.planner.problem import load_problem  # noqa: E402
from hriplan.planner.session import PlanningSession  # noqa: E402

SCENARIOS = Path(__file__).parent / "scenarios"
NAMES = ("a_ur5_upright_box", "b_madar_handover", "c_madar_peg_in_hole")
OURS = timing._TOPPRA
THEIRS = timing.toppra.algorithm.TOPPRA


def problems(name: str, seeds: int = 3) -> list[tuple[tuple, dict]]:
    """The (args, kwargs) of every TOPP-RA the plans of scenario `name` make."""
    made = []

    class Seen(OURS):
        def __init__(self, *args, **kwargs) -> None:
            super().__init__(*args, **kwargs)
            made.append((args, kwargs))

    problem = load_problem(SCENARIOS / f"{name}.json")
    session = PlanningSession(problem.robot, problem.scene, problem.hands or None)
    session.set_constraints(problem.constraints)
    timing._TOPPRA = Seen
    try:
        for seed in range(seeds):
            options = problem.options.model_copy(update={"seed": seed})
            session.plan(problem.start, problem.goal, options, problem.group, safety=None)
    finally:
        timing._TOPPRA = OURS
    return made


def samples(route: type, args: tuple, kwargs: dict) -> tuple[np.ndarray, ...]:
    """One solve by `route` and its trajectory at every 10 ms and at the end."""
    extra = {} if route is OURS else {"parametrizer": "ParametrizeConstAccel"}
    trajectory = route(*args, **kwargs, **extra).compute_trajectory(0.0, 0.0)
    end = float(trajectory.path_interval[1])
    times = np.append(0.01 * np.arange(int(np.ceil(end / 0.01 - 1e-6))), end)
    return trajectory(times, 0), trajectory(times, 1), trajectory(times, 2)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args()
    print("| scenario | solves | gridpoints (median) | toppra's classes (ms) | hriplan's (ms) | ratio | same bits |")
    print("|---|---|---|---|---|---|---|")
    for name in NAMES:
        made = problems(name)
        same = all(all(np.array_equal(x, y) for x, y in zip(samples(THEIRS, *p), samples(OURS, *p))) for p in made)
        spent: dict[type, list[float]] = {THEIRS: [], OURS: []}
        for _ in range(args.rounds):
            for route in (THEIRS, OURS):
                started = time.process_time()
                for problem in made:
                    samples(route, *problem)
                spent[route].append((time.process_time() - started) / len(made) * 1e3)
        theirs, ours = statistics.median(spent[THEIRS]), statistics.median(spent[OURS])
        grid = statistics.median(len(kwargs["gridpoints"]) for _, kwargs in made)
        print(f"| {name} | {len(made)} | {grid:.0f} | {theirs:.2f} | {ours:.2f} | {ours / theirs:.2f} | {same} |")


if __name__ == "__main__":
    main()
