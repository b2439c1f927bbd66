"""The garbage collector while a command imports what it works with: paused, then what the imports
made frozen out of every later collection.

Importing numpy, pinocchio, pydantic and hriplan's modules (about 80 pydantic models) makes some
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
