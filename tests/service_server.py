"""Start the real server (`hriplan serve` in a subprocess) on a free loopback port for tests."""

from __future__ import annotations

import atexit
import contextlib
import os
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import httpx

SRC = Path(__file__).resolve().parents[1] / "src"

def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]

@contextlib.contextmanager
def running_server(*args: str, token: str | None = None, startup: float = 120.0) -> Iterator[str]:
    """The base URL of a server started with `args`; stopped (workers included) afterwards."""
    port = free_port()
    env = dict(os.environ, PYTHONPATH=f"{SRC}{os.pathsep}{os.environ.get('PYTHONPATH', '')}")
    env.pop("HRIPLAN_TOKEN", None)
    command = [sys.executable, "-m", "hriplan.cli", "serve", "--port", str(port), *args]
    process = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    url = f"http://127.0.0.1:{port}"
    headers = {"Authorization": f"Bearer {token}"} if token else {}
    try:
        deadline = time.monotonic() + startup
        while True:
            if process.poll() is not None:
                raise RuntimeError(f"the server exited ({process.returncode}): {process.stdout.read()}")
            with contextlib.suppress(httpx.TransportError):
                if httpx.get(f"{url}/health", headers=headers, timeout=2).status_code == 200:
                    break
            if time.monotonic() > deadline:
                raise RuntimeError("the server did not start in time")
            time.sleep(0.2)
        yield url
    finally:
        process.terminate()
        try:
            process.wait(20)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()

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
SHARED_ARGS = ("--workers", "2", "--queue", "2", "--query-time-limit", "1", "--row-limit", "500")

def shared_server() -> str:
    """One server for every test module that needs the default set-up (started once, stopped at exit)."""
    if SHARED_ARGS not in _shared:
        context = running_server(*SHARED_ARGS)
        _shared[SHARED_ARGS] = context.__enter__()
        atexit.register(context.__exit__, None, None, None)
    return _shared[SHARED_ARGS]
