"""A sweep from variants to a results table: skip finished variants, run the rest, summarise."""

from __future__ import annotations

import re
import time
from collections import Counter
from pathlib import Path

from pydantic import BaseModel

from hriplan.planner.outcome import SUCCEEDED
from hriplan.sweeps.engines import Engine, LocalEngine, Work
from hriplan.sweeps.progress import Progress
from hriplan.sweeps.results import ResultStore, Row
from hriplan.sweeps.variants import Variant
from hriplan.sweeps.worker import run_variant


class SweepInterrupted(Exception):
    """Ctrl-C: what was finished is kept; rerunning the same sweep resumes."""

    def __init__(self, done: int, directory: Path) -> None:
        super().__init__(f"interrupted: {done} variants kept in {directory}; rerun the same command to resume")


class SweepSummary(BaseModel):
    variants: int
    skipped: int  # already finished before this run
    ran: int
    solved: int  # variants whose every step solved (or derived, without planning)
    statuses: dict[str, int]  # per step row
    reasons: dict[str, int]  # the most common reasons of failed rows
    wall_time: float
    results: str

    def text(self) -> str:
        lines = [
            f"{self.variants} variants: {self.ran} run, {self.skipped} already done; "
            f"{self.solved} succeeded in every step ({self.wall_time:.1f} s)",
            "step rows: " + ", ".join(f"{n} {s}" for s, n in sorted(self.statuses.items())),
        ]
        lines += [f"  {n} x {reason}" for reason, n in self.reasons.items()]
        return "\n".join(lines + [f"results: {self.results}"])


def _pattern(reason: str) -> str:
    """A reason with its numbers masked, so failures of one kind are counted together."""
    return re.sub(r"-?\d+(\.\d+)?", "#", reason)


def succeeded(rows: list[Row]) -> bool:
    return bool(rows) and all(r["status"] in SUCCEEDED for r in rows)


def summarize(rows: list[Row], keys: set[str], skipped: int, ran: int, wall: float, results: Path) -> SweepSummary:
    mine = [r for r in rows if r["key"] in keys]
    by_key: dict[str, list[Row]] = {}
    for r in mine:
        by_key.setdefault(r["key"], []).append(r)
    failed = Counter(_pattern(r["reason"] or r["status"]) for r in mine if r["status"] not in SUCCEEDED)
    return SweepSummary(
        variants=len(keys),
        skipped=skipped,
        ran=ran,
        solved=sum(succeeded(v) for v in by_key.values()),
        statuses=dict(Counter(r["status"] for r in mine)),
        reasons=dict(failed.most_common(3)),
        wall_time=wall,
        results=str(results),
    )


def run_sweep(
    variants: list[Variant],
    directory: Path,
    engine: Engine | None = None,
    plan: bool = True,
    csv: bool = False,
    work: Work = run_variant,
    progress: bool = True,
) -> SweepSummary:
    """Run the variants not yet in `directory`, writing rows as they arrive; compact at the end."""
    began = time.monotonic()
    store = ResultStore(directory)
    finished = store.finished_keys()
    todo = [v for v in variants if v.key not in finished]
    bar = Progress(len(todo)) if progress and todo else None
    done = 0

    def deliver(variant: Variant, rows: list[Row]) -> None:
        nonlocal done
        store.add(rows)
        done += 1
        if bar is not None:
            bar.advance()

    try:
        if todo:
            (engine or LocalEngine()).run(todo, plan, deliver, work)
    except KeyboardInterrupt:
        store.compact(csv)
        raise SweepInterrupted(len(variants) - len(todo) + done, directory) from None
    finally:
        if bar is not None:
            bar.close()
    results = store.compact(csv)
    return summarize(
        store.rows(), {v.key for v in variants}, len(variants) - len(todo), len(todo), time.monotonic() - began, results
    )
