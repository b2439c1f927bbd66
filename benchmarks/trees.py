"""Measure this checkout and another tree in the same run: each tree's numbers come from a fresh
process of the calling script with `--measure` (its `measure()` printed as JSON) and that tree's
`src` on the path, the trees taking turns round by round so that both see the same load."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

HERE = Path(__file__).parents[1] / "src"


def runs_by_tree(description: str, script: str, measure: Callable[[], dict]) -> tuple[dict[str, list[dict]], bool]:
    """Parse `--src`, `--rounds` and `--measure`; with `--measure` print `measure()` and exit.
    Else each tree's rounds of numbers, "this checkout" first, and whether another tree was given."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--src", type=Path, help="another tree's src, measured in the same run")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--measure", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.measure:
        print(json.dumps(measure()))
        sys.exit(0)
    trees = {"this checkout": HERE, **({"other": args.src} if args.src else {})}
    runs: dict[str, list[dict]] = {label: [] for label in trees}
    for _ in range(args.rounds):
        for label, src in trees.items():
            env = {**os.environ, "PYTHONPATH": str(src), "OPENBLAS_NUM_THREADS": "1"}
            done = subprocess.run(
                [sys.executable, script, "--measure"], env=env, capture_output=True, text=True, check=True
            )
            runs[label].append(json.loads(done.stdout.strip().splitlines()[-1]))
    return runs, args.src is not None
