"""Command-line latency: what a user waits for, in fresh processes (imports included).

Run: PYTHONPATH=src .venv/bin/python benchmarks/bench_cli.py [--reps 5] [--src OTHER/src ...]
(`--src` measures other checkouts' code too, e.g. the code before a change, each command for
each checkout in turn, so that they are compared under the same load.)
- help: `hriplan --help` (target <= 0.3 s).
- constraints: warm `hriplan constraints examples/handover_full_can.yaml -q` (reasoning cached on
  disk by an untimed first run; target <= 1 s), and the same process's import time alone.
- demo plan: warm `hriplan plan examples/handover_full_can.yaml -q` (the plan step of
  `make demo`: two steps reasoned, planned, validated, timed and written; target <= 2 s) and
  the whole `make demo` command (plus the viewer page and the figures).
Medians of wall and CPU seconds. Wall times depend on the machine's load, so the load average is
printed with them (CPU time depends on it far less); the modules
a command imports (what the lazy imports remove) do not, and are listed too.
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

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"
EXAMPLE = ROOT / "examples" / "handover_full_can.yaml"
HEAVY = ("ompl", "toppra", "scipy", "matplotlib", "meshcat", "rdflib", "owlready2", "pinocchio")


def process_env(src: Path) -> dict[str, str]:
    """The environment of a measured process: `src` first on the path, and bytecode written (a
    PYTHONDONTWRITEBYTECODE inherited from a sandbox would make every warm run compile the modules
    changed since their bytecode was last written, 0.1-0.2 s that an installed package never pays)."""
    env = {key: value for key, value in os.environ.items() if key != "PYTHONDONTWRITEBYTECODE"}
    return env | {"PYTHONPATH": str(src)}


def timed(args: list[str], reps: int, src: Path) -> tuple[list[float], list[float]]:
    """Wall and CPU (user + sys) seconds of `python -m hriplan.cli ARGS` in fresh processes, after
    one untimed warm-up run. CPU time depends far less on the machine's load than wall time."""
    env = process_env(src)
    command = [sys.executable, "-m", "hriplan.cli", *args]
    subprocess.run(command, env=env, capture_output=True, check=True, timeout=600)
    walls, cpus = [], []
    for _ in range(reps):
        before, started = children_cpu(), time.perf_counter()
        subprocess.run(command, env=env, capture_output=True, check=True, timeout=600)
        walls.append(time.perf_counter() - started)
        cpus.append(children_cpu() - before)
    return walls, cpus


def children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def imported(args: list[str], src: Path, heavy_modules: tuple[str, ...] = HEAVY) -> tuple[float, list[str]]:
    """Seconds spent importing (python -X importtime, top-level modules) and which of
    `heavy_modules` load, in their order."""
    env = process_env(src)
    out = subprocess.run(
        [sys.executable, "-X", "importtime", "-m", "hriplan.cli", *args],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    total, heavy = 0.0, set()
    for line in out.stderr.splitlines():
        fields = line.split("|")
        if not line.startswith("import time:") or len(fields) != 3 or not fields[1].strip().isdigit():
            continue
        name = fields[2].strip()
        if not fields[2].startswith("  "):  # a top-level import (nested ones are indented further)
            total += int(fields[1]) / 1e6
        if name in heavy_modules:
            heavy.add(name)
    return total, sorted(heavy, key=heavy_modules.index)


def row(name: str, runs: list[tuple[list[float], list[float]]], target: float | None) -> str:
    cells = " | ".join(f"{statistics.median(walls):.2f} / {statistics.median(cpus):.2f}" for walls, cpus in runs)
    verdict = "" if target is None else f"<= {target}: {'met' if statistics.median(runs[0][0]) <= target else 'missed'}"
    return f"| {name} | {cells} | {verdict} |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=5)
    parser.add_argument("--src", type=Path, nargs="*", default=[], help="other hriplan sources to measure alongside")
    args = parser.parse_args()
    sources, reps = [SRC, *(p.resolve() for p in args.src)], args.reps
    out = Path(tempfile.mkdtemp(prefix="hriplan-bench-cli-"))
    print(
        f"load average before: {os.getloadavg()[0]:.2f} ({os.cpu_count()} cores); {reps} runs each, fresh processes\n"
    )
    print("| command | " + " | ".join(f"{s.parent.name}/src: wall / CPU s" for s in sources) + " | target |")
    print("|---|" + "---|" * len(sources) + "---|")
    plan = ["plan", str(EXAMPLE), "-q", "-o", str(out / "can.json")]
    demo = [*plan, "--html", str(out / "can.html"), "--plots", str(out / "plots")]
    measured = (
        ("hriplan --help", ["--help"], reps, 0.3),
        ("hriplan constraints (warm)", ["constraints", str(EXAMPLE), "-q"], reps, 1.0),
        ("hriplan plan, the demo's plan step (warm)", plan, reps, 2.0),
        ("make demo's whole command (warm)", demo, max(1, reps // 2), None),
    )
    for name, command, n, target in measured:
        print(row(name, [timed(command, n, src) for src in sources], target), flush=True)
    print(f"\nload average after: {os.getloadavg()[0]:.2f}\n")
    for src in sources:
        for name, command in (
            ("--help", ["--help"]),
            ("constraints", ["constraints", str(EXAMPLE), "-q"]),
            ("plan", plan),
        ):
            seconds, heavy = imported(command, src)
            print(
                f"- {src.parent.name}/src {name}: imports {seconds:.2f} s; heavy modules loaded: {', '.join(heavy) or 'none'}"
            )


if __name__ == "__main__":
    main()
