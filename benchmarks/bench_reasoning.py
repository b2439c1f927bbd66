"""Reasoning latency of the knowledge base: cold (JVM start), warm (cached), and scaling.

Run: PYTHONPATH=src .venv/bin/python benchmarks/bench_reasoning.py [--reps 5] [--scales 1 10 100]
- cold: KnowledgeBase(situation) on a cache miss (world build + Pellet in a JVM + fact
  extraction + cache write), in a process that has imported hriplan; also once in a fresh
  process, imports included. JVM CPU time (user + sys of child processes) is printed next to
  wall time because wall time depends on the machine's load.
- warm: the same situation again, from the in-memory cache and from the disk cache (what a
  new process sees).
- scaling: the handover example with its objects and people repeated 10x and 100x.
Targets: cold <= 1 s, warm <= 50 ms. The JVM's class-data archive is kept in a temporary cache
home made by this script: its first run creates the archive and is reported separately.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"


def children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


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
                objects.append(o.model_copy(update={"name": f"{o.name}_{i}", "pose": o.pose.model_copy(update={"xyz": (x + dx, y + dy, z)})}))
        objects.append(base.objects[0].model_copy(update={"name": f"cup_{i}", "kind": "Cup", "pose": base.objects[0].pose.model_copy(update={"xyz": (dx, 2.5 + dy, 0.8)})}))
        for h in base.humans:
            role = "Bystander" if h.role == "Receiver" else h.role
            humans.append(h.model_copy(update={"name": f"{h.name}_{i}", "role": role, "position": (h.position[0] + dx + 3.0, h.position[1] + dy)}))
    return base.model_copy(update={"objects": objects, "humans": humans})


def timed(fn):
    cpu, start = children_cpu(), time.perf_counter()
    result = fn()
    return result, time.perf_counter() - start, children_cpu() - cpu


def measure(factor: int, reps: int, workdir: Path) -> dict:
    from hriplan.ontology.cache import ReasoningCache
    from hriplan.ontology.knowledge_base import KnowledgeBase
    from hriplan.rules.infer import derive

    situation = scaled(factor)
    colds, cpus = [], []
    for rep in range(reps):
        cache = ReasoningCache(workdir / f"x{factor}-{rep}")
        kb, wall, cpu = timed(lambda cache=cache: KnowledgeBase(situation, cache=cache))
        colds.append(wall)
        cpus.append(cpu)
    _, warm_memory, _ = timed(lambda: KnowledgeBase(situation, cache=cache))
    _, warm_disk, _ = timed(lambda: KnowledgeBase(situation, cache=ReasoningCache(cache.directory)))
    derivation, derive_s, _ = timed(lambda: derive(kb))
    return {"factor": factor, "objects": len(situation.objects), "humans": len(situation.humans),
            "cold_s": statistics.median(colds), "cold_min_s": min(colds), "cold_max_s": max(colds),
            "jvm_cpu_s": statistics.median(cpus), "warm_memory_ms": warm_memory * 1e3, "warm_disk_ms": warm_disk * 1e3,
            "derive_ms": derive_s * 1e3, "constraints": len(derivation.constraints)}  # fmt: skip


def stages(workdir: Path) -> dict:
    """Where the cold time of the base situation goes."""
    from hriplan.ontology import reasoner
    from hriplan.ontology.assertions import situation_assertions
    from hriplan.ontology.vocabulary import ontology_source
    from hriplan.ontology.world import build_world
    from hriplan.rules.ruleset import load_rules

    situation = scaled(1)
    source = ontology_source()
    rules, facts = load_rules(), situation_assertions(situation)
    _, convert, _ = timed(lambda: source.ntriples)
    world, build, _ = timed(lambda: build_world(source, rules, situation, facts))
    _, pellet, cpu = timed(lambda: reasoner.run_pellet(world))
    _, extract, _ = timed(lambda: reasoner.extract_facts(world))
    _, dump, _ = timed(lambda: reasoner.dump_ntriples(world))
    return {"ontology_to_ntriples_ms": convert * 1e3, "build_world_ms": build * 1e3, "pellet_ms": pellet * 1e3, "pellet_jvm_cpu_ms": cpu * 1e3,
            "extract_facts_ms": extract * 1e3, "dump_ntriples_ms": dump * 1e3}  # fmt: skip


def child(cache_dir: str) -> None:
    """A fresh process: imports, then one cold KnowledgeBase (empty cache). Prints JSON."""
    start = time.perf_counter()
    from hriplan.ontology.cache import ReasoningCache
    from hriplan.ontology.knowledge_base import KnowledgeBase
    from hriplan.ontology.situation import EXAMPLES_DIR, load_situation

    imports = time.perf_counter() - start
    situation = load_situation(EXAMPLES_DIR / "handover_can.json")
    _, cold, cpu = timed(lambda: KnowledgeBase(situation, cache=ReasoningCache(cache_dir)))
    print(json.dumps({"imports_s": imports, "cold_s": cold, "jvm_cpu_s": cpu}))


def fresh_process(workdir: Path, run: str) -> dict:
    env = {**os.environ, "PYTHONPATH": str(SRC), "XDG_CACHE_HOME": str(workdir / "xdg")}
    command = [sys.executable, __file__, "--child", str(workdir / f"child-{run}")]
    return json.loads(subprocess.run(command, env=env, capture_output=True, text=True, check=True).stdout)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=5)
    parser.add_argument("--scales", type=int, nargs="+", default=[1, 10, 100])
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child)
        return
    with tempfile.TemporaryDirectory() as tmp:
        workdir = Path(tmp)
        os.environ["XDG_CACHE_HOME"] = str(workdir / "xdg")  # the JVM archive starts absent
        print(f"load average at start: {os.getloadavg()[0]:.2f} ({os.cpu_count()} cpus)")
        first = fresh_process(workdir, "first")
        print(f"first run ever (creates the JVM class-data archive): imports {first['imports_s']:.2f} s, "
              f"cold {first['cold_s']:.2f} s (JVM CPU {first['jvm_cpu_s']:.2f} s)")  # fmt: skip
        fresh = [fresh_process(workdir, str(rep)) for rep in range(args.reps)]
        colds = sorted(f["cold_s"] for f in fresh)
        print(f"fresh process, archive present ({args.reps} runs): imports {statistics.median(f['imports_s'] for f in fresh):.2f} s, "
              f"cold median {statistics.median(colds):.2f} s ({colds[0]:.2f}-{colds[-1]:.2f}), "
              f"JVM CPU {statistics.median(f['jvm_cpu_s'] for f in fresh):.2f} s")  # fmt: skip
        print("cold stages (base situation):", ", ".join(f"{k} {v:.0f}" for k, v in stages(workdir).items()))
        print("\n| scale | objects | humans | cold median (min-max) s | JVM CPU s | warm memory ms | warm disk ms | derive ms | constraints |")
        print("|---|---|---|---|---|---|---|---|---|")
        for factor in args.scales:
            r = measure(factor, args.reps if factor < 100 else max(1, args.reps // 2), workdir)
            print(f"| {r['factor']}x | {r['objects']} | {r['humans']} | {r['cold_s']:.2f} ({r['cold_min_s']:.2f}-{r['cold_max_s']:.2f}) "
                  f"| {r['jvm_cpu_s']:.2f} | {r['warm_memory_ms']:.2f} | {r['warm_disk_ms']:.1f} | {r['derive_ms']:.1f} | {r['constraints']} |")  # fmt: skip
        print(f"\nload average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
