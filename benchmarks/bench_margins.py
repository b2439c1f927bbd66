"""Constraint margins and their gradients, this checkout against another tree's code in one run.

Run: PYTHONPATH=src .venv/bin/python benchmarks/bench_margins.py [--src /tmp/base/src] [--rounds 2]
Per scenario (a, b, c of benchmarks/scenarios): the cost of `ConstraintEvaluator.margins` and
`.gradients` per state (states drawn uniformly in the group's joint box, best of 5 passes), of
margins as dense validation asks them (2000 states at once: `margins_many`, compiled with
HRIPLAN_KERNELS=1; state by state in a tree without it) and the
plan median of `PlanningSession.plan` over seeds; the table gives the best round's per-state costs
and the median round's plan medians. With --src, each round runs both trees in turn in fresh
processes (alternating) and the table gives their ratio; the trees' numbers are compared
too: the margins and gradient rows of every constraint kind (box, sphere, cylinder, cone inside
and outside; orientation with 0, 1, 2 free axes and with a tolerance gradient) at 500 random
MADAR states, the kinds `margins_many` compiles (all but 0 and 2 free axes) asked at once, and
the planned paths of each seed.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from trees import runs_by_tree

SCENARIOS = Path(__file__).parent / "scenarios"
PLANS = {"a_ur5_upright_box": 12, "b_madar_handover": 12, "c_madar_peg_in_hole": 4}


def _per_state_us(call, states: np.ndarray) -> float:
    best = np.inf
    for _ in range(5):
        start = time.perf_counter()
        for s in states:
            call(s)
        best = min(best, (time.perf_counter() - start) / len(states) * 1e6)
    return best


def every_kind(robot):
    """An evaluator on MADAR's right arm with one constraint of each kind, region and axis count."""
    from hriplan.planner.constraints.binding import bind
    from hriplan.planner.constraints.evaluator import ConstraintEvaluator
    from hriplan.planner.constraints.spec import (
        BoxConstraint,
        ConeConstraint,
        CylinderConstraint,
        FrameRef,
        OrientationConstraint,
        SphereConstraint,
    )
    from hriplan.robots.collision import CollisionChecker
    from hriplan.robots.scene import Scene
    from hriplan.robots.spatial import Pose

    joints, tool = robot.group_joints("right_arm"), "right_tool"
    frame = FrameRef(offset=Pose(xyz=(0.2, 0.5, 1.0), rpy=(0.1, 0.2, 0.3)))
    target = Pose(rpy=(0.3, 0.2, 0.1))
    specs = [
        OrientationConstraint(id="o0", joints=joints, target_link=tool, target=target, frame=frame, tolerance=0.1),
        OrientationConstraint(id="o1", joints=joints, target_link=tool, free_axes=["y"], target=target, frame=frame),
        OrientationConstraint(id="o2", joints=joints, target_link=tool, free_axes=["x", "y"], target=target),
        OrientationConstraint(
            id="o1g", joints=joints, target_link=tool, free_axes=["z"], tolerance=0.1, tolerance_gradient=0.2
        ),
    ]
    for region in ("inside", "outside"):
        kw = {"joints": joints, "target_link": tool, "frame": frame, "region": region}
        specs += [
            BoxConstraint(id=f"box_{region}", size=(0.3, 0.4, 0.5), **kw),
            SphereConstraint(id=f"sphere_{region}", radius=0.5, **kw),
            CylinderConstraint(id=f"cylinder_{region}", radius=0.3, height=0.6, **kw),
            ConeConstraint(id=f"cone_{region}", radius=0.4, height=0.6, **kw),
        ]
    bound = bind(specs, robot, CollisionChecker(robot, Scene()))
    bound[3].p_goal = np.array([0.1, 0.6, 1.0])
    return ConstraintEvaluator(robot, bound, "right_arm", np.zeros(robot.model.nq))


def _at_once(evaluator):
    """Margins of many configurations as dense validation asks them (a tree without
    `margins_many` asked them state by state)."""
    many = getattr(evaluator, "margins_many", None)
    return many if many is not None else lambda qs: np.array([evaluator.margins(q) for q in qs])


def measure() -> dict:
    """One tree's numbers (the code on sys.path)."""
    from hriplan.planner.constraints.binding import bind
    from hriplan.planner.constraints.evaluator import ConstraintEvaluator
    from hriplan.planner.problem import load_problem
    from hriplan.planner.session import PlanningSession
    from hriplan.robots.model import load_robot

    out: dict = {}
    evaluator = every_kind(load_robot("madar"))
    xs = np.random.default_rng(0).uniform(-3.0, 3.0, (500, evaluator.n))
    values = [evaluator.margins(evaluator.full(x)) for x in xs]
    grads = [evaluator.gradients(x) for x in xs]
    covered = [c for c in evaluator.constraints if c.id not in ("o0", "o2")]
    compiled = ConstraintEvaluator(evaluator.robot, covered, "right_arm", evaluator.q)
    out["numbers"] = {
        "margins": np.array(values).tolist(),
        "margins at once": _at_once(compiled)(compiled.full_many(xs)).tolist(),
        "gradient pass margins": np.array([g[0] for g in grads]).tolist(),
        "gradients": np.array([g[1] for g in grads]).tolist(),
    }
    out["paths"] = {}
    for scenario, seeds in PLANS.items():
        problem = load_problem(SCENARIOS / f"{scenario}.json")
        session = PlanningSession(problem.robot, problem.scene, problem.hands or None)
        session.set_constraints(problem.constraints)
        robot = session.robot
        bound = bind(list(session.constraints.values()), robot, session.checker)
        evaluator = ConstraintEvaluator(robot, bound, problem.group, robot.configuration(problem.start))
        low, high = robot.limits(problem.group)
        xs = np.random.default_rng(1).uniform(low, high, (2000, len(low)))
        out[f"{scenario} margins (us)"] = _per_state_us(evaluator.margins, np.array([evaluator.full(x) for x in xs]))
        out[f"{scenario} gradients (us)"] = _per_state_us(evaluator.gradients, xs)
        at_once, qs = _at_once(evaluator), evaluator.full_many(xs)
        out[f"{scenario} margins, 2000 states at once (us a state)"] = _per_state_us(at_once, qs[None]) / len(qs)
        seconds, paths = [], []
        for seed in range(seeds):
            options = problem.options.model_copy(update={"seed": seed})
            start = time.perf_counter()
            result = session.plan(problem.start, problem.goal, options, problem.group, safety=None)
            seconds.append(time.perf_counter() - start)
            paths.append(np.array(result.motion.path).tolist() if result.motion else [])
        out[f"{scenario} plan median (s)"] = float(np.median(seconds))
        out["paths"][scenario] = paths
    return out


def _largest_difference(a, b) -> float:
    a, b = np.array(a, dtype=float), np.array(b, dtype=float)
    if a.shape != b.shape:
        return np.inf
    return float(np.abs(a - b).max(initial=0.0))  # two unsolved plans: no path either


def _same(a, b) -> bool:
    return _largest_difference(a, b) <= 1e-9  # rad


def main() -> None:
    runs, compared = runs_by_tree(__doc__.splitlines()[0], __file__, measure)
    mine = runs["this checkout"]
    keys = [k for k in mine[0] if k not in ("numbers", "paths")]
    print("| measure | this checkout |" + (" other | ratio |" if compared else ""))
    print("|---|---|" + ("---|---|" if compared else ""))
    for key in keys:
        # per state: the best round (the load of a shared machine only adds); plans: the median
        pick = np.min if "(us" in key else np.median
        value = float(pick([r[key] for r in mine]))
        row = f"| {key} | {value:.4g} |"
        if compared:
            theirs = float(pick([r[key] for r in runs["other"]]))
            row += f" {theirs:.4g} | {value / theirs:.2f} |"
        print(row)
    if compared:
        other = runs["other"][0]
        for key, numbers in mine[0]["numbers"].items():
            print(f"{key}: largest difference {_largest_difference(numbers, other['numbers'][key]):.3g}")
        for scenario, paths in mine[0]["paths"].items():
            # a plan that ends at its time limit depends on the clock: the tree's own rounds tell
            repeat = [
                sum(_same(p, q) for p, q in zip(r[0]["paths"][scenario], r[-1]["paths"][scenario]))
                for r in runs.values()
            ]
            same = sum(_same(p, q) for p, q in zip(paths, other["paths"][scenario]))
            print(
                f"{scenario}: {same} of {len(paths)} paths the same as the other tree's (each tree's first and last rounds: {repeat})"
            )


if __name__ == "__main__":
    main()
