"""Whole tasks: solved counts and the time per step over the multi-step corpus, for this checkout
and others in the same run.

Run: PYTHONPATH=src .venv/bin/python benchmarks/bench_whole_tasks.py [--src OTHER/src ...]
     [--reps 1] [--report benchmarks/REPORT-whole-tasks.md]
The corpus is this checkout's `tests/data/whole_tasks/*.yaml` and `examples/*.yaml`. Each task is
planned by `hriplan plan --json` in a fresh process per checkout, the checkouts taking turns task by
task, so that they are compared under the same load (`--src` names another checkout's `src`, e.g.
the previous commit's in a `git worktree`). A task file the other checkout cannot read counts as
refused. Per step: its status and its planning time (the search, from the step's report), per task
the whole process's wall time (imports, reasoning, planning, timing, validation, writing).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_cli import process_env

ROOT = Path(__file__).resolve().parents[1]
CORPUS = sorted((ROOT / "tests" / "data" / "whole_tasks").glob("*.yaml")) + sorted((ROOT / "examples").glob("*.yaml"))


def plan(task: Path, src: Path) -> dict:
    """One `hriplan plan --json` of `task` with the code in `src`: its outcome and wall time."""
    with tempfile.TemporaryDirectory() as out:
        started = time.perf_counter()
        done = subprocess.run(
            [sys.executable, "-m", "hriplan.cli", "plan", str(task), "--json", "-q", "-o", f"{out}/{task.stem}.json"],
            env=process_env(src),
            cwd=task.parent,
            capture_output=True,
            text=True,
            timeout=900,
        )
        wall = time.perf_counter() - started
    if done.returncode == 2 or not done.stdout.strip():
        return {"wall": wall, "refused": done.stderr.strip().splitlines()[-1:] or ["(no output)"], "steps": []}
    outcome = json.loads(done.stdout)
    steps = [
        {"name": s["name"], "status": s["status"], "planning_time": (s.get("report") or {}).get("planning_time")}
        for s in outcome["steps"]
    ]
    return {"wall": wall, "solved": outcome["solved"], "steps": steps}


def summary(runs: list[dict]) -> dict:
    """Per checkout and task: solved or not, steps solved of steps, median step planning time and wall."""
    first = runs[0]
    if "refused" in first:
        return {"result": "refused: " + first["refused"][0][:80], "steps": "-", "step_ms": "-", "wall": "-"}
    times = [s["planning_time"] for run in runs for s in run["steps"] if s["planning_time"] is not None]
    solved = sum(s["status"] == "solved" for s in first["steps"])
    return {
        "result": "solved" if all(r["solved"] for r in runs) else "not solved",
        "steps": f"{solved}/{len(first['steps'])}",
        "step_ms": f"{1000 * statistics.median(times):.1f}" if times else "-",
        "wall": f"{statistics.median(r['wall'] for r in runs):.2f}",
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--src", type=Path, action="append", default=[], help="another checkout's src to compare")
    parser.add_argument("--reps", type=int, default=1, help="runs per task and checkout (seeds are fixed)")
    parser.add_argument("--report", type=Path, help="also write the table as Markdown here")
    args = parser.parse_args()
    trees = [ROOT / "src", *args.src]
    results: dict[tuple[int, str], dict] = {}
    for task in CORPUS:
        for index, src in enumerate(trees):
            runs = [plan(task, src) for _ in range(args.reps)]
            results[index, task.stem] = summary(runs)
            print(f"{task.stem:32s} [{index}] {results[index, task.stem]}", file=sys.stderr, flush=True)
    header = "| task | " + " | ".join(
        f"[{i}] result | [{i}] steps solved | [{i}] step ms | [{i}] wall s" for i in range(len(trees))
    )
    lines = [
        "checkouts: " + ", ".join(f"[{i}] {src}" for i, src in enumerate(trees)),
        f"load average at the end: {os.getloadavg()[0]:.1f}; {args.reps} run(s) per task and checkout",
        "",
        header + " |",
        "|---" * (1 + 4 * len(trees)) + "|",
    ]
    for task in CORPUS:
        cells = []
        for i in range(len(trees)):
            row = results[i, task.stem]
            cells += [row["result"], row["steps"], row["step_ms"], row["wall"]]
        lines.append(f"| {task.stem} | " + " | ".join(cells) + " |")
    for i in range(len(trees)):
        solved = sum(results[i, t.stem]["result"] == "solved" for t in CORPUS)
        lines.append(f"\n[{i}]: {solved} of {len(CORPUS)} tasks solved")
    text = "\n".join(lines)
    print(text)
    if args.report:
        args.report.write_text(text + "\n")


if __name__ == "__main__":
    main()
