"""The server's edge: loopback unless a token is set, the token itself, body limits, no server
files named by a request (mesh paths, rule files outside the configured folder), YAML without
aliases, CORS off unless asked, and the per-request time limit."""

import copy
import json
import subprocess
import sys
from pathlib import Path

import httpx
import pytest
import rdflib
import yaml
from service_server import SRC, running_server, shared_server, wait_for_workers
from starlette.testclient import TestClient

from hriplan.service.app import create_app
from hriplan.service.config import ServiceConfig

ROOT = Path(__file__).resolve().parents[2]
TOKEN = "s3cret-token-for-tests"
AUTH = {"Authorization": f"Bearer {TOKEN}"}
TASK = yaml.safe_load((ROOT / "examples" / "handover_empty_can.yaml").read_text())
PROBLEM = json.loads((ROOT / "benchmarks" / "scenarios" / "b_madar_handover.json").read_text())
PANDA = ROOT / "tests" / "data" / "robots" / "panda.yaml"
RULE = (
    "# Any can is carried upright, full or not (a test rule).\n"
    "[upright_any_can] TransportingTask(?t) ^ movesObject(?t, ?o) ^ Can(?o) -> isConstrainedBy(?o, UprightPartial)\n"
)


@pytest.fixture(scope="module")
def rules_dir(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("rules")
    (folder / "cans.rules").write_text(RULE)
    (folder.parent / "outside.rules").write_text(RULE)
    return folder


@pytest.fixture(scope="module")
def server(rules_dir):
    args = (
        "--workers",
        "1",
        "--token",
        TOKEN,
        "--request-time-limit",
        "8",
        "--body-limit",
        "8192",
        "--rules-dir",
        str(rules_dir),
        "--robot-file",
        str(PANDA),
        "--no-kernels",
    )
    # --no-kernels wins over the HRIPLAN_KERNELS=1 its workers inherit
    with running_server(*args, token=TOKEN, environment={"HRIPLAN_KERNELS": "1"}) as url:
        yield url


@pytest.fixture(scope="module")
def client(server):
    with httpx.Client(base_url=server, headers=AUTH, timeout=60) as c:
        yield c


def serve(*args: str, **env_vars: str) -> subprocess.CompletedProcess:
    env = {"PYTHONPATH": str(SRC), "PATH": "/usr/bin:/bin", **env_vars}
    return subprocess.run(
        [sys.executable, "-m", "hriplan.cli", "serve", *args], env=env, capture_output=True, text=True, timeout=60
    )


def test_binding_off_loopback_needs_a_token():
    refused = serve("--host", "0.0.0.0", "--port", "0")
    assert (
        refused.returncode == 2
        and refused.stderr.strip()
        == "error: binding to 0.0.0.0 (not loopback) needs a bearer token: --token or HRIPLAN_TOKEN"
    )
    for option, value, message in [
        ("--query-time-limit", "0", "Input should be greater than 0"),
        ("--row-limit", "0", "Input should be greater than 0"),
        ("--response-limit", "0", "Input should be greater than 0"),
        ("--query-workers", "0", "Input should be greater than or equal to 1"),
    ]:
        bad = serve(option, value)  # named as the option given (--row-limit was --query-row-limit)
        assert bad.returncode == 2 and bad.stderr.strip() == f"error: {option}: {message}"
    short = serve("--token", "abc", "--port", "0")
    assert short.returncode == 2 and short.stderr.startswith(
        "error: --token: String should have at least 16 characters"
    )


def test_with_no_kernels_the_planning_workers_have_them_off_despite_the_environment(client):
    assert [w["kernels"] for w in client.get("/health").json()["workers"]] == [False]


def test_every_route_needs_the_token(server, client):
    for path in ("/health", "/sparql?query=ASK%7B%7D", "/docs", "/openapi.json"):
        missing = httpx.get(server + path)
        wrong = httpx.get(server + path, headers={"Authorization": "Bearer not-the-token-at-all"})
        assert missing.status_code == wrong.status_code == 401 and missing.headers["www-authenticate"] == "Bearer"
        assert missing.json()["error"].startswith("a bearer token is required")
    assert client.get("/health").status_code == 200
    assert client.get("/sparql", params={"query": "ASK {}"}).json()["boolean"] is True


def test_bodies_over_the_limit_are_413_declared_or_streamed(server):
    big = b'{"steps": [' + b" " * 9000 + b"]}"
    declared = httpx.post(f"{server}/constraints", content=big, headers={**AUTH, "content-type": "application/json"})
    streamed = httpx.post(
        f"{server}/constraints",
        content=iter([big[:5000], big[5000:]]),
        headers={**AUTH, "content-type": "application/json"},
    )
    assert declared.status_code == streamed.status_code == 413
    assert streamed.json()["error"] == "the request body is larger than the limit of 8192 bytes"


def test_rule_files_come_only_from_the_configured_folder(client):
    plain = client.post("/constraints", json=TASK).json()
    assert plain["steps"][0]["derivation"]["constraints"] and "UprightPartial" not in {
        c["kind"] for c in plain["steps"][0]["derivation"]["constraints"]
    }
    ruled = client.post("/constraints", json={**TASK, "rule_files": ["cans.rules"]})
    assert ruled.status_code == 200, ruled.text
    upright = [c for c in ruled.json()["steps"][0]["derivation"]["constraints"] if c["kind"] == "UprightPartial"]
    assert [c["rules"][0] for c in upright] == ["upright_any_can"]
    outside = "is outside the server's rules folder; name a file in it"
    for name, message in [
        ("../outside.rules", outside),
        ("/etc/passwd", outside),
        ("missing.rules", "is not in the server's rules folder"),
    ]:
        refused = client.post("/constraints", json={**TASK, "rule_files": [name]})
        assert refused.status_code == 400 and refused.json()["error"] == f"rule file {name!r} {message}"


def test_a_robot_file_is_read_only_if_the_server_was_started_with_it(client):
    """Was: any `robot_file` a request named was read at validation ('/etc/passwd: expected a
    mapping of fields at the top level, got str'), telling a client about any file the server
    could read. Now only the files given to `--robot-file`, in JSON, YAML or a body without a type."""
    refused = "robot_file '/etc/passwd' is not one of the robot files this server was started with"
    problem = copy.deepcopy(PROBLEM) | {"robot_file": "/etc/passwd"}
    for path, body, headers in [
        ("/constraints", json.dumps({**TASK, "robot_file": "/etc/passwd"}), {"content-type": "application/json"}),
        ("/constraints", yaml.safe_dump({**TASK, "robot_file": "/etc/passwd"}), {"content-type": "application/yaml"}),
        ("/solve", json.dumps(problem), {}),
    ]:
        response = client.post(path, content=body, headers=headers)
        assert response.status_code == 400 and response.json()["error"].startswith(refused), response.text
    # the Panda it was started with derives (its worker loads the file too)
    task = yaml.safe_load((PANDA.parent / "panda_cup.yaml").read_text()) | {"robot": "panda", "robot_file": str(PANDA)}
    derived = client.post("/constraints", json=task)
    assert derived.status_code == 200, derived.text
    kinds = {c["kind"] for c in derived.json()["steps"][0]["derivation"]["constraints"]}
    assert "UprightPartial" in kinds


def test_serve_refuses_a_bad_robot_file_at_start(tmp_path):
    bad = tmp_path / "robot.yaml"
    bad.write_text("name: x\n")
    done = subprocess.run(
        [sys.executable, "-m", "hriplan.cli", "serve", "--port", "0", "--robot-file", str(bad)],
        capture_output=True,
        text=True,
        timeout=120,
        env={"PYTHONPATH": str(SRC), "PATH": "/usr/bin:/bin"},
    )
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert done.stderr.startswith(f"error: --robot-file: {bad}: "), done.stderr


def test_mesh_shapes_which_name_server_files_are_refused_everywhere(client):
    mesh = {"type": "mesh", "path": "/etc/passwd"}
    task = copy.deepcopy(TASK)
    task["objects"][0]["shape"] = mesh
    problem = copy.deepcopy(PROBLEM)
    problem["scene"]["obstacles"].append({"name": "m", "shape": mesh})
    for path, body in [
        ("/constraints", task),
        ("/solve", problem),
        ("/sessions", {"scene": {"obstacles": [{"name": "m", "shape": mesh}]}}),
    ]:
        response = client.post(path, json=body)
        assert response.status_code == 400 and response.json()["error"].startswith(
            "mesh shapes name a file on the server"
        )


def test_yaml_aliases_are_refused(client):
    bomb = "a: &a [x, x, x]\nb: &b [*a, *a, *a]\nc: [*b, *b, *b]\nsteps: []\n"
    response = client.post("/constraints", content=bomb, headers={"content-type": "application/yaml"})
    assert (
        response.status_code == 400
        and response.json()["error"] == "body: line 2: not valid YAML (aliases are not accepted in request bodies)"
    )


def test_a_request_past_its_time_limit_is_504_and_its_worker_is_replaced(server, client):
    (before,) = wait_for_workers(server, 1, AUTH)
    slow = copy.deepcopy(PROBLEM)
    slow["options"].update(planner="RRTConnect", space="rejection", time_limit=60, seed=1)
    for constraint in slow["constraints"]["constraints"]:  # a band too thin for rejection sampling to meet
        if constraint["type"] == "orientation":
            constraint["tolerance"] = 0.002
    response = client.post("/solve", json=slow)
    assert (
        response.status_code == 504
        and response.json()["error"] == "the request ran past its time limit of 8 s and was stopped"
    )
    (after,) = wait_for_workers(server, 1, AUTH)
    assert after != before


def test_cors_is_off_unless_origins_are_given():
    origin = {"Origin": "https://dashboard.example", "Access-Control-Request-Method": "POST"}

    def preflight(config: ServiceConfig) -> httpx.Response:
        return TestClient(create_app(config)).options("/plan", headers=origin)  # no `with`: no lifespan, no workers

    closed = preflight(ServiceConfig())
    assert "access-control-allow-origin" not in closed.headers
    opened = preflight(ServiceConfig(cors_origins=["https://dashboard.example"]))
    assert opened.status_code == 200 and opened.headers["access-control-allow-origin"] == "https://dashboard.example"


def test_without_a_token_only_loopback_hosts_and_the_servers_own_origin_get_in():
    url = shared_server()
    port = int(url.rsplit(":", 1)[1])
    ask = {"query": "ASK {}"}

    def status(host: str | None = None, origin: str | None = None, method: str = "GET") -> httpx.Response:
        headers = {k: v for k, v in (("host", host), ("origin", origin)) if v is not None}
        if method == "POST":  # what a web page's plain form sends
            return httpx.post(f"{url}/sparql", data=ask, headers=headers)
        return httpx.get(f"{url}/sparql", params=ask, headers=headers)

    for host in (f"localhost:{port}", f"127.0.0.1:{port}", f"[::1]:{port}", f"LOCALHOST:{port}"):
        assert status(host).status_code == 200, host
    own = status(f"localhost:{port}", f"http://localhost:{port}", "POST")
    assert own.status_code == 200 and own.json()["boolean"] is True
    for host in (f"rebound.example:{port}", "127.0.0.1", f"127.0.0.1:{port + 1}", f"127.0.0.1.nip.io:{port}"):
        refused = status(host)  # DNS rebinding: a name of the attacker's that now points here
        assert refused.status_code == 403 and refused.json()["error"] == (
            f"the Host header {host!r} is not this server (loopback at port {port}); "
            "serve another name with --allowed-host NAME"
        ), host
    for origin in ("https://attacker.example", "null", f"http://127.0.0.1:{port + 1}"):
        refused = status(f"127.0.0.1:{port}", origin, "POST")
        assert refused.status_code == 403 and refused.json()["error"] == (
            f"requests from the web page at {origin} are refused "
            "(not this server's origin; allow one with --cors-origin)"
        )


def test_the_service_description_names_the_address_reached_not_the_host_header():
    url = shared_server()
    port = url.rsplit(":", 1)[1]
    answer = httpx.get(f"{url}/sparql", headers={"host": f"localhost:{port}", "accept": "text/turtle"})
    graph = rdflib.Graph().parse(data=answer.text, format="turtle")
    sd = rdflib.Namespace("http://www.w3.org/ns/sparql-service-description#")
    assert set(graph.subjects(rdflib.RDF.type, sd.Service)) == {rdflib.URIRef(f"http://127.0.0.1:{port}/sparql")}
    assert "localhost" not in answer.text


def test_allowed_hosts_and_cors_origins_are_let_in():
    config = ServiceConfig(allowed_hosts=["robot.local"], cors_origins=["https://dashboard.example"])
    client = TestClient(create_app(config), base_url="http://127.0.0.1:8000")  # no lifespan: no workers
    assert client.get("/sessions/x", headers={"host": "robot.local:8000"}).status_code == 404  # past the guard
    assert client.get("/sessions/x", headers={"host": "robot.other:8000"}).status_code == 403
    assert client.get("/sessions/x", headers={"origin": "https://dashboard.example"}).status_code == 404
    with_token = TestClient(create_app(ServiceConfig(token="t" * 16)), base_url="http://robot.example:8000")
    assert with_token.get("/sessions/x", headers=dict(AUTH, authorization="Bearer " + "t" * 16)).status_code == 404


def test_a_token_comes_from_a_file_or_the_environment_and_is_never_blank(tmp_path):
    blank = "error: --token: a token may not contain spaces or line breaks"
    for refused in (serve("--token", " " * 20), serve(HRIPLAN_TOKEN=" " * 20), serve("--token", "abcdefgh ijklmnopq")):
        assert refused.returncode == 2 and refused.stderr.strip() == blank  # was accepted
    empty = tmp_path / "empty"
    empty.write_text("\n  \n")
    refused = serve("--token-file", str(empty))
    assert (
        refused.returncode == 2
        and refused.stderr.strip() == f"error: --token-file {empty}: the first line holds no token"
    )
    missing = serve("--token-file", str(tmp_path / "nope"))
    assert missing.returncode == 2 and missing.stderr.strip() == f"error: {tmp_path / 'nope'}: no such file"
    both = serve("--token-file", str(empty), "--token", TOKEN)
    assert both.returncode == 2 and both.stderr.strip().startswith("error: give the token once")
    kept = tmp_path / "token"
    kept.write_text(TOKEN + "\n")
    with running_server("--workers", "1", "--token-file", str(kept), token=TOKEN) as url:
        assert httpx.get(f"{url}/health").status_code == 401
        assert httpx.get(f"{url}/health", headers=AUTH).json()["status"] == "ok"


def test_without_the_server_extra_the_hint_names_this_checkouts_python(tmp_path):
    (tmp_path / "uvicorn.py").write_text("raise ModuleNotFoundError(\"No module named 'uvicorn'\", name='uvicorn')\n")
    env = {"PYTHONPATH": f"{tmp_path}:{SRC}", "PATH": "/usr/bin:/bin"}
    missing = subprocess.run(
        [sys.executable, "-m", "hriplan.cli", "serve"], env=env, capture_output=True, text=True, timeout=60
    )
    assert missing.returncode == 2 and missing.stderr.strip() == (
        f"error: the server needs the `server` extra ({sys.executable} -m pip install -e '{ROOT}[server]'): "
        "uvicorn is missing"
    )


def test_the_schema_lists_the_sparql_routes_and_the_bearer_scheme_and_docs_load_nothing_from_elsewhere(client):
    schema = client.get("/openapi.json").json()
    assert {"get", "post"} <= set(schema["paths"]["/sparql"]) and "/tasks/{task_id}/steps/{step}/sparql" in schema[
        "paths"
    ]
    assert schema["components"]["securitySchemes"]["bearer"] == {"type": "http", "scheme": "bearer"}
    assert schema["security"] == [{"bearer": []}]
    page = client.get("/docs")
    assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
    assert "<script" not in page.text and "//" not in page.text.replace("http://", "")  # was swagger-ui from a CDN
    assert "/tasks/{task_id}/sparql" in page.text
