"""Compiled kernels that call into other files, cached on disk keyed by every file they use.

Why: numba keys a function's disk cache by its own source file only (the file's digest), not
by its callees in other modules, so a kernel calling the certifier's or the constraint terms'
code would keep running their old code after those files changed (an upgrade, an edit).
`njit_keyed` compiles as `njit(cache=True, nogil=True)` and adds the digests of the files the
kernel depends on to the stamp numba compares before loading a cached kernel: a change in any
of them compiles it again. Where the numba in use keeps its stamp elsewhere (a future version),
the kernel is not cached at all rather than cached stale.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

from numba import njit
from numba.core.caching import NullCache


def njit_keyed(*dependencies: ModuleType, nogil: bool = True) -> Callable[[Callable], Callable]:
    """`njit(cache=True, nogil=nogil)` with its cache also keyed by the source files of
    `dependencies` and of the modules they are keyed by in turn (a module's `KEYED_BY`: the
    certifier's kernels call the mesh pairs' walk, so a kernel calling the certifier's is keyed
    by both) (nogil=False for kernels that call back into Python: they hold the GIL)."""
    files = [m.__file__ for m in keyed_by(dependencies)]

    def compile_keyed(function: Callable) -> Callable:
        dispatcher = njit(cache=True, nogil=nogil)(function)
        index = getattr(getattr(dispatcher, "_cache", None), "_cache_file", None)
        if index is None or not hasattr(index, "_source_stamp"):
            dispatcher._cache = NullCache()
            return dispatcher
        index._source_stamp = (index._source_stamp, *(file_digest(f) for f in files))
        return dispatcher

    return compile_keyed


def keyed_by(modules: tuple[ModuleType, ...]) -> list[ModuleType]:
    """`modules` and, in turn, every module listed in one's `KEYED_BY`, each once, in order."""
    found: list[ModuleType] = []
    waiting = list(modules)
    while waiting:
        module = waiting.pop(0)
        if module not in found:
            found.append(module)
            waiting += list(getattr(module, "KEYED_BY", ()))
    return found


def file_digest(path: str) -> bytes:
    """The sha256 of a file's bytes."""
    return hashlib.sha256(Path(path).read_bytes()).digest()
