"""The real server for the service tests: started once per set-up, stopped at exit."""

from __future__ import annotations

import atexit
import time

import httpx

from hriplan.service.launch import (  # noqa: F401 - SRC is for tests that run the CLI, the rest for hostile tests
    BOMBS,
    SRC,
    TENFOLD,
    nested_replace,
    running_server,
)


def wait_for_workers(url: str, count: int, headers: dict[str, str] | None = None, timeout: float = 60.0) -> list[int]:
    """The worker pids once `count` are ready again (after a replacement)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        status = httpx.get(f"{url}/health", headers=headers or {}).json()
        if sum(w["ready"] for w in status["workers"]) == count == len(status["workers"]):
            return [w["pid"] for w in status["workers"]]
        time.sleep(0.2)
    raise AssertionError(f"the pool did not get back to {count} workers")


_shared: dict[tuple[str, ...], str] = {}
SHARED_ARGS = ("--workers", "2", "--queue", "2", "--query-time-limit", "1", "--row-limit", "100")


def shared_server() -> str:
    """One server for every test module that needs the default set-up (started once, stopped at exit)."""
    if SHARED_ARGS not in _shared:
        context = running_server(*SHARED_ARGS)
        _shared[SHARED_ARGS] = context.__enter__()
        atexit.register(context.__exit__, None, None, None)
    return _shared[SHARED_ARGS]
