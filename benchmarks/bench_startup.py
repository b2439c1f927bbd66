"""Start-up: what a `hriplan` process spends before and besides its work (issue 21), the demo's
`plan` first, for this checkout and others in the same run.

Run: PYTHONPATH=src .venv/bin/python benchmarks/bench_startup.py [--reps 7] [--src OTHER/src ...]
(e.g. `git archive main src | tar -x -C /tmp/base` and `--src /tmp/base/src` for the code before a
change). The checkouts alternate run by run (this one, the other, this one, ...), so that both see
the same load; medians of wall and CPU (user + sys) seconds of fresh processes, warm: the
derivation cache on disk, by an untimed first run of each command.
- plan: `hriplan plan examples/handover_full_can.yaml` (the demo task; target <= 1.0 s wall);
- validate: `hriplan validate` of a trajectory that plan wrote;
- constraints: `hriplan constraints examples/handover_full_can.yaml -q`;
- help: `hriplan --help`.
Then, per command and checkout, the seconds `python -X importtime` counts for the top-level
imports and the heavy modules loaded (what lazy imports leave out: not timing, does not depend on
the load); and where the demo's `plan` process spends its time (PHASES: CPU seconds of each
group of imports, in the order the process needs them, then of the work, in fresh processes; CPU,
not wall, so that other jobs on the machine change them less).
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import bench_cli

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"
EXAMPLE = ROOT / "examples" / "handover_full_can.yaml"
HEAVY = (
    "matplotlib",
    "matplotlib.pyplot",
    "scipy",
    "scipy.optimize",
    "toppra",
    "ompl",
    "pinocchio",
    "rdflib",
    "owlready2",
    "meshcat",
    "fastapi",
    "pyarrow",
    "ray",
)
PLAN_TARGET = 1.0
# One fresh process: each group of imports the demo's `plan` needs, timed in turn, then the work
# (`hriplan plan` of the demo task, in process: the caches on disk warm).
PHASES = """
import contextlib, io, sys, time
marks = [time.process_time()]
import numpy; marks.append(time.process_time())
import pydantic, typer, yaml; marks.append(time.process_time())
import pinocchio, coal; marks.append(time.process_time())
import hriplan.planner.timing, toppra; marks.append(time.process_time())
import hriplan.cli.main, hriplan.cli.tasks, hriplan.cli.summary, hriplan.tasks.pipeline, hriplan.planner.session
marks.append(time.process_time())
with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):
    hriplan.cli.main.app(["plan", sys.argv[1], "-q", "-o", sys.argv[2]], prog_name="hriplan")
marks.append(time.process_time())
print(" ".join(f"{b - a:.4f}" for a, b in zip(marks, marks[1:])))
"""
PHASE_NAMES = (
    "numpy",
    "pydantic, typer, yaml",
    "pinocchio, coal",
    "toppra (its pyplot and scipy stood in by planner/timing.py), timing.py and the hriplan modules it imports",
    "hriplan's other modules",
    "the work (plan, warm)",
)


def run(args: list[str], src: Path) -> tuple[float, float]:
    """Wall and CPU seconds of one fresh `python -m hriplan.cli ARGS` with `src` first on the path."""
    env = bench_cli.process_env(src)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    subprocess.run([sys.executable, "-m", "hriplan.cli", *args], env=env, capture_output=True, check=True, timeout=600)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=7)
    parser.add_argument("--src", type=Path, nargs="*", default=[], help="other hriplan sources to measure alongside")
    args = parser.parse_args()
    sources = [SRC, *(p.resolve() for p in args.src)]
    names = [f"{s.parent.name}/src" if s != SRC else "this checkout" for s in sources]
    out = Path(tempfile.mkdtemp(prefix="hriplan-bench-startup-"))
    plan = ["plan", str(EXAMPLE), "-o", str(out / "can.json")]
    commands = {
        "plan (demo task)": plan,
        "validate": ["validate", str(out / "can.take_can.json")],
        "constraints": ["constraints", str(EXAMPLE), "-q"],
        "--help": ["--help"],
    }
    for src in sources:  # warm: the derivation cache on disk, and a trajectory to validate
        for command in commands.values():
            run(command, src)
    print(f"load average before: {os.getloadavg()[0]:.2f} ({os.cpu_count()} cores); {args.reps} runs each, alternating")
    print("\n| command | " + " | ".join(f"{n}: wall / CPU s" for n in names) + " |")
    print("|---|" + "---|" * len(sources))
    medians = {}
    for label, command in commands.items():
        times: dict[Path, list[tuple[float, float]]] = {src: [] for src in sources}
        for _ in range(args.reps):
            for src in sources:
                times[src].append(run(command, src))
        medians[label] = [
            (statistics.median(w for w, _ in times[s]), statistics.median(c for _, c in times[s])) for s in sources
        ]
        print(f"| {label} | " + " | ".join(f"{w:.2f} / {c:.2f}" for w, c in medians[label]) + " |", flush=True)
    print(f"\nload average after: {os.getloadavg()[0]:.2f}")
    wall = medians["plan (demo task)"][0][0]
    verdict = "met" if wall <= PLAN_TARGET else "missed"
    print(f"demo plan, this checkout: {wall:.2f} s wall (target <= {PLAN_TARGET} s: {verdict} under this load)")
    if len(sources) > 1:
        for name, (w, c) in zip(names[1:], medians["plan (demo task)"][1:], strict=True):
            print(f"  against {name}: wall x{wall / w:.2f}, CPU x{medians['plan (demo task)'][0][1] / c:.2f}")
    print()
    for label, command in commands.items():
        for name, src in zip(names, sources, strict=True):
            runs = [bench_cli.imported(command, src, HEAVY) for _ in range(3)]
            seconds, heavy = statistics.median(s for s, _ in runs), runs[0][1]
            print(
                f"- {label}, {name}: imports {seconds:.2f} s (importtime, median of 3); loaded: {', '.join(heavy) or 'none'}"
            )
    print_phases(sources, names, args.reps, out)


def phases(src: Path, out: Path) -> list[float]:
    """PHASES' CPU seconds in one fresh process with `src` first on the path."""
    env = bench_cli.process_env(src)
    done = subprocess.run(
        [sys.executable, "-c", PHASES, str(EXAMPLE), str(out / "phases.json")],
        env=env,
        capture_output=True,
        text=True,
        check=True,
        timeout=600,
    )
    return [float(x) for x in done.stdout.split()]


def print_phases(sources: list[Path], names: list[str], reps: int, out: Path) -> None:
    """The demo's `plan` process phase by phase, median of `reps` per checkout (alternating)."""
    runs: dict[Path, list[list[float]]] = {src: [] for src in sources}
    for _ in range(reps):
        for src in sources:
            runs[src].append(phases(src, out))
    print("\n| the demo's plan process, CPU s | " + " | ".join(names) + " |")
    print("|---|" + "---|" * len(sources))
    columns = [[statistics.median(r[k] for r in runs[src]) for k in range(len(PHASE_NAMES))] for src in sources]
    for k, name in enumerate(PHASE_NAMES):
        print(f"| {name} | " + " | ".join(f"{c[k]:.3f}" for c in columns) + " |")
    print("| sum (interpreter start-up not counted) | " + " | ".join(f"{sum(c):.3f}" for c in columns) + " |")


if __name__ == "__main__":
    main()
