"""A function wrapped to report the CPU time of its outermost calls: benchmarks that charge a
stage's time (functions that call each other, or themselves) once, where the outermost call ends."""

from __future__ import annotations

import time
from collections.abc import Callable


def outermost_cpu(original: Callable, depth: list[int], add: Callable[[float], None]) -> Callable:
    """`original`, handing `add` the CPU seconds of each call not made inside another call that
    shares `depth` (a one-item counter: the functions of one stage share one)."""

    def timed(*args, **kwargs):
        depth[0] += 1
        started = time.process_time()
        try:
            return original(*args, **kwargs)
        finally:
            depth[0] -= 1
            if not depth[0]:
                add(time.process_time() - started)

    return timed
