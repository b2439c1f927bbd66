"""When Python's garbage collector runs and which objects it is kept from: hriplan decides it here.

A full (generation 2) collection traverses every object the collector tracks. hriplan's processes
hold 100 000-190 000 of them for their whole life (numpy, pydantic, pinocchio, numba's kernels,
the ontology, the robots' and the reasoner's caches), and traversing them costs 60-120 ms for
almost nothing freed; such a collection comes every 50-70 re-plans and lands in one of them. A
frozen object (`gc.freeze()`) sits in the permanent generation, which collections skip. It is
still freed when its last reference goes; only a reference cycle among frozen objects is never
freed, so each moment below freezes once per process, never per request (a freeze per request
would keep every dropped cycle of every request).

- A command imports with the collector paused, then freezes what the imports made
  (`collector_paused_while_importing`, below).
- A process about to serve many requests (the service's server and its workers, once ready)
  collects once, then freezes what is left (`freeze_what_lives`).
- Any other process that plans (a motion manager through the plug-in API, a sweep's worker)
  does the same once, after its first timed motion (`freeze_after_first_plan`, called by
  `PlanningSession.time`): by then its robot, kernels, ontology and caches are made. A process
  that has frozen already (a command, a service worker, a host that manages its collector) or
  turned the collector off is left as it is.

The command's pause, in detail: importing numpy, pinocchio, pydantic and hriplan's modules (about
80 pydantic models) makes some
85,000 objects the collector tracks, which live as long as the process; it traversed them again
and again while they were made (about 150 young collections and a full one in the demo's `plan`,
80-100 ms CPU of its 1.2 s) and found almost nothing to free. Paused while a command imports, then
`gc.freeze()` moves every object that exists into the permanent generation, so the collections
of the work (on again) traverse only the work's objects. Nothing a command computes depends on
when the collector runs.
"""

from __future__ import annotations

import gc
import sys
from collections.abc import Iterator
from contextlib import contextmanager


class _Planned:
    """Whether this process has timed a motion (the first-plan freeze is done or declined)."""

    once = False


def freeze_what_lives() -> None:
    """Collect every generation (the garbage made so far is not kept), then freeze every object left.

    For a process about to serve many requests. The collection is the last to traverse these
    objects: ~70 ms over a planning worker's ~190 000 (0.35 s when numba has just compiled the
    kernels, whose ~116 000 dropped objects it frees)."""
    gc.collect()
    gc.freeze()


def freeze_after_first_plan() -> None:
    """Once per process, at its first timed motion: `freeze_what_lives`, unless the process froze
    already or runs with the collector off (theirs to manage)."""
    if _Planned.once:
        return
    _Planned.once = True
    if gc.isenabled() and gc.get_freeze_count() == 0:
        freeze_what_lives()


@contextmanager
def collector_paused_while_importing() -> Iterator[None]:
    """Pause the collector for a block of imports; if they loaded modules, freeze what exists.

    A block that loaded nothing new (a second command in one process, the tests' in-process
    commands) leaves the generations as they were: freezing keeps a cycle that was already garbage
    for the life of the process, so it is done where it pays, once per first import."""
    if not gc.isenabled():  # paused by an enclosing block, or by the caller: theirs to turn back on
        yield
        return
    loaded = len(sys.modules)
    gc.disable()
    try:
        yield
    finally:
        if len(sys.modules) > loaded:
            gc.freeze()
        gc.enable()
