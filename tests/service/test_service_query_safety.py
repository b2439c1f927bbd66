"""SPARQL is read-only and closed (no updates, no SERVICE, no FROM), and stops at its limits:
the rules `hriplan query` and the HTTP endpoint share (ontology/sparql.py)."""

import csv
import http.server
import io
import json
import subprocess
import sys
import threading
import time
import xml.etree.ElementTree as ET

import pytest
import rdflib

from hriplan import HriplanError
from hriplan.ontology.sparql import QueryLimits, QueryTimeout, run_query
from hriplan.ontology.vocabulary import ontology_source

HP = "https://hriplan.org/ontology#"
CROSS_JOIN = "SELECT (COUNT(*) AS ?n) WHERE { ?a ?b ?c . ?d ?e ?f . ?g ?h ?i . ?j ?k ?l }"


@pytest.fixture(scope="module")
def graph() -> rdflib.Graph:
    return rdflib.Graph().parse(data=ontology_source(None).ntriples, format="nt")


@pytest.mark.parametrize(
    "update",
    [
        "INSERT DATA { hp:a hp:b hp:c }",
        "DELETE WHERE { ?s ?p ?o }",
        "PREFIX ex: <http://example.org/> DELETE { ?s ?p ?o } INSERT { ?s ?p 1 } WHERE { ?s ?p ?o }",
        "LOAD <http://127.0.0.1:9/data.ttl>",
        "CLEAR ALL",
        "DROP GRAPH <http://example.org/g>",
        "CREATE GRAPH <http://example.org/g>",
    ],
)
def test_updates_are_refused_by_name_and_the_graph_is_unchanged(graph, update):
    before = len(graph)
    with pytest.raises(HriplanError, match="^updates are not supported"):
        run_query(graph, update)
    assert len(graph) == before


class _Recorder(http.server.BaseHTTPRequestHandler):
    hits: list[str] = []

    def do_GET(self) -> None:
        _Recorder.hits.append(self.path)
        self.send_response(200)
        self.end_headers()

    def log_message(self, *args) -> None:
        pass


@pytest.fixture
def listener():
    """A loopback HTTP server that records any request a query would make."""
    server = http.server.HTTPServer(("127.0.0.1", 0), _Recorder)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    _Recorder.hits = []
    yield f"http://127.0.0.1:{server.server_address[1]}"
    server.shutdown()


@pytest.mark.parametrize(
    ("template", "message"),
    [
        ("SELECT * WHERE { SERVICE <{url}/sparql> { ?s ?p ?o } }", "^SERVICE is not supported"),
        (
            "SELECT * WHERE { ?x a hp:Can . OPTIONAL { SERVICE SILENT <{url}/s> { ?x ?p ?o } } }",
            "^SERVICE is not supported",
        ),
        ("SELECT * FROM <{url}/data.ttl> WHERE { ?s ?p ?o }", "^FROM and FROM NAMED are not supported"),
        ("SELECT * FROM NAMED <{url}/g.ttl> WHERE { GRAPH ?g { ?s ?p ?o } }", "^FROM and FROM NAMED are not supported"),
        ("ASK FROM <file:///etc/passwd> { ?s ?p ?o }", "^FROM and FROM NAMED are not supported"),
    ],
)
def test_nothing_outside_the_graph_is_fetched_or_read(graph, listener, template, message):
    with pytest.raises(HriplanError, match=message):
        run_query(graph, template.replace("{url}", listener))
    time.sleep(0.1)
    assert _Recorder.hits == []


def test_a_cross_join_stops_at_the_time_limit_with_a_clear_error(graph):
    began = time.monotonic()
    with pytest.raises(QueryTimeout, match=r"^the query ran past its time limit of 0.5 s"):
        run_query(graph, CROSS_JOIN, QueryLimits(time_limit=0.5))
    assert time.monotonic() - began < 5.0  # unlimited, it runs for hours; the slack is for a loaded machine


def test_a_large_answer_stops_at_the_row_limit(graph):
    with pytest.raises(HriplanError, match="^the query answers more than 100 rows"):
        run_query(graph, "SELECT * WHERE { ?s ?p ?o }", QueryLimits(row_limit=100))
    with pytest.raises(HriplanError, match="^the query answers more than 100 triples"):
        run_query(graph, "CONSTRUCT { ?s ?p ?o } WHERE { ?s ?p ?o }", QueryLimits(row_limit=100))
    assert len(run_query(graph, "SELECT * WHERE { ?s ?p ?o } LIMIT 100", QueryLimits(row_limit=100)).rows) == 100


def test_default_limits_apply_without_being_asked(graph):
    assert QueryLimits() == QueryLimits(time_limit=10.0, row_limit=10_000)
    assert len(graph) < 10_000 < len(graph) ** 2
    # ~940 000 rows: the default row limit stops it, or on a loaded machine the default time limit first.
    with pytest.raises(
        HriplanError, match=r"^the query (answers more than 10000 rows|ran past its time limit of 10 s)"
    ):
        run_query(graph, "SELECT * WHERE { ?a ?b ?c . ?d ?e ?f }")


def test_protocol_syntaxes_carry_the_same_rows(graph):
    result = run_query(graph, "SELECT ?kind ?tol WHERE { ?kind hp:hasTolerance ?tol } ORDER BY ?kind")
    kinds = [str(r[0]) for r in result.rows]
    assert len(kinds) >= 3 and all(k.startswith(HP) for k in kinds)
    as_json = [b["kind"]["value"] for b in json.loads(result.serialize("json"))["results"]["bindings"]]
    ns = {"s": "http://www.w3.org/2005/sparql-results#"}
    as_xml = [e.text for e in ET.fromstring(result.serialize("xml")).findall(".//s:binding[@name='kind']/s:uri", ns)]
    as_csv = [row[0] for row in list(csv.reader(io.StringIO(result.serialize("csv"))))[1:]]
    tsv = result.serialize("tsv").splitlines()
    assert tsv[0] == "?kind\t?tol" and tsv[1].split("\t")[1].endswith("^^<http://www.w3.org/2001/XMLSchema#decimal>")
    assert as_json == as_xml == as_csv == kinds == [line.split("\t")[0].strip("<>") for line in tsv[1:]]
    with pytest.raises(HriplanError, match="a SELECT result is served as json, xml, csv, tsv, not turtle"):
        result.serialize("turtle")


def test_the_command_line_follows_the_same_rules():
    def query(text: str) -> subprocess.CompletedProcess:
        return subprocess.run(
            [sys.executable, "-m", "hriplan.cli", "query", text], capture_output=True, text=True, timeout=120
        )

    update = query("INSERT DATA { hp:a hp:b hp:c }")
    assert (
        update.returncode == 2
        and update.stderr == "error: updates are not supported: the knowledge base is read-only\n"
    )
    service = query("SELECT * WHERE { SERVICE <http://127.0.0.1:9/s> { ?s ?p ?o } }")
    assert service.returncode == 2 and service.stderr.startswith("error: SERVICE is not supported")
