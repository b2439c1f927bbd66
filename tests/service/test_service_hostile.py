"""Hostile queries against a real server on loopback (issue 22): a regex, a VALUES join and
string functions that check no deadline are stopped at the query time limit by killing their
query worker, memory and answer size are bounded, and queries never take a planning worker,
so a plan does not wait behind them. A worker that dies is noticed, and dies with its server."""

import contextlib
import json
import os
import signal
import threading
import time
from pathlib import Path

import httpx
import pytest
from service_server import BOMBS, TENFOLD, nested_replace, running_server, wait_for_workers

ROOT = Path(__file__).resolve().parents[2]
PROBLEM = json.loads((ROOT / "benchmarks" / "scenarios" / "b_madar_handover.json").read_text())
TASK = (ROOT / "examples" / "handover_full_can.yaml").read_text()
REGEX, VALUES, REPLACE = BOMBS["regex"], BOMBS["values"], BOMBS["replace"]  # REPLACE: 100 MB strings
WIDE = f"SELECT ?x WHERE {{ ?s rdfs:comment ?o BIND(REPLACE(STR(?o), {TENFOLD}) AS ?x) }}"  # ~10x the comments
TIMED_OUT = "the query ran past its time limit of 3 s; narrow it or add a LIMIT"


@pytest.fixture(scope="module")
def server():
    args = ("--workers", "1", "--query-time-limit", "3", "--request-time-limit", "60", "--query-memory", "32")
    with running_server(*args, "--response-limit", "100000") as url:
        yield url


def pids(url: str) -> tuple[list[int], list[int]]:
    health = httpx.get(f"{url}/health").json()
    return [w["pid"] for w in health["workers"]], [w["pid"] for w in health["query_workers"]]


def query_workers_ready(url: str) -> list[int]:
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        health = httpx.get(f"{url}/health").json()
        if health["status"] == "ok":
            return [w["pid"] for w in health["query_workers"]]
        time.sleep(0.2)
    raise AssertionError("the query worker was not replaced")


@pytest.mark.parametrize("query", [REGEX, VALUES], ids=["regex", "values-join"])
def test_a_query_that_checks_no_deadline_is_killed_at_the_query_time_limit(server, query):
    planners, (before,) = pids(server), query_workers_ready(server)
    answer = httpx.get(f"{server}/sparql", params={"query": query}, timeout=90)
    # not the request's limit (60 s), which was all that stopped it before
    assert answer.status_code == 504 and answer.json()["error"] == TIMED_OUT
    (after,) = query_workers_ready(server)
    assert after != before and not _alive(before)
    assert pids(server)[0] == planners[0]  # the planning worker was never involved


def test_string_functions_stop_at_the_memory_limit(server):
    query_workers_ready(server)
    assert len(REPLACE) < 250  # 100 MB strings, or 1 GB with one level more
    answer = httpx.get(f"{server}/sparql", params={"query": REPLACE}, timeout=90)
    assert answer.status_code == 400 and answer.json()["error"] == (
        "the query needed more than the memory limit of 32 MB; narrow it"
    )
    small = httpx.get(f"{server}/sparql", params={"query": nested_replace(4)})
    assert small.status_code == 200  # the worker survived its bounded job; 4 levels fit
    assert {int(b["n"]["value"]) % 10_000 for b in small.json()["results"]["bindings"]} == {0}


def test_an_answer_stops_at_the_byte_limit_not_only_the_row_limit(server):
    query_workers_ready(server)
    answer = httpx.get(f"{server}/sparql", params={"query": WIDE}, timeout=90)
    assert answer.status_code == 400 and answer.json()["error"] == (
        "the query answers more than 100000 bytes (the byte limit); narrow it or add a LIMIT"
    )
    small = httpx.get(f"{server}/sparql", params={"query": WIDE + " LIMIT 2"}, timeout=90)
    rows = small.json()["results"]["bindings"]
    assert len(rows) == 2 and all(len(r["x"]["value"]) >= 10 and len(r["x"]["value"]) % 10 == 0 for r in rows)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    with open(f"/proc/{pid}/stat") as stat:  # a zombie is dead
        return stat.read().rsplit(")", 1)[1].split()[0] != "Z"


def _server_pid(worker: int) -> int:
    with open(f"/proc/{worker}/stat") as stat:
        return int(stat.read().rsplit(")", 1)[1].split()[1])


def _bomb(url: str) -> None:
    with contextlib.suppress(httpx.TransportError):  # its server is killed under it
        httpx.get(f"{url}/sparql", params={"query": REGEX}, timeout=600)


def test_bombs_never_hold_up_a_plan_and_die_with_a_killed_server():
    with running_server("--workers", "1", "--query-time-limit", "600", "--request-time-limit", "600") as url:
        with httpx.Client(base_url=url, timeout=120) as client:
            assert client.post("/solve", json=PROBLEM).json()["solved"]  # warm the planning worker
            bombs = [
                threading.Thread(
                    target=httpx.get,
                    args=(f"{url}/sparql",),
                    kwargs={"params": {"query": REGEX}, "timeout": 600},
                    daemon=True,
                )
                for _ in range(2)
            ]
            for bomb in bombs:
                bomb.start()
            while not all(w["busy"] for w in client.get("/health").json()["query_workers"]):
                time.sleep(0.05)
            answer = client.post("/solve", json=PROBLEM).json()
            # planned while both bombs were still in flight: one running, one queued behind it
            assert answer["solved"] and all(bomb.is_alive() for bomb in bombs)
            health = client.get("/health").json()
        (busy,) = [w["pid"] for w in health["query_workers"] if w["busy"]]
        (planner,) = [w["pid"] for w in health["workers"]]
        os.kill(_server_pid(busy), signal.SIGKILL)
        deadline = time.monotonic() + 30
        while (_alive(busy) or _alive(planner)) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not _alive(busy) and not _alive(planner)  # before: the busy worker spun at 100 % CPU


def test_a_killed_idle_worker_is_replaced_and_the_next_request_served(server):
    query_workers_ready(server)
    (planner,), _ = pids(server)
    wait_for_workers(server, 1)
    os.kill(planner, signal.SIGKILL)
    answer = httpx.post(
        f"{server}/constraints", content=TASK, headers={"content-type": "application/yaml"}, timeout=120
    )
    assert answer.status_code == 200 and answer.json()["task"] == "handover_full_can"  # before: 500, never started
    (replaced,) = wait_for_workers(server, 1)
    assert replaced != planner and httpx.get(f"{server}/health").json()["status"] == "ok"
