"""What a task planner's question costs: `feasible` for the handover of
examples/task_planner/deliver_cup.yaml on a warm session (robot, collision model, reasoner loaded,
the question asked once before).

Run: PYTHONPATH=src .venv/bin/python benchmarks/bench_feasible.py [--repeats 9]
Prints the median wall and CPU milliseconds of: a new question (alice moved 2 mm each time, so nothing is
kept: derive, plan, validate and time, the retreat after the release), a new question the answer
of which is no (bob beside alice's hand, moved 2 mm each time), and the same question again (the
answer kept in the session). Then, for the new feasible questions, where the CPU time goes (the
machine may be shared; CPU time is what the work itself takes): the medians of the stages (inclusive, so they overlap where one calls another: the retreat's own
timing is in both "retreat" and "timing and validation").
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path

from hriplan.api import HumanSpec, PlanningSession, feasible, load_task
from hriplan.planner.session import PlanningSession as Session
from hriplan.tasks import pipeline
from hriplan.tasks.model import TaskFile

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
STEP = "hand_over_cup"
# (stage, owner, attribute): the functions timed, each the whole of its stage.
STAGES = [
    ("derive (rules, cached reasoning)", pipeline.TaskRunner, "derive_step"),
    ("search (IK, CBiRRT)", pipeline, "plan_motion"),
    ("timing and validation (ISO/TS 15066)", Session, "time"),
    ("retreat after the release", pipeline.TaskRunner, "_release"),
    ("collision scene rebuilds", Session, "set_scene"),
]


def timed(spent: dict[str, float], stage: str, function: Callable) -> Callable:
    def wrapper(*args, **kwargs):
        started = time.process_time()
        try:
            return function(*args, **kwargs)
        finally:
            spent[stage] += time.process_time() - started

    return wrapper


def moved(world: TaskFile, dx: float) -> TaskFile:
    alice = world.humans[0]
    return world.model_copy(
        update={"humans": [alice.model_copy(update={"position": (alice.position[0] + dx, alice.position[1])})]}
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=9)
    args = parser.parse_args()
    world = load_task(EXAMPLES / "task_planner" / "deliver_cup.yaml")
    session = PlanningSession(world.robot, hands=dict(world.hands))
    warm = feasible(session, world, STEP, EXAMPLES)
    assert warm.ok, warm.reason

    per_stage: dict[str, list[float]] = defaultdict(list)
    new, new_cpu, costs = [], [], []
    originals = [(owner, name, getattr(owner, name)) for _, owner, name in STAGES]
    for k in range(1, args.repeats + 1):
        spent: dict[str, float] = defaultdict(float)
        for (stage, owner, name), (_, _, function) in zip(STAGES, originals):
            setattr(owner, name, timed(spent, stage, function))
        try:
            started, cpu = time.perf_counter(), time.process_time()
            answer = feasible(session, moved(world, 0.002 * k), STEP, EXAMPLES)
            new.append(time.perf_counter() - started)
            new_cpu.append(time.process_time() - cpu)
        finally:
            for owner, name, function in originals:
                setattr(owner, name, function)
        assert answer.ok, answer.reason
        costs.append(answer.cost)
        for stage, _, _ in STAGES:
            per_stage[stage].append(spent[stage])

    blocked, blocked_cpu = [], []
    scene = session.checker.scene
    for k in range(args.repeats):
        bob = HumanSpec(name="bob", position=(-0.25 + 0.002 * k, 1.4), yaw=1.5708)
        session.set_scene(scene.model_copy(update={"humans": [bob]}))
        started, cpu = time.perf_counter(), time.process_time()
        answer = feasible(session, world, STEP, EXAMPLES)
        blocked.append(time.perf_counter() - started)
        blocked_cpu.append(time.process_time() - cpu)
        assert not answer.ok
    session.set_scene(scene)

    kept = []
    for _ in range(args.repeats):
        started = time.perf_counter()
        feasible(session, world, STEP, EXAMPLES)
        kept.append(time.perf_counter() - started)

    def ms(values: list[float]) -> str:
        return f"{1000 * statistics.median(values):8.1f} ms"

    print(f"feasible({STEP}) on a warm session, medians of {args.repeats} (wall, CPU of this process):")
    print(
        f"  new question, feasible      {ms(new)} {ms(new_cpu)}  cost {statistics.median(costs):.2f} s of timed motion"
    )
    print(f"  new question, infeasible    {ms(blocked)} {ms(blocked_cpu)}  {answer.status}: {answer.reason[:60]}...")
    print(f"  same question again (kept)  {ms(kept)}")
    print("where a new feasible question's CPU time goes (inclusive medians):")
    for stage, _, _ in STAGES:
        print(f"  {stage:38s}{ms(per_stage[stage])}")
    print("target: 20 ms for a new handover question:", "met" if statistics.median(new) <= 0.02 else "not met")


if __name__ == "__main__":
    main()
