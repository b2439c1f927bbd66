"""The HTTP service under load, and the SPARQL engine choice (rdflib vs pyoxigraph).

Run: PYTHONPATH=src .venv/bin/python benchmarks/bench_service.py [--requests 200] [--concurrency 8] [--workers 2] [--reps 20]
- engines: the same queries on the ontology and on a task step's reasoned graph, by rdflib as
  hriplan runs it (with its deadline and row guards), by plain rdflib, and by pyoxigraph (if
  installed); median over --reps. rdflib-endpoint evaluates with one of these two engines.
- load: a real server (`hriplan serve`, loopback, a free port) gets --requests mixed requests
  (task plan, problem solve, constraints, SPARQL) from --concurrency clients; every answer is
  checked against a marker of its own request (a task name, a start value, a literal), and
  latency p50/p95 per kind is printed. The loop is bounded by count and stops by itself.
- bomb: problem-solve latency alone, then while two cross-join queries run into the query
  time limit (--query-time-limit 2): planning waits at most that limit.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import copy
import json
import statistics
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

import httpx  # noqa: E402
import yaml  # noqa: E402

from hriplan.service.launch import running_server  # noqa: E402

TASK = yaml.safe_load((ROOT / "examples" / "handover_full_can.yaml").read_text())
PROBLEM = json.loads((ROOT / "benchmarks" / "scenarios" / "b_madar_handover.json").read_text())
QUERIES = {
    "tolerances": "SELECT ?kind ?tol WHERE { ?kind hp:hasTolerance ?tol }",
    "required (task)": "SELECT ?step ?kind WHERE { ?step hp:requiresConstraint ?kind }",
    "all triples": "SELECT (COUNT(*) AS ?n) WHERE { ?s ?p ?o }",
    "subclass path": "SELECT (COUNT(*) AS ?n) WHERE { ?c rdfs:subClassOf+ ?d }",
    "same-type pairs": "SELECT (COUNT(*) AS ?n) WHERE { ?a a ?c . ?b a ?c }",
}
CROSS_JOIN = "SELECT (COUNT(*) AS ?n) WHERE { ?a ?b ?c . ?d ?e ?f . ?g ?h ?i . ?j ?k ?l }"


def median_ms(run, reps: int) -> float:
    times = []
    for _ in range(reps):
        began = time.perf_counter()
        run()
        times.append(time.perf_counter() - began)
    return 1e3 * statistics.median(times)


def engines(reps: int) -> list[str]:
    from hriplan.ontology.sparql import QueryLimits, prepare_query, run_query
    from hriplan.ontology.vocabulary import PREFIXES
    from hriplan.tasks.knowledge import knowledge_base_for
    from hriplan.tasks.model import TaskFile
    from hriplan.tasks.pipeline import TaskRunner

    graph = knowledge_base_for(TaskRunner(TaskFile.model_validate(TASK)), None).graph
    try:
        import pyoxigraph
    except ImportError:
        pyoxigraph = None
    if pyoxigraph is not None:
        store = pyoxigraph.Store()
        store.bulk_load(graph.serialize(format="nt").encode(), pyoxigraph.RdfFormat.N_TRIPLES)
        prefixes = {k: str(v) for k, v in PREFIXES.items()}
    lines = [
        f"graph: the handover task's first step, {len(graph)} triples; median of {reps} runs, ms",
        "| query | rows (each engine) | hriplan (rdflib + guards) | rdflib plain | pyoxigraph |",
        "|---|---|---|---|---|",
    ]
    limits = QueryLimits(time_limit=60, row_limit=10**7)
    for name, text in QUERIES.items():
        guarded = median_ms(lambda t=text: run_query(graph, t, limits), reps)
        plain = median_ms(lambda t=text: list(graph.query(prepare_query(t))), reps)
        oxi = median_ms(lambda t=text: list(store.query(t, prefixes=prefixes)), reps) if pyoxigraph else float("nan")
        rows = [len(run_query(graph, text, limits).rows), len(list(graph.query(prepare_query(text))))]
        rows += [len(list(store.query(text, prefixes=prefixes)))] if pyoxigraph else []
        counts = [str(r[0]) for r in run_query(graph, text, limits).rows] if "COUNT" in text else []
        lines.append(
            f"| {name} | {'/'.join(map(str, rows))}{' (count ' + counts[0] + ')' if counts else ''} | {guarded:.2f} | {plain:.2f} | {oxi:.2f} |"
        )
    began = time.perf_counter()
    try:
        run_query(graph, CROSS_JOIN, QueryLimits(time_limit=1.0))
    except Exception as exc:
        lines.append(
            f"| 4-way cross join, limit 1 s | - | stopped after {time.perf_counter() - began:.2f} s: {str(exc)[:40]}... | runs until killed | runs until killed (no time limit in the API) |"
        )
    return lines


def one(client: httpx.Client, kind: str, k: int) -> tuple[str, float, bool, str]:
    began = time.perf_counter()
    if kind == "plan":
        response = client.post("/plan", json={**TASK, "name": f"load{k}"})
        ok = response.status_code == 200 and response.json()["task"] == f"load{k}" and response.json()["solved"]
    elif kind == "solve":
        problem = copy.deepcopy(PROBLEM)
        problem["start"]["right_shoulder_pan_joint"] += k * 1e-5
        response = client.post("/solve", json=problem)
        body = response.json() if response.status_code == 200 else {}
        ok = (
            bool(body.get("solved"))
            and abs(body["trajectory"]["points"][0]["positions"][0] - problem["start"]["right_shoulder_pan_joint"])
            < 1e-9
        )
    elif kind == "constraints":
        response = client.post("/constraints", json={**TASK, "name": f"load{k}"})
        ok = response.status_code == 200 and response.json()["task"] == f"load{k}"
    else:
        response = client.get("/sparql", params={"query": f'SELECT ?tag WHERE {{ BIND("tag{k}" AS ?tag) }}'})
        ok = response.status_code == 200 and response.json()["results"]["bindings"][0]["tag"]["value"] == f"tag{k}"
    return kind, time.perf_counter() - began, ok, "" if ok else f"{response.status_code} {response.text[:120]}"


def load(url: str, requests: int, concurrency: int) -> list[str]:
    kinds = ["plan", "solve", "constraints", "sparql"]
    with httpx.Client(base_url=url, timeout=300) as client:
        for kind in kinds:  # warm every kind once (robot loads, reasoning cache)
            one(client, kind, -1)
        began = time.perf_counter()
        with concurrent.futures.ThreadPoolExecutor(concurrency) as pool:
            results = list(pool.map(lambda k: one(client, kinds[k % 4], k), range(requests)))
        wall = time.perf_counter() - began
    failures = [r for r in results if not r[2]]
    lines = [
        f"{requests} requests at concurrency {concurrency}: {wall:.1f} s, {len(failures)} errors or mixed-up answers",
        "| kind | n | p50 s | p95 s |",
        "|---|---|---|---|",
    ]
    for kind in kinds:
        times = sorted(r[1] for r in results if r[0] == kind)
        lines.append(
            f"| {kind} | {len(times)} | {times[len(times) // 2]:.2f} | {times[min(len(times) - 1, int(0.95 * len(times)))]:.2f} |"
        )
    lines += [f"failure: {f[3]}" for f in failures[:5]]
    return lines


def bomb(url: str) -> list[str]:
    with httpx.Client(base_url=url, timeout=120) as client:
        alone = [one(client, "solve", k)[1] for k in range(5)]
        bombs = [
            threading.Thread(target=client.get, args=("/sparql",), kwargs={"params": {"query": CROSS_JOIN}})
            for _ in range(2)
        ]
        for b in bombs:
            b.start()
        time.sleep(0.1)
        began = time.perf_counter()
        during = one(client, "solve", 99)
        waited = time.perf_counter() - began
        for b in bombs:
            b.join()
    return [
        f"solve alone: median {statistics.median(alone):.2f} s; during two SPARQL bombs (query limit 2 s): {waited:.2f} s, solved {during[2]}"
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--requests", type=int, default=200)
    parser.add_argument("--concurrency", type=int, default=8)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--reps", type=int, default=20)
    args = parser.parse_args()
    print("\n".join(engines(args.reps)), flush=True)
    with running_server("--workers", str(args.workers), "--query-time-limit", "2") as url:
        print("\n".join(load(url, args.requests, args.concurrency)), flush=True)
        print("\n".join(bomb(url)), flush=True)


if __name__ == "__main__":
    main()
