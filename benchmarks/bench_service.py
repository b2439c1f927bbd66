"""The HTTP service under load, and the SPARQL engine choice (rdflib vs pyoxigraph).

Run: PYTHONPATH=src .venv/bin/python benchmarks/bench_service.py [--requests 200] [--concurrency 8] [--workers 2] [--reps 20]
     [--before CHECKOUT] [--only-hostile] [--only-kernels] [--solves 12]
     [--only-tail --before CHECKOUT --tail-requests 200]
- engines: the same queries on the ontology and on a task step's reasoned graph, by rdflib as
  hriplan runs it (with its deadline and row guards), by plain rdflib, and by pyoxigraph (if
  installed); median over --reps. rdflib-endpoint evaluates with one of these two engines.
- load: a real server (`hriplan serve`, loopback, a free port, the compiled kernels on: its
  default) gets --requests mixed requests (task plan, problem solve, constraints, SPARQL) from
  --concurrency clients; every answer is
  checked against a marker of its own request (a task name, a start value, a literal), and
  latency p50/p95 per kind is printed. The loop is bounded by count and stops by itself.
- hostile: a server from this checkout and, with --before, one from another checkout (e.g.
  `git worktree add /tmp/svc-before main`), in the same run: cheap-query and solve latency alone,
  then while the issue-22 bombs (regex, VALUES join, nested REPLACE, 4-way cross join) are in
  flight; and each bomb's status and time (--query-time-limit 2, --request-time-limit 30). With
  --before, this checkout's server plans without the compiled kernels, as an older one does.
- kernels: two servers of this checkout with one planning worker each, `--no-kernels` and the
  default (compiled kernels loaded as a worker starts): the time each took to start, then
  --solves problems of benchmarks/scenarios (a, b, c; seeds 0, 1, ...) sent to both, alternating
  which goes first: median latency per scenario, and how many answers planned the same motion
  (positions within 1e-9 rad).
- tail (--only-tail): the latency tail of re-plans, where a full garbage collection in a worker
  or the server lands: a server from this checkout and one from --before (required), one
  planning worker each, get --tail-requests requests one at a time, alternating between the
  two servers (which goes first alternates too): /solve of b_madar_handover with its receiver
  moved (10 cm to and fro plus 1 mm more each time, as bench_replan) and a new seed, and /plan
  of the handover task renamed. Median, p95, the most, and how many took over twice the median,
  per kind and server.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import contextlib
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

from hriplan.service.launch import BOMBS, running_server  # noqa: E402

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


def _cheap(client: httpx.Client) -> float:
    began = time.perf_counter()
    assert client.get("/sparql", params={"query": QUERIES["tolerances"]}).status_code == 200
    return time.perf_counter() - began


def _bomb(url: str, name: str, query: str, out: dict[str, str]) -> None:
    began = time.perf_counter()
    try:
        response = httpx.get(f"{url}/sparql", params={"query": query}, timeout=120)
        out[name] = f"{response.status_code} after {time.perf_counter() - began:.1f} s"
    except httpx.TransportError as exc:
        out[name] = f"{type(exc).__name__} after {time.perf_counter() - began:.1f} s"


def _all_busy(health: dict) -> bool:
    """The bombs hold every query worker (before the query lane: every worker)."""
    return all(w["busy"] for w in health.get("query_workers", health["workers"]))


def hostile(url: str, label: str) -> list[str]:
    """Latency of cheap queries and solves alone, then with every bomb in flight at once."""
    with httpx.Client(base_url=url, timeout=120) as client:
        for k in range(2):  # warm both planning workers and the query path
            one(client, "solve", k)
        cheap_alone = [_cheap(client) for _ in range(10)]
        solve_alone = [one(client, "solve", k)[1] for k in range(3)]
        outcomes: dict[str, str] = {}
        bombs = {**BOMBS, "cross join": CROSS_JOIN}
        threads = [threading.Thread(target=_bomb, args=(url, n, q, outcomes)) for n, q in bombs.items()]
        for thread in threads:
            thread.start()
        while not _all_busy(client.get("/health").json()):
            time.sleep(0.05)
        solves = [one(client, "solve", 100 + k) for k in range(3)]
        cheap_during = [_cheap(client) for _ in range(3)]
        for thread in threads:
            thread.join()
    return [
        f"| {label} | {1e3 * statistics.median(cheap_alone):.0f} ms | {1e3 * max(cheap_during):.0f} ms"
        f" | {statistics.median(solve_alone):.2f} s | {max(s[1] for s in solves):.2f} s"
        f" ({sum(s[2] for s in solves)}/3 solved) | {'; '.join(f'{n}: {outcomes.get(n)}' for n in bombs)} |"
    ]


KERNEL_SCENARIOS = ("a_ur5_upright_box", "b_madar_handover", "c_madar_peg_in_hole")


def _solved_positions(client: httpx.Client, problem: dict) -> tuple[float, list | None]:
    began = time.perf_counter()
    body = client.post("/solve", json=problem).json()
    positions = [p["positions"] for p in body["trajectory"]["points"]] if body.get("solved") else None
    return time.perf_counter() - began, positions


def kernels(solves: int) -> list[str]:
    """The same problems solved by a server without the kernels and by one with them."""
    servers, started = {}, {}
    with contextlib.ExitStack() as stack:
        for label, extra in (("no kernels", ("--no-kernels",)), ("kernels", ())):
            began = time.perf_counter()
            servers[label] = stack.enter_context(running_server("--workers", "1", *extra))
            started[label] = time.perf_counter() - began
        clients = {
            label: stack.enter_context(httpx.Client(base_url=url, timeout=300)) for label, url in servers.items()
        }
        lines = [
            f"start-up (until /health answers, workers ready): no kernels {started['no kernels']:.1f} s, "
            f"kernels {started['kernels']:.1f} s",
            "| scenario | no kernels, median s | kernels, median s | ratio | same motion | solved (each) |",
            "|---|---|---|---|---|---|",
        ]
        for name in KERNEL_SCENARIOS:
            problem = json.loads((ROOT / "benchmarks" / "scenarios" / f"{name}.json").read_text())
            for client in clients.values():  # each worker's session for this robot made before timing
                _solved_positions(client, problem)
            times: dict[str, list[float]] = {label: [] for label in clients}
            solved, same = dict.fromkeys(clients, 0), 0
            for seed in range(solves):
                problem["options"]["seed"] = seed
                order = list(clients) if seed % 2 == 0 else list(clients)[::-1]
                found = {}
                for label in order:
                    seconds, found[label] = _solved_positions(clients[label], problem)
                    times[label].append(seconds)
                    solved[label] += found[label] is not None
                a, b = found.values()
                same += (
                    a is not None
                    and b is not None
                    and len(a) == len(b)
                    and max(abs(x - y) for p, r in zip(a, b) for x, y in zip(p, r)) <= 1e-9
                )
            off, on = (statistics.median(times[label]) for label in ("no kernels", "kernels"))
            lines.append(
                f"| {name} | {off:.3f} | {on:.3f} | {on / off:.2f} | {same}/{solves} | "
                f"{solved['no kernels']}/{solved['kernels']} of {solves} |"
            )
    return lines


def _moved(k: int) -> dict:
    """The handover problem with its receiver moved as bench_replan moves her, and seed k."""
    problem = copy.deepcopy(PROBLEM)
    person = problem["scene"]["humans"][0]
    dx = (0.1 if k % 2 == 0 else 0.0) + 0.001 * k
    person["position"][0] += dx
    person["reach"] = {side: [x + dx, y, z] for side, (x, y, z) in person["reach"].items()}
    problem["options"]["seed"] = k
    return problem


def _timed(client: httpx.Client, kind: str, k: int) -> float:
    began = time.perf_counter()
    if kind == "solve":
        response = client.post("/solve", json=_moved(k))
    else:
        response = client.post("/plan", json={**TASK, "name": f"tail{k + 1}"})
    assert response.status_code == 200, response.text[:200]
    return time.perf_counter() - began


def tail(before: Path, requests: int) -> list[str]:
    """Latency of re-plans one at a time on two one-worker servers, alternating: median, p95, most."""
    servers = {}
    with contextlib.ExitStack() as stack:
        for label, src in (("before", before / "src"), ("after", ROOT / "src")):
            servers[label] = stack.enter_context(running_server("--workers", "1", src=src))
        clients = {
            label: stack.enter_context(httpx.Client(base_url=url, timeout=120)) for label, url in servers.items()
        }
        for client in clients.values():  # each worker's session, reasoner and caches made before timing
            _timed(client, "solve", -1)
            _timed(client, "plan", -1)
        times: dict[tuple[str, str], list[float]] = {}
        for k in range(requests):
            kind = "solve" if k % 2 == 0 else "plan"
            for label in list(clients) if k // 2 % 2 == 0 else list(clients)[::-1]:
                times.setdefault((label, kind), []).append(_timed(clients[label], kind, k))
    lines = [
        f"{requests} requests, one at a time, alternating between the servers (one planning worker each)",
        "| server | kind | n | median ms | p95 ms | most ms | over twice the median |",
        "|---|---|---|---|---|---|---|",
    ]
    for (label, kind), values in sorted(times.items(), key=lambda item: (item[0][1], item[0][0] != "before")):
        ordered = sorted(values)
        p95 = ordered[min(len(ordered) - 1, int(0.95 * len(ordered)))]
        lines.append(
            f"| {label} | {kind} | {len(values)} | {1e3 * statistics.median(values):.0f} | {1e3 * p95:.0f}"
            f" | {1e3 * ordered[-1]:.0f} | {sum(v > 2 * statistics.median(values) for v in values)} |"
        )
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--requests", type=int, default=200)
    parser.add_argument("--concurrency", type=int, default=8)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--reps", type=int, default=20)
    parser.add_argument("--before", type=Path, help="another checkout to compare with (its src/ is served)")
    parser.add_argument("--only-hostile", action="store_true", help="skip the engine, load and kernels parts")
    parser.add_argument("--only-kernels", action="store_true", help="only the kernels part")
    parser.add_argument("--solves", type=int, default=12, help="problems per scenario in the kernels part")
    parser.add_argument("--only-tail", action="store_true", help="only the tail part (needs --before)")
    parser.add_argument("--tail-requests", type=int, default=200, help="requests per server in the tail part")
    args = parser.parse_args()
    if args.only_tail:
        if args.before is None:
            parser.error("--only-tail compares with --before CHECKOUT")
        print("\n".join(tail(args.before, args.tail_requests)), flush=True)
        return
    if not args.only_hostile:
        print("\n".join(kernels(args.solves)), flush=True)
    if args.only_kernels:
        return
    if not args.only_hostile:
        print("\n".join(engines(args.reps)), flush=True)
        with running_server("--workers", str(args.workers), "--query-time-limit", "2") as url:
            print("\n".join(load(url, args.requests, args.concurrency)), flush=True)
    print(
        "| server | cheap query alone (median) | during bombs (slowest of 3) | solve alone (median)"
        " | solve during bombs (slowest of 3) | bombs (status after time) |",
        "|---|---|---|---|---|---|",
        sep="\n",
    )
    hostile_args = ("--workers", str(args.workers), "--query-time-limit", "2", "--request-time-limit", "30")
    # Against a checkout from before the compiled kernels, this one's solves go without them too.
    after_args = ("--no-kernels",) if args.before else ()
    for label, src, extra in [
        ("before", args.before / "src" if args.before else None, ()),
        ("after", ROOT / "src", after_args),
    ]:
        if src is not None:
            with running_server(*hostile_args, *extra, src=src) as url:
                print("\n".join(hostile(url, f"{label} ({src.parent.name})")), flush=True)


if __name__ == "__main__":
    main()
