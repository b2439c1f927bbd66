"""A sweep from variants to a results table: skip finished variants, run the rest, summarise."""

from __future__ import annotations

import json
import re
import time
from collections import Counter
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from hriplan import HriplanError, __version__
from hriplan.files import parse_data, read_text, write_atomically
from hriplan.planner.outcome import SUCCEEDED
from hriplan.sweeps.engines import Engine, LocalEngine, Work
from hriplan.sweeps.progress import Progress
from hriplan.sweeps.results import ResultStore, Row
from hriplan.sweeps.variants import Variant, run_key
from hriplan.sweeps.worker import run_variant


class SweepInterrupted(Exception):
    """Ctrl-C or SIGTERM: what was finished is kept; rerunning the same sweep resumes."""

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


MANIFEST = "sweep.json"


def _mode(plan: bool) -> str:
    return "plan" if plan else "derive-only"


def _check_folder(directory: Path, identity: dict[str, str], merge: bool) -> dict[str, Any]:
    """The folder's manifest (empty for a new folder); one line if it holds another task's or
    mode's results and merging was not asked for."""
    path = directory / MANIFEST
    if not path.exists():
        if not merge and ResultStore(directory).finished_keys():
            raise HriplanError(f"{directory} holds results of an unknown sweep (no {MANIFEST}): pass --merge to add")
        return {"runs": []}
    manifest = parse_data(read_text(path, "sweep manifest"), "json")
    seen = [run.get("identity") for run in manifest.get("runs", [])]
    if seen and identity not in seen and not merge:
        was = seen[-1] or {}
        differs = "mode" if was.get("task") == identity["task"] else "task"
        raise HriplanError(
            f"{directory} holds the results of another {differs} ({was.get(differs)}, this one is "
            f"{identity[differs]}): use another folder, or pass --merge to add to it"
        )
    return manifest


def _failed_keys(store: ResultStore) -> set[str]:
    by_key: dict[str, list[Row]] = {}
    for row in store.rows():
        by_key.setdefault(row["key"], []).append(row)
    return {key for key, rows in by_key.items() if not succeeded(rows)}


def _keep_trajectories(directory: Path, variant: Variant, rows: list[Row]) -> list[Row]:
    """Write the trajectories a worker returned to `trajectories/KEY/STEP.json` (on this machine,
    wherever the worker ran); each row names its file instead."""
    kept = []
    for row in rows:
        row = dict(row)
        text = row.pop("trajectory", None)
        if text is not None:
            path = Path("trajectories") / variant.key / f"{row['step']}.json"
            write_atomically(directory / path, text)
            row["trajectory_file"] = str(path)
        kept.append(row)
    return kept


def run_sweep(
    variants: list[Variant],
    directory: Path,
    engine: Engine | None = None,
    plan: bool = True,
    csv: bool = False,
    work: Work = run_variant,
    progress: bool = True,
    spec: dict[str, Any] | None = None,
    merge: bool = False,
    retry_failed: bool = False,
    save_trajectories: bool = False,
) -> SweepSummary:
    """Run the variants not yet in `directory`, writing rows as they arrive; compact at the end.

    Variants are keyed by what their result depends on (variants.run_key). `spec` (what was asked:
    the task and its --vary, or the files) goes into the folder's manifest, `sweep.json`, beside the
    hriplan version and start time of each run; a folder of another task or mode is refused unless
    `merge`. `retry_failed` runs again the variants whose last run did not succeed. Nothing is
    created before the engine has started."""
    began, started = time.monotonic(), datetime.now(timezone.utc).isoformat(timespec="seconds")
    directory = Path(directory)
    spec = spec or {}
    identity = {"task": str(spec.get("task", "")), "mode": _mode(plan)}
    variants = [
        v.model_copy(update={"key": run_key(v, plan), "trajectories": save_trajectories and plan}) for v in variants
    ]
    manifest = _check_folder(directory, identity, merge)
    store = ResultStore(directory)
    finished = store.finished_keys() - (_failed_keys(store) if retry_failed else set())
    todo = [v for v in variants if v.key not in finished]
    engine = engine or LocalEngine()
    try:
        if todo:
            engine.start(work, len(todo))
    except KeyboardInterrupt:  # while joining a cluster or starting workers: nothing new to keep
        raise SweepInterrupted(len(variants) - len(todo), directory) from None
    try:
        store.create()
        manifest["runs"] = manifest.get("runs", []) + [
            {"identity": identity, "spec": spec, "version": __version__, "started": started, "variants": len(variants)}
        ]
        write_atomically(directory / MANIFEST, json.dumps(manifest, indent=1))
        bar = Progress(len(todo)) if progress and todo else None

        def deliver(variant: Variant, rows: list[Row]) -> None:
            store.add([row | {"mode": identity["mode"]} for row in _keep_trajectories(directory, variant, rows)])
            if bar is not None:
                bar.advance()

        try:
            if todo:
                engine.run(todo, plan, deliver, work)
        except KeyboardInterrupt:  # counted from the folder: it may land as the store keeps a variant
            store.compact(csv)
            kept = len({v.key for v in variants} & store.finished_keys())
            raise SweepInterrupted(kept, directory) from None
        finally:
            if bar is not None:
                bar.close()
    finally:
        engine.stop()
    results = store.compact(csv)
    return summarize(
        store.rows(), {v.key for v in variants}, len(variants) - len(todo), len(todo), time.monotonic() - began, results
    )
