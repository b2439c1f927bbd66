"""A service process freezes what it holds once it is ready (hriplan/collector.py), so the full
garbage collections of its requests traverse the requests' objects, not the ~100 000-190 000
the imports, kernels and caches made. In fresh processes: what the tests' process froze does not
count."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[2]

# The worker's body (worker_main.serve) in a thread of a fresh process, driven through its pipe.
WORKER = """
import gc, json, os, threading
from multiprocessing import Pipe
from hriplan.service.worker_main import serve
ours, theirs = Pipe()
assert gc.get_freeze_count() == 0
threading.Thread(target=serve, args=(theirs, os.getppid(), None, LANE), daemon=True).start()
assert ours.recv()[0] == "ready"
out = {"frozen": gc.get_freeze_count(), "traversed": len(gc.get_objects())}
ours.send(JOB)
while (reply := ours.recv())[0] in ("accepted", "deadline"):
    pass
out["reply"] = reply[0]
out["frozen_after"], out["traversed_after"] = gc.get_freeze_count(), len(gc.get_objects())
print(json.dumps(out))
"""


def _worker(lane: str, job: tuple) -> dict:
    code = WORKER.replace("LANE", repr(lane)).replace("JOB", repr(job))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout.splitlines()[-1])


def test_a_planning_worker_is_frozen_when_ready_and_its_requests_traverse_little():
    problem = json.loads((ROOT / "benchmarks" / "scenarios" / "b_madar_handover.json").read_text())
    out = _worker("planning", ("solve", {"problem": problem}))
    assert out["frozen"] > 40_000 and out["traversed"] < 5_000  # everything the start-up made
    assert out["reply"] == "ok"
    # The request built the worker's session (robot, collision model): what a full collection
    # traverses now; the first plan adds no second freeze (collector.freeze_after_first_plan).
    assert out["traversed_after"] < out["frozen"] / 10
    assert out["frozen_after"] <= out["frozen"]


def test_a_query_worker_is_frozen_when_ready():
    job = ("sparql", {"query": "SELECT ?s WHERE { ?s a owl:Class } LIMIT 1", "limits": {}, "accept": None})
    out = _worker("queries", job)
    assert out["frozen"] > 20_000 and out["traversed"] < 5_000
    assert out["reply"] == "ok"


def test_the_server_freezes_what_it_holds_before_it_serves():
    """`hriplan serve` up to uvicorn.run (stubbed: it reports the collector's state)."""
    pytest.importorskip("uvicorn")
    code = (
        "import gc, json, uvicorn\n"
        "uvicorn.run = lambda app, **_: print(json.dumps([gc.get_freeze_count(), len(gc.get_objects())]))\n"
        "from hriplan.cli.main import app\n"
        "try:\n"
        "    app(['serve', '--port', '0'], prog_name='hriplan')\n"
        "except SystemExit:\n"
        "    pass\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert out.returncode == 0, out.stderr[-3000:]
    frozen, traversed = json.loads(out.stdout.splitlines()[-1])
    assert frozen > 50_000 and traversed < 5_000
