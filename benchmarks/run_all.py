"""Every benchmark: each `benchmarks/bench_*.py` with its defaults, one after another, its output
as it comes, then how long each took and the total. `make bench` runs this.

Run: PYTHONPATH=src .venv/bin/python benchmarks/run_all.py [--only NAME ...] [--skip NAME ...]
(NAME without `bench_` and `.py`, e.g. `--skip planner`). A script that fails is reported and the
others still run; the exit status is 1 if any failed.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BENCHMARKS = ROOT / "benchmarks"

# Said before they start, so that nobody waits blind (README, Benchmarks, has every script's time).
SLOW = {"bench_planner.py": "20 minutes or more on 2 shared cores (README, Benchmarks)"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="*", default=[], help="run only these (names without bench_ and .py)")
    parser.add_argument("--skip", nargs="*", default=[], help="skip these")
    args = parser.parse_args()
    scripts = [
        path
        for path in sorted(BENCHMARKS.glob("bench_*.py"))
        if (not args.only or path.stem.removeprefix("bench_") in args.only)
        and path.stem.removeprefix("bench_") not in args.skip
    ]
    print(f"{len(scripts)} benchmark scripts: {', '.join(p.name for p in scripts)}")
    for path in scripts:
        if path.name in SLOW:
            print(f"{path.name} alone takes {SLOW[path.name]}")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT / "src"), os.environ.get("PYTHONPATH")])))
    took: list[tuple[str, float, int]] = []
    started = time.perf_counter()
    for path in scripts:
        print(f"\n=== {path.name}", flush=True)
        start = time.perf_counter()
        code = subprocess.run([sys.executable, str(path)], cwd=ROOT, env=env).returncode
        took.append((path.name, time.perf_counter() - start, code))
        print(f"=== {path.name}: {took[-1][1]:.0f} s{'' if code == 0 else f', FAILED (exit {code})'}", flush=True)
    total = time.perf_counter() - started
    print("\n| script | seconds | |\n|---|---|---|")
    for name, seconds, code in took:
        print(f"| {name} | {seconds:.0f} | {'ok' if code == 0 else f'failed (exit {code})'} |")
    print(f"| total | {total:.0f} ({total / 60:.1f} min) | load average now {os.getloadavg()[0]:.1f} |")
    sys.exit(1 if any(code for _, _, code in took) else 0)


if __name__ == "__main__":
    main()
