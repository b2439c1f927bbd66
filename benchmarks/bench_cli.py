"""Command-line latency: what a user waits for, in fresh processes (imports included).

Run: PYTHONPATH=src .venv/bin/python benchmarks/bench_cli.py [--reps 5] [--src OTHER/src]
(`--src` measures another checkout's code the same way, e.g. the code before a change, so the
two can be compared under the same load.)
- help: `hriplan --help` (target <= 0.3 s).
- constraints: warm `hriplan constraints examples/handover_full_can.yaml -q` (reasoning cached on
  disk by an untimed first run; target <= 1 s), and the same process's import time alone.
- demo plan: warm `hriplan plan examples/handover_full_can.yaml -q` (the plan step of
  `make demo`: two steps reasoned, planned, validated, timed and written; target <= 2 s) and
  the whole `make demo` command (plus the viewer page and the figures).
Wall times depend on the machine's load, so the load average is printed with them; the modules
a command imports (what the lazy imports remove) do not, and are listed too.
"""

from __future__ import annotations

import argparse
import os
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


def timed(args: list[str], reps: int, src: Path) -> list[float]:
    """Wall time of `python -m hriplan.cli ARGS` in fresh processes, after one untimed warm-up run."""
    env = dict(os.environ, PYTHONPATH=str(src))
    command = [sys.executable, "-m", "hriplan.cli", *args]
    subprocess.run(command, env=env, capture_output=True, check=True, timeout=600)
    times = []
    for _ in range(reps):
        started = time.perf_counter()
        subprocess.run(command, env=env, capture_output=True, check=True, timeout=600)
        times.append(time.perf_counter() - started)
    return times


def imported(args: list[str], src: Path) -> tuple[float, list[str]]:
    """Seconds spent importing (python -X importtime, top-level modules) and which heavy ones load."""
    env = dict(os.environ, PYTHONPATH=str(src))
    out = subprocess.run([sys.executable, "-X", "importtime", "-m", "hriplan.cli", *args], env=env,
                         capture_output=True, text=True, timeout=600)  # fmt: skip
    total, heavy = 0.0, set()
    for line in out.stderr.splitlines():
        fields = line.split("|")
        if not line.startswith("import time:") or len(fields) != 3 or not fields[1].strip().isdigit():
            continue
        name = fields[2].strip()
        if not fields[2].startswith("  "):  # a top-level import (nested ones are indented further)
            total += int(fields[1]) / 1e6
        if name in HEAVY:
            heavy.add(name)
    return total, sorted(heavy)


def row(name: str, times: list[float], target: float | None) -> str:
    best, median = min(times), statistics.median(times)
    verdict = "" if target is None else ("met" if median <= target else "missed")
    return f"| {name} | {median:.2f} | {best:.2f} | {'' if target is None else f'<= {target}'} {verdict} |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=5)
    parser.add_argument("--src", type=Path, default=SRC, help="the hriplan sources to measure")
    args = parser.parse_args()
    src, reps = args.src.resolve(), args.reps
    out = Path(tempfile.mkdtemp(prefix="hriplan-bench-cli-"))
    print(f"sources: {src}; load average before: {os.getloadavg()[0]:.2f} ({os.cpu_count()} cores); {args.reps} runs each\n")
    print("| command | median s | best s | target |\n|---|---|---|---|")
    print(row("hriplan --help", timed(["--help"], reps, src), 0.3))
    print(row("hriplan constraints (warm)", timed(["constraints", str(EXAMPLE), "-q"], reps, src), 1.0))
    plan = ["plan", str(EXAMPLE), "-q", "-o", str(out / "can.json")]
    print(row("hriplan plan, the demo's plan step (warm)", timed(plan, reps, src), 2.0))
    demo = [*plan, "--html", str(out / "can.html"), "--plots", str(out / "plots")]
    print(row("make demo's whole command (warm)", timed(demo, max(1, reps // 2), src), None))
    print(f"\nload average after: {os.getloadavg()[0]:.2f}\n")
    for name, command in (("--help", ["--help"]), ("constraints", ["constraints", str(EXAMPLE), "-q"]), ("plan", plan)):
        seconds, heavy = imported(command, src)
        print(f"- {name}: imports {seconds:.2f} s; heavy modules loaded: {', '.join(heavy) or 'none'}")


if __name__ == "__main__":
    main()
