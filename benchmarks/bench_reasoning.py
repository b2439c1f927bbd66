"""Reasoning latency: geometry-only changes, new qualitative situations, cold processes, sweeps.

Run: PYTHONPATH=src .venv/bin/python benchmarks/bench_reasoning.py [--reps 5] [--sweep 1000] [--scales 1 10 100]
Every time is a derivation as the pipeline does it: KnowledgeBase(situation) + derive(kb).
- geometry: the bystander example's step, the person moved 10 cm at a time without crossing a
  threshold (one reasoner run, then cache hits); target <= 10 ms.
- new qualitative situation, warm process (ontology schema loaded, nothing cached): every
  example situation and task step, in process ("fast") and with Pellet; target <= 100 ms.
- cold process: a fresh interpreter, empty cache, imports reported apart; target <= 1 s.
- sweep: `--sweep` variants of transport_hot_cup with the collaborator and the bystander at
  random positions, one shared cache (memory + disk); target 1000 in <= 30 s.
- scaling: handover_can with its objects and people repeated 10x and 100x, both reasoners.
Ratios between reasoners hold within one run; absolute times depend on the machine's load.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"
BYSTANDER = ROOT / "examples" / "transport_cup_bystander.yaml"


def timed(fn: Callable[[], object]) -> tuple[object, float]:
    start = time.perf_counter()
    result = fn()
    return result, time.perf_counter() - start


def cpu_timed(fn: Callable[[], object]) -> tuple[object, float, float]:
    """Wall and CPU time of this process (CPU time is what the load does not inflate)."""
    cpu = time.process_time()
    result, wall = timed(fn)
    return result, wall, time.process_time() - cpu


def derivation(situation, cache, reasoner: str = "fast"):
    from hriplan.ontology.knowledge_base import KnowledgeBase
    from hriplan.rules.infer import derive

    return derive(KnowledgeBase(situation, cache=cache, reasoner=reasoner))


class RunCounter:
    """Counts in-process reasoner runs (cache misses) by wrapping the knowledge base's `reason`."""

    def __init__(self) -> None:
        import hriplan.ontology.knowledge_base as kb

        self.runs, original = 0, kb.reason

        def counting(*args, **kwargs):
            self.runs += 1
            return original(*args, **kwargs)

        kb.reason = counting


def moved(situation, person: str, x: float, y: float):
    return situation.model_copy(
        update={
            "humans": [h.model_copy(update={"position": (x, y)}) if h.name == person else h for h in situation.humans]
        }
    )


def task_situations(path: Path) -> list:
    from hriplan.tasks.load import load_task
    from hriplan.tasks.pipeline import TaskRunner

    runner = TaskRunner(load_task(path), path.parent)
    runner.run(plan=False)
    return [kb.situation for kb in runner.knowledge_bases.values()]


def geometry_only(reps: int, counter: RunCounter) -> dict:
    from hriplan.ontology.cache import ReasoningCache

    (base,) = task_situations(BYSTANDER)
    person = base.humans[0]
    cache, before = ReasoningCache(None), counter.runs
    _, first = timed(lambda: derivation(base, cache))
    times, cpus = [], []
    for step in range(1, reps + 1):
        situation = moved(base, person.name, person.position[0] + 0.1 * step, person.position[1])
        _, wall, cpu = cpu_timed(lambda situation=situation: derivation(situation, cache))
        times.append(wall)
        cpus.append(cpu)
    return {
        "first_ms": first * 1e3,
        "median_ms": statistics.median(times) * 1e3,
        "max_ms": max(times) * 1e3,
        "cpu_median_ms": statistics.median(cpus) * 1e3,
        "moves": reps,
        "reasoner_runs": counter.runs - before,
    }


def corpus() -> dict:
    from hriplan.ontology.situation import EXAMPLES_DIR, load_situation

    found = {p.stem: load_situation(p) for p in sorted(EXAMPLES_DIR.glob("*.json"))}
    for path in sorted((ROOT / "examples").glob("*.yaml")):
        found |= {f"{path.stem}:{s.task.name}": s for s in task_situations(path)}
    return found


def new_situations(pellet_reps: int, workdir: Path) -> dict:
    from hriplan.ontology.cache import ReasoningCache

    situations = corpus()
    measured = [cpu_timed(lambda s=s: derivation(s, ReasoningCache(None)))[1:] for s in situations.values()]
    fast, cpus = [m[0] for m in measured], [m[1] for m in measured]
    names = list(situations)[:pellet_reps]
    pellet = [
        timed(lambda n=n: derivation(situations[n], ReasoningCache(workdir / f"pellet-{n}"), "pellet"))[1]
        for n in names
    ]
    return {
        "situations": len(situations),
        "fast_median_ms": statistics.median(fast) * 1e3,
        "fast_max_ms": max(fast) * 1e3,
        "fast_cpu_median_ms": statistics.median(cpus) * 1e3,
        "pellet_situations": len(names),
        "pellet_median_s": statistics.median(pellet),
        "pellet_max_s": max(pellet),
    }


def sweep(variants: int, workdir: Path, counter: RunCounter) -> dict:
    from hriplan.ontology.cache import ReasoningCache
    from hriplan.ontology.situation import EXAMPLES_DIR, load_situation

    base, rng = load_situation(EXAMPLES_DIR / "transport_hot_cup.json"), random.Random(1)
    situations = []
    for _ in range(variants):  # the collaborator and the bystander anywhere in front of the robot
        situation = base
        for person in ("col", "ann"):
            situation = moved(situation, person, rng.uniform(-2.0, 2.0), rng.uniform(0.3, 3.0))
        situations.append(situation)
    cache, before = ReasoningCache(workdir / "sweep"), counter.runs
    results, total, cpu = cpu_timed(lambda: [derivation(s, cache) for s in situations])
    scales = sorted({d.velocity_scale for d in results})  # type: ignore[union-attr]
    return {
        "variants": variants,
        "total_s": total,
        "cpu_s": cpu,
        "per_variant_ms": total / variants * 1e3,
        "reasoner_runs": counter.runs - before,
        "velocity_scales": scales,
    }


def scaled(factor: int):
    """The handover example with `factor` times as many objects and people (on a grid)."""
    from hriplan.ontology.situation import EXAMPLES_DIR, load_situation

    base = load_situation(EXAMPLES_DIR / "handover_can.json")
    objects, humans = list(base.objects), list(base.humans)
    for i in range(1, factor):
        dx, dy = 0.7 * (i % 10), 0.7 * (i // 10)
        for o in base.objects:
            if o.name != "can1":
                x, y, z = o.pose.xyz
                objects.append(
                    o.model_copy(
                        update={"name": f"{o.name}_{i}", "pose": o.pose.model_copy(update={"xyz": (x + dx, y + dy, z)})}
                    )
                )
        objects.append(
            base.objects[0].model_copy(
                update={
                    "name": f"cup_{i}",
                    "kind": "Cup",
                    "pose": base.objects[0].pose.model_copy(update={"xyz": (dx, 2.5 + dy, 0.8)}),
                }
            )
        )
        for h in base.humans:
            role = "Bystander" if h.role == "Receiver" else h.role
            humans.append(
                h.model_copy(
                    update={
                        "name": f"{h.name}_{i}",
                        "role": role,
                        "position": (h.position[0] + dx + 3.0, h.position[1] + dy),
                    }
                )
            )
    return base.model_copy(update={"objects": objects, "humans": humans})


def scaling(factor: int, workdir: Path) -> dict:
    from hriplan.ontology.cache import ReasoningCache

    situation = scaled(factor)
    fast, fast_s = timed(lambda: derivation(situation, ReasoningCache(None)))
    pellet, pellet_s = timed(lambda: derivation(situation, ReasoningCache(workdir / f"scale-{factor}"), "pellet"))
    assert fast == pellet, f"the reasoners disagree at {factor}x"
    return {
        "factor": factor,
        "objects": len(situation.objects),
        "humans": len(situation.humans),
        "fast_ms": fast_s * 1e3,
        "pellet_s": pellet_s,
        "constraints": len(fast.constraints),
    }  # type: ignore[union-attr]


def child(reasoner: str) -> None:
    """A fresh process: imports, then one derivation of a new situation (empty cache). Prints JSON."""
    start = time.perf_counter()
    from hriplan.ontology.cache import default_cache
    from hriplan.ontology.situation import EXAMPLES_DIR, load_situation

    imports = time.perf_counter() - start
    situation = load_situation(EXAMPLES_DIR / "handover_can.json")
    _, cold = timed(lambda: derivation(situation, default_cache(), reasoner))
    print(json.dumps({"imports_s": imports, "cold_s": cold}))


def fresh_process(workdir: Path, reasoner: str, run: int) -> dict:
    env = {**os.environ, "PYTHONPATH": str(SRC), "XDG_CACHE_HOME": str(workdir / f"xdg-{reasoner}-{run}")}
    command = [sys.executable, __file__, "--child", reasoner]
    return json.loads(subprocess.run(command, env=env, capture_output=True, text=True, check=True).stdout)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=5)
    parser.add_argument("--sweep", type=int, default=1000)
    parser.add_argument("--scales", type=int, nargs="+", default=[1, 10, 100])
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child)
        return
    with tempfile.TemporaryDirectory() as tmp:
        workdir = Path(tmp)
        print(f"load average at start: {os.getloadavg()[0]:.2f} ({os.cpu_count()} cpus)")
        for reasoner in ("fast", "pellet"):
            runs = [fresh_process(workdir, reasoner, r) for r in range(args.reps)]
            colds = sorted(r["cold_s"] for r in runs)
            print(
                f"cold process, {reasoner} ({args.reps} runs): imports median {statistics.median(r['imports_s'] for r in runs):.2f} s, "
                f"first derivation median {statistics.median(colds):.3f} s ({colds[0]:.3f}-{colds[-1]:.3f})"
            )
        os.environ["XDG_CACHE_HOME"] = str(workdir / "xdg-main")
        counter = RunCounter()
        g = geometry_only(args.reps * 4, counter)
        print(
            f"geometry only ({g['moves']} moves of 10 cm): first {g['first_ms']:.1f} ms, then median {g['median_ms']:.2f} ms "
            f"(max {g['max_ms']:.2f}; CPU median {g['cpu_median_ms']:.2f}), reasoner runs {g['reasoner_runs']}"
        )
        n = new_situations(args.reps, workdir)
        print(
            f"new qualitative situation, warm process: fast median {n['fast_median_ms']:.1f} ms (max {n['fast_max_ms']:.1f}; "
            f"CPU median {n['fast_cpu_median_ms']:.1f}) over "
            f"{n['situations']} situations; Pellet median {n['pellet_median_s']:.2f} s (max {n['pellet_max_s']:.2f}) over "
            f"{n['pellet_situations']}; ratio {n['pellet_median_s'] * 1e3 / n['fast_median_ms']:.0f}x"
        )
        s = sweep(args.sweep, workdir, counter)
        print(
            f"sweep: {s['variants']} variants in {s['total_s']:.2f} s (CPU {s['cpu_s']:.2f} s; {s['per_variant_ms']:.2f} ms each), "
            f"reasoner runs {s['reasoner_runs']}, velocity scales {s['velocity_scales']}"
        )
        print("\n| scale | objects | humans | fast ms | Pellet s | constraints |")
        print("|---|---|---|---|---|---|")
        for factor in args.scales:
            r = scaling(factor, workdir)
            print(
                f"| {r['factor']}x | {r['objects']} | {r['humans']} | {r['fast_ms']:.1f} | {r['pellet_s']:.2f} | {r['constraints']} |"
            )
        print(f"\nload average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
