"""Worker functions for the sweep engine tests (importable by spawned workers and Ray actors).

Each takes the directory of its call log first: bind it with functools.partial."""

from __future__ import annotations

import os
import time
from pathlib import Path

from hriplan.sweeps.worker import run_variant


def _log(path, variant) -> Path:
    path = Path(path)
    with open(path / "calls.log", "a") as f:
        f.write(variant.key + "\n")
    return path


def counting(log, variant, plan):
    """The real worker, logging each call (to count what a rerun plans)."""
    _log(log, variant)
    return run_variant(variant, plan)


def dies_on_seed_7(log, variant, plan):
    """The worker process dies whenever it runs the variant with seed 7; the others take 3 s, so
    one is still running on the other worker when it dies (and goes down with a local pool)."""
    _log(log, variant)
    if variant.task.planning.seed == 7:
        os._exit(3)
    time.sleep(3.0)
    return run_variant(variant, plan)


def dies_once_on_seed_7(log, variant, plan):
    """Dies the first time it runs seed 7 (a marker file remembers), then works."""
    path = _log(log, variant)
    marker = path / "died"
    if variant.task.planning.seed == 7 and not marker.exists():
        marker.write_text("x")
        os._exit(3)
    return run_variant(variant, plan)


def calls(directory: Path) -> list[str]:
    log = Path(directory) / "calls.log"
    return log.read_text().split() if log.exists() else []


class Holder:
    """A Ray actor that only holds its CPU (a cluster busy with another job)."""

    def ping(self) -> bool:
        return True


def alive(pid: int) -> bool:
    """The process exists and is not a zombie waiting to be reaped."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def children(pid: int) -> list[int]:
    """The processes `pid` started (Linux /proc)."""
    found = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            found += [int(c) for c in (task / "children").read_text().split()]
        except OSError:
            pass
    return found
