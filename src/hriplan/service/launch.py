"""Start a real server (`hriplan serve` in a subprocess) on a free loopback port: for tests,
benchmarks, and anyone who wants a throw-away server from Python; and the hostile queries
(issue 22) the tests and the benchmark send it."""

from __future__ import annotations

import contextlib
import os
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import IO

import httpx

SRC = Path(__file__).resolve().parents[2]
TENFOLD = '".", "0123456789"'  # REPLACE's arguments that write each character ten times


def nested_replace(levels: int) -> str:
    """Each comment's length after `levels` nested tenfold REPLACEs: 10^levels x ~100 characters."""
    nested = "STR(?o)"
    for _ in range(levels):
        nested = f"REPLACE({nested}, {TENFOLD})"
    return f"SELECT (STRLEN({nested}) AS ?n) WHERE {{ ?s rdfs:comment ?o }}"


BOMBS = {  # each checks no deadline inside rdflib: only a killed process stops it
    "regex": 'SELECT ?o WHERE { ?s rdfs:comment ?o FILTER(REGEX(STR(?o), "^(.*)*(.*)*(.*)*(.*)*x$")) }',
    "values": "SELECT (COUNT(*) AS ?n) WHERE { "
    + " ".join(f"VALUES ?v{i} {{ 1 2 3 4 5 6 7 8 9 10 }}" for i in range(8))
    + " }",
    "replace": nested_replace(6),
}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def running_server(
    *args: str,
    token: str | None = None,
    startup: float = 120.0,
    log: IO[str] | None = None,
    src: Path = SRC,
    environment: Mapping[str, str] | None = None,
) -> Iterator[str]:
    """The base URL of a server started with `args` from the sources in `src` (another checkout's,
    for a before/after benchmark), with `environment` added to this process's; stopped (workers
    included) afterwards. Its log goes to `log` or a temporary file (a pipe nobody reads would
    fill up and stall the server)."""
    port = free_port()
    env = dict(os.environ, **(environment or {}))
    env["PYTHONPATH"] = f"{src}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"
    env.pop("HRIPLAN_TOKEN", None)
    command = [sys.executable, "-m", "hriplan.cli", "serve", "--port", str(port), *args]
    own_log = log is None
    log = tempfile.TemporaryFile(mode="w+") if log is None else log
    process = subprocess.Popen(command, env=env, stdout=log, stderr=subprocess.STDOUT, text=True)
    url = f"http://127.0.0.1:{port}"
    headers = {"Authorization": f"Bearer {token}"} if token else {}
    try:
        deadline = time.monotonic() + startup
        while True:
            if process.poll() is not None:
                log.seek(0)
                raise RuntimeError(f"the server exited ({process.returncode}): {log.read()[-2000:]}")
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
        if own_log:
            log.close()
