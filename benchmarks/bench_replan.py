"""Re-plan after a perception update, through the plug-in API (issue "Reasoning at the speed of
perception"): the receiver of examples/handover_full_can_receiver.yaml moves 10 cm, and the
motion manager derives and plans the handover again on the same session.

Run: .venv/bin/python benchmarks/bench_replan.py [--updates 10] [--switch-kernels] [--switch-still] [--freeze]
Prints, per update, the wall time of `run_task` (derive + plan + time, warm session and
reasoner) and of its parts, then the medians, and the median CPU time per re-plan of each stage
(STAGES: inclusive, a stage inside another is indented under it), the full garbage collections
during the re-plans, the objects frozen and left to them, and the resident memory after update
10 and the last. Times are seconds on this
machine; compare the parts with each other, in one run. Last, the ISO/TS 15066 monitor on the
last re-plan's own calls: the batched `ApproachMonitor.speed_scale` against the per-point route it
replaced (coal on every pair through `CollisionChecker.person_pairs`, pinocchio Jacobians), same
numbers checked.
`--save FILE` writes every update's outcome (JSON, one line an update, planning times left out);
`--against FILE` compares each update's with that file's (another tree's run): re-plans must
give the same trajectories, bit for bit, and the same report; its constraints' largest margins
may differ by 1e-12 (with the kernels on, validation computes them in one compiled batch, its
kinematics rounding apart from pinocchio's by ~1e-16). `--rtol R` lets every number differ by R
relatively (the same structure, sample counts and statuses): with the kernels on, the ISO/TS
15066 monitor's compiled route rounds apart from the numpy route's by ~1e-16, which TOPP-RA
carries into the samples at ~1e-12; it prints the largest relative difference found.
"""

from __future__ import annotations

import argparse
import contextlib
import gc
import json
import os
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pinocchio as pin
from cpu_spent import outermost_cpu

from hriplan.api import PlanningSession, load_task, run_task
from hriplan.planner import session as session_module
from hriplan.planner.kernels import load_kernels
from hriplan.planner.session import PlanningSession as Session
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.kernel_switch import kernels_on, use_kernels
from hriplan.safety.approach import CLOSING, ApproachMonitor
from hriplan.safety.separation import kept_speeds
from hriplan.tasks import pipeline
from hriplan.tasks.pipeline import TaskRunner

EXAMPLE = Path(__file__).parents[1] / "examples" / "handover_full_can_receiver.yaml"
# (label, owner, attributes): CPU time spent in each per re-plan; a label's leading spaces say
# which stage above holds it. Functions are wrapped where the re-plan looks them up; one the
# owner lacks is left out (a checker before 2026-12-03 built in set_world, now when first asked).
STAGES = (
    ("derivation (rules, nearness)", TaskRunner, ("derive_step", "step_knowledge")),
    ("planning (the handover)", pipeline, ("plan_motion",)),
    ("retreat path after the release", pipeline, ("retreat_path",)),
    ("leave check", Session, ("leave",)),
    ("time and validate (both motions)", Session, ("time",)),
    ("  TOPP-RA with the ISO/TS 15066 limit", session_module, ("time_parameterize",)),
    ("    ISO/TS 15066 monitor (speed_scale)", ApproachMonitor, ("speed_scale",)),
    ("  dense validation", session_module, ("validate_path",)),
    ("    closest person distance (report)", CollisionChecker, ("human_distances", "closest_human")),
    ("    collision checks", CollisionChecker, ("in_collision", "first_collision")),
    ("collision builds (anywhere)", CollisionChecker, ("set_world", "_ready", "_people_ready")),
)


def _not_held(checker: CollisionChecker, joints: object, q_base: object) -> contextlib.AbstractContextManager:
    """`CollisionChecker.moving` as a no-op: every pair asked at every state (--switch-still)."""
    return contextlib.nullcontext()


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--updates", type=int, default=10)
    parser.add_argument("--save", type=Path, help="write each update's outcome here (JSON lines)")
    parser.add_argument("--against", type=Path, help="compare each update's outcome with this --save file")
    parser.add_argument("--rtol", type=float, default=0.0, help="--against: numbers may differ by this, relatively")
    parser.add_argument(
        "--freeze",
        action="store_true",
        help="gc.collect() and gc.freeze() after the warm-up re-plan (a tree with hriplan/collector.py's "
        "freeze_after_first_plan has done so in the warm-up: the flag then adds nothing but a second freeze)",
    )
    parser.add_argument(
        "--switch-kernels",
        action="store_true",
        help="the compiled kernels on for two updates, off for two, and so on: median CPU of each (--save and "
        "--against then hold both routes' outcomes; use a multiple of 4 updates for equal shares)",
    )
    parser.add_argument(
        "--switch-still",
        action="store_true",
        help="CollisionChecker.moving in use for two updates, a no-op for two (every pair asked at every state), "
        "and so on: median CPU and collision checks of each",
    )
    args = parser.parse_args()
    held_moving = getattr(CollisionChecker, "moving", None)  # a tree before it has none
    if args.switch_still and held_moving is None:
        parser.error("--switch-still needs CollisionChecker.moving")
    if args.switch_kernels and not load_kernels():
        parser.error("--switch-kernels needs numba (pip install 'hriplan[fast]')")
    task = load_task(EXAMPLE)
    session = PlanningSession(task.robot, hands=task.hands)
    timing = {"time": 0.0}
    original_time = Session.time

    def timed_stage(self, *a, **k):
        started = time.perf_counter()
        try:
            return original_time(self, *a, **k)
        finally:
            timing["time"] += time.perf_counter() - started

    Session.time = timed_stage
    spent = _spent_in_stages()
    batched, compared = (
        ApproachMonitor.speed_scale,
        {"on": False, "points": 0, "batch": 0.0, "point": 0.0, "worst": 0.0},
    )

    def comparing(self, xs, dxs):
        if compared["on"]:
            _compare(batched, self, np.asarray(xs), np.asarray(dxs), compared)
        return batched(self, xs, dxs)

    ApproachMonitor.speed_scale = comparing
    run_task(task, session, advance=False)  # warm: robot, collision model, reasoner's schema
    if args.freeze:  # what the warm-up made is kept out of later full garbage collections
        gc.collect()
        gc.freeze()
    totals, cpu, stages, by_stage, outcomes, kernels, held = [], [], [], [], [], [], []
    full = _full_collections()
    resident = {}
    bob = task.humans[0]
    for k in range(args.updates):
        # 10 cm to and fro, plus 1 mm more each time: every update is a place she has not been
        dx = (0.1 if k % 2 == 0 else 0.0) + 0.001 * k
        reach = {side: (x + dx, y, z) for side, (x, y, z) in bob.reach.items()}  # the hand moves with her
        moved = bob.model_copy(update={"position": (bob.position[0] + dx, bob.position[1]), "reach": reach})
        variant = task.model_copy(update={"humans": [moved]})
        timing["time"] = 0.0
        spent.clear()
        if args.switch_kernels:
            use_kernels(k // 2 % 2 == 0)
        if args.switch_still:
            CollisionChecker.moving = held_moving if k // 2 % 2 == 0 else _not_held
        kernels.append(kernels_on())
        held.append(getattr(CollisionChecker, "moving", None) is held_moving)
        started, started_cpu = time.perf_counter(), time.process_time()
        outcome = run_task(variant, session, advance=False)  # each re-plan from the task's start
        totals.append(time.perf_counter() - started)
        cpu.append(time.process_time() - started_cpu)
        stages.append(timing["time"])
        by_stage.append(dict(spent))
        if args.save or args.against:  # kept only then: the resident memory below is the session's
            outcomes.append(_without_planning_times(outcome.model_dump(mode="json")))
        if k + 1 in (min(10, args.updates), args.updates):
            resident[k + 1] = _resident_mb()
        print(
            f"update {k + 1}: {outcome.steps[-1].status:>8} in {totals[-1]:.3f} s, CPU {cpu[-1]:.3f} s (timing stage {stages[-1]:.3f} s)"
        )
    print(
        f"median: {statistics.median(totals):.3f} s per re-plan (CPU {statistics.median(cpu):.3f} s, the most "
        f"{max(cpu):.3f} s), of which the timing stage {statistics.median(stages):.3f} s"
    )
    gc.callbacks.remove(full.pop())
    print(
        f"full garbage collections during the re-plans: {len(full)}, {1e3 * sum(full):.0f} ms in all "
        f"({', '.join(f'{1e3 * t:.0f}' for t in full) or '-'} ms); objects frozen {gc.get_freeze_count()}, "
        f"traversed by a full collection {len(gc.get_objects())}; resident memory "
        + ", ".join(f"{mb:.1f} MB after update {k}" for k, mb in resident.items())
    )
    if args.switch_kernels:
        on, off = ([t for t, k in zip(cpu, kernels) if k == side] for side in (True, False))
        print(
            f"median CPU per re-plan: kernels on {1e3 * statistics.median(on):.1f} ms ({len(on)} updates), "
            f"off {1e3 * statistics.median(off):.1f} ms ({len(off)})"
        )
    if args.switch_still:
        checks = [s.get("    collision checks", 0.0) for s in by_stage]
        for name, values in (("CPU per re-plan", cpu), ("collision checks", checks)):
            on, off = ([t for t, h in zip(values, held) if h == side] for side in (True, False))
            print(
                f"median {name}: still pairs held {1e3 * statistics.median(on):.1f} ms ({len(on)} updates), "
                f"every pair asked {1e3 * statistics.median(off):.1f} ms ({len(off)})"
            )
        CollisionChecker.moving = held_moving
    print("median CPU per re-plan by stage (inclusive):")
    for label, _, _ in STAGES:
        print(f"  {label:44s} {1e3 * statistics.median(s.get(label, 0.0) for s in by_stage):6.1f} ms")
    if args.save:
        args.save.write_text("".join(json.dumps(o, sort_keys=True) + "\n" for o in outcomes))
    if args.against:
        before = [json.loads(line) for line in args.against.read_text().splitlines()]
        widest = [0.0]
        same = [k + 1 for k, (a, b) in enumerate(zip(outcomes, before)) if _same_outcome(a, b, args.rtol, widest)]
        within = f" (numbers within {args.rtol:g} relatively, the largest {widest[0]:.1e})" if args.rtol else ""
        print(f"outcomes identical to {args.against} at {len(same)} of {len(outcomes)} updates{within}")
        assert len(same) == len(outcomes) == len(before), (
            f"updates that differ: {sorted(set(range(1, len(outcomes) + 1)) - set(same))}"
        )
    compared["on"] = True
    run_task(variant, session, advance=False)
    c = compared
    print(
        f"speed_scale on one re-plan's {c['points']} points: batched {1e3 * c['batch']:.1f} ms, per point through coal "
        f"{1e3 * c['point']:.1f} ms ({c['point'] / c['batch']:.1f}x); largest relative difference {c['worst']:.1e} (coal's points "
        f"on a cylinder, GJK run to 1e-12, are ~1e-6 m from the exact ones the compiled route finds)"
    )


def _full_collections() -> list:
    """The seconds each full (generation 2) garbage collection takes from now on; its last item is
    the gc callback that measures them, to remove."""
    seconds: list = []
    began = [0.0]

    def measure(phase: str, info: dict) -> None:
        if info["generation"] == 2:
            if phase == "start":
                began[0] = time.perf_counter()
            else:
                seconds.insert(len(seconds) - 1, time.perf_counter() - began[0])

    seconds.append(measure)
    gc.callbacks.append(measure)
    return seconds


def _resident_mb() -> float:
    """This process's resident memory (Linux), MB."""
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def _without_planning_times(value):
    """`value` (a JSON tree) without its planning_time entries: the clock, not the result."""
    if isinstance(value, dict):
        return {k: _without_planning_times(v) for k, v in value.items() if k != "planning_time"}
    if isinstance(value, list):
        return [_without_planning_times(v) for v in value]
    return value


def _same_outcome(a, b, rtol: float, widest: list[float], loose: bool = False) -> bool:
    """Two outcomes (JSON trees) equal, every number to `rtol` relatively (the largest relative
    difference kept in widest[0]; with an `rtol`, numbers within 1e-15 of zero equal too: a
    rest's velocities, ~1e-17 of either sign) and those under a `max_violation` key (`loose`)
    also to 1e-12."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(
            _same_outcome(a[k], b[k], rtol, widest, loose or k == "max_violation") for k in a
        )
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same_outcome(x, y, rtol, widest, loose) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, float) and a != b:
        if rtol and max(abs(a), abs(b)) <= 1e-15:
            return True
        relative = abs(a - b) / max(abs(a), abs(b))
        widest[0] = max(widest[0], relative)
        return relative <= rtol or (loose and abs(a - b) <= 1e-12)
    return a == b


def _spent_in_stages() -> dict[str, float]:
    """Wrap every STAGES function to add its CPU time (outermost calls of the label's functions
    only) under its label."""
    spent: dict[str, float] = {}
    for label, owner, names in STAGES:
        depth = [0]

        def add(seconds: float, _label: str = label) -> None:
            spent[_label] = spent.get(_label, 0.0) + seconds

        for name in (n for n in names if hasattr(owner, n)):
            setattr(owner, name, outermost_cpu(getattr(owner, name), depth, add))
    return spent


def _compare(batched: Callable, monitor: ApproachMonitor, xs: np.ndarray, dxs: np.ndarray, stats: dict) -> None:
    """`batched` speed_scale (a fresh monitor: no memo) against the per-point coal route, same inputs."""
    fresh = ApproachMonitor(monitor.robot, monitor.checker, monitor.policy, monitor.group, monitor.base)
    started = time.perf_counter()
    new = batched(fresh, xs, dxs)
    stats["batch"] += time.perf_counter() - started
    started = time.perf_counter()
    old = np.array([_per_point_scale(fresh, x, dx) for x, dx in zip(xs, dxs)])
    stats["point"] += time.perf_counter() - started
    finite = np.isfinite(old)
    assert np.array_equal(finite, np.isfinite(new)), "the two routes disagree on where the speed is limited"
    stats["worst"] = max(
        stats["worst"], float(np.max(np.abs(new[finite] - old[finite]) / np.maximum(old[finite], 1.0), initial=0.0))
    )
    stats["points"] += len(xs)


def _per_point_scale(monitor: ApproachMonitor, x: np.ndarray, dx: np.ndarray) -> float:
    """The speed scale at one point the pre-batch way: every pair through coal, Jacobian twists."""
    robot, scale = monitor.robot, np.inf
    model, data, q = robot.model, robot.model.createData(), monitor.full(x)
    planned = {model.getJointId(j) for j in robot.group_joints(monitor.group)}
    velocity = np.zeros(model.nv)
    velocity[[model.joints[j].idx_v for j in planned]] = dx
    pin.computeJointJacobians(model, data, q)
    moved = [j for j in range(1, model.njoints) if planned & set(model.supports[j])]
    twists = {j: pin.getJointJacobian(model, data, j, pin.LOCAL_WORLD_ALIGNED) @ velocity for j in moved}
    for person in monitor.people:
        pairs = monitor.checker.person_pairs(q, person.name)
        rows = np.flatnonzero([j in twists for j in pairs.joints])
        twist = np.array([twists[j] for j in pairs.joints[rows]])
        origin = np.array([data.oMi[int(j)].translation for j in pairs.joints[rows]])
        v = twist[:, :3] + np.cross(twist[:, 3:], pairs.robot_point[rows] - origin)
        d, capsules = pairs.distance[rows], [pairs.capsules[k] for k in rows]
        whole = np.array([person.contact_region(c) is not None for c in capsules]) | (d <= 1e-6)
        towards = np.einsum("ij,ij->i", v, pairs.person_point[rows] - pairs.robot_point[rows]) / np.maximum(d, 1e-6)
        approach = np.where(whole, np.linalg.norm(v, axis=1), towards)
        allowed = kept_speeds(monitor.policy, person, d, capsules)  # with the policy's margin, as timed
        closing = approach > CLOSING
        if closing.any():
            scale = min(scale, float(np.min(allowed[closing] / approach[closing])))
    return scale


if __name__ == "__main__":
    main()
