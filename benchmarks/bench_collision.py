"""Collision check and plan medians, this checkout against another tree's code in one run.

Run: PYTHONPATH=src .venv/bin/python benchmarks/bench_collision.py [--src /tmp/base/src] [--rounds 2]
Per robot (UR5, MADAR): the cost of `in_collision` on free states drawn uniformly and on the states
of planned paths (also "in its motion": within `CollisionChecker.moving` of the planned group
from the start, as the planner asks them; the full check in a tree without it); per scenario (benchmarks/scenarios, a without its constraints too): the median
seconds of `PlanningSession.plan` with the scenario's own options (CBiRRT), over seeds, and the
solved count. With --src, each round runs both trees in turn in fresh processes (alternating, so
that the machine's load falls on both alike) and the table gives their ratio.
"""

from __future__ import annotations

import contextlib
import time
from pathlib import Path

import numpy as np
from trees import runs_by_tree

SCENARIOS = Path(__file__).parent / "scenarios"
# Seeds a scenario plans in one session (its first plan makes the session's trees and caches):
# the peg-in-hole's 4 put that first plan and its one slow seed (2: ~20 000 states) in the middle
# of its median, so 12, as the others (its 12 plans cost ~1.5 s).
PLANS = {"a_ur5_upright_box": 12, "a_ur5_unconstrained": 12, "b_madar_handover": 12, "c_madar_peg_in_hole": 12}
UNCONSTRAINED = {"a_ur5_unconstrained": "a_ur5_upright_box"}


def _per_state_us(checker, states: np.ndarray, clock=time.perf_counter) -> float:
    best = np.inf
    for _ in range(3):
        start = clock()
        for q in states:
            checker.in_collision(q)
        best = min(best, (clock() - start) / len(states) * 1e6)
    return best


def in_motion(checker, session, problem):
    """The block within which the planner asks a scenario's states (`CollisionChecker.moving`: the
    planned group from the start); none in a tree without it, whose checks are then the full ones."""
    moving = getattr(checker, "moving", None)
    if moving is None:
        return contextlib.nullcontext()
    group = problem.group or session.robot.default_group
    return moving(group, session.robot.configuration(problem.start))


def free_states(checker, rng: np.random.Generator, drawn: int = 3000, kept: int = 500) -> np.ndarray:
    """Up to `kept` collision-free states among `drawn` uniformly within the joint limits."""
    model = checker.robot.model
    states = rng.uniform(model.lowerPositionLimit, model.upperPositionLimit, (drawn, model.nq))
    return np.array([q for q in states if not checker.in_collision(q)][:kept])


def scenario_plans(scenario: str, seeds: int, clock=time.perf_counter):
    """Plan `scenario` (benchmarks/scenarios, with its own options, CBiRRT) once a seed on one
    session: the session, the path's states (full configurations), the seconds each plan took
    by `clock`, the solved count, the results and the problem."""
    from hriplan.planner.problem import load_problem
    from hriplan.planner.session import PlanningSession

    problem = load_problem(SCENARIOS / f"{UNCONSTRAINED.get(scenario, scenario)}.json")
    session = PlanningSession(problem.robot, problem.scene, problem.hands or None)
    session.set_constraints([] if scenario in UNCONSTRAINED else problem.constraints)
    seconds, states, results = [], [], []
    base = session.robot.configuration(problem.start)
    for seed in range(seeds):
        options = problem.options.model_copy(update={"seed": seed})
        start = clock()
        result = session.plan(problem.start, problem.goal, options, problem.group, safety=None)
        seconds.append(clock() - start)
        results.append(result)
        if result.motion is not None:
            states += [session.robot.configuration(x, problem.group, base=base) for x in result.motion.path]
    solved = sum(r.status == "solved" for r in results)
    return session, np.array(states), seconds, solved, results, problem


def measure() -> dict:
    """One tree's numbers (the code on sys.path)."""
    from hriplan.robots.collision import CollisionChecker
    from hriplan.robots.model import load_robot

    out: dict = {}
    rng = np.random.default_rng(0)
    for name in ("ur5", "madar"):
        checker = CollisionChecker(load_robot(name))
        free = free_states(checker, rng)
        out[f"{name} free state (us)"] = _per_state_us(checker, free)
    for scenario, seeds in PLANS.items():
        session, states, seconds, solved, _, problem = scenario_plans(scenario, seeds)
        out[f"{scenario} plan median (s)"] = float(np.median(seconds))
        out[f"{scenario} solved"] = solved
        if len(states):
            out[f"{scenario} path state (us)"] = _per_state_us(session.checker, states)
            with in_motion(session.checker, session, problem):
                out[f"{scenario} path state in its motion (us)"] = _per_state_us(session.checker, states)
    return out


def main() -> None:
    runs, compared = runs_by_tree(__doc__.splitlines()[0], __file__, measure)
    keys = list(runs["this checkout"][0])
    header = "| measure | this checkout |" + (" other | ratio |" if compared else "")
    print(header)
    print("|---|---|" + ("---|---|" if compared else ""))
    for key in keys:
        print(median_row(runs, key, compared))


def median_row(runs: dict[str, list[dict]], key: str, compared: bool) -> str:
    """A table row: the median of `key` over this checkout's rounds, and the other's and the ratio."""
    mine = float(np.median([r[key] for r in runs["this checkout"]]))
    row = f"| {key} | {mine:.4g} |"
    if compared:
        theirs = float(np.median([r.get(key, np.nan) for r in runs["other"]]))
        row += f" {theirs:.4g} | {mine / theirs:.2f} |"
    return row


if __name__ == "__main__":
    main()
