"""The SPARQL 1.1 Protocol endpoint of the real server, spoken to by SPARQLWrapper (a real
SPARQL client) and, where SPARQLWrapper cannot send the request, by httpx."""

import csv
import io
from pathlib import Path

import httpx
import pytest
import rdflib
import yaml
from service_server import shared_server
from SPARQLWrapper import CSV, JSON, JSONLD, POST, POSTDIRECTLY, TSV, TURTLE, URLENCODED, XML, SPARQLWrapper
from SPARQLWrapper.SPARQLExceptions import QueryBadFormed

ROOT = Path(__file__).resolve().parents[2]
TASK = yaml.safe_load((ROOT / "examples" / "handover_full_can.yaml").read_text())
HP = "https://hriplan.org/ontology#"
TOLERANCES = "SELECT ?kind ?tol WHERE { ?kind hp:hasTolerance ?tol } ORDER BY ?kind"
REQUIRED = "SELECT ?kind WHERE { ?step hp:requiresConstraint ?kind } ORDER BY ?kind"
CROSS_JOIN = "SELECT (COUNT(*) AS ?n) WHERE { ?a ?b ?c . ?d ?e ?f . ?g ?h ?i . ?j ?k ?l }"


@pytest.fixture(scope="module")
def server():
    return shared_server()  # --workers 2 --queue 2 --query-time-limit 1 --row-limit 100


@pytest.fixture(scope="module")
def stored(server):
    response = httpx.post(f"{server}/tasks", json=TASK)
    assert response.status_code == 201
    return response.json()


def endpoint(url: str, query: str, fmt: str, method: str = "GET", request: str = URLENCODED) -> SPARQLWrapper:
    client = SPARQLWrapper(url)
    client.setQuery(query)
    client.setReturnFormat(fmt)
    client.setMethod(method)
    client.setRequestMethod(request)
    return client


def kinds(bindings: list[dict]) -> list[str]:
    return [b["kind"]["value"].removeprefix(HP) for b in bindings]


def test_select_is_the_same_rows_in_json_xml_csv_and_tsv(server):
    url = f"{server}/sparql"
    from_json = kinds(endpoint(url, TOLERANCES, JSON).queryAndConvert()["results"]["bindings"])
    assert {"UprightFull", "UprightPartial", "InsertionAlignment"} <= set(from_json)
    document = endpoint(url, TOLERANCES, XML).queryAndConvert()  # a parsed DOM
    from_xml = [u.firstChild.data.removeprefix(HP) for u in document.getElementsByTagName("uri")]
    from_csv = [
        row[0].removeprefix(HP)
        for row in list(csv.reader(io.StringIO(endpoint(url, TOLERANCES, CSV).queryAndConvert().decode())))[1:]
    ]
    tsv = endpoint(url, TOLERANCES, TSV).queryAndConvert().decode().splitlines()
    from_tsv = [line.split("\t")[0].strip("<>").removeprefix(HP) for line in tsv[1:]]
    assert tsv[0] == "?kind\t?tol" and from_json == from_xml == from_csv == from_tsv


def test_post_as_a_sparql_query_body_and_as_a_form_answer_alike(server):
    url = f"{server}/sparql"
    direct = endpoint(url, TOLERANCES, JSON, POST, POSTDIRECTLY).queryAndConvert()
    form = endpoint(url, TOLERANCES, JSON, POST, URLENCODED).queryAndConvert()
    assert direct == form and kinds(direct["results"]["bindings"])


def test_ask_and_construct_negotiate_their_own_syntaxes(server):
    url = f"{server}/sparql"
    assert endpoint(url, "ASK { hp:UprightFull hp:hasTolerance ?t }", JSON).queryAndConvert()["boolean"] is True
    construct = "CONSTRUCT { ?k hp:hasTolerance ?t } WHERE { ?k hp:hasTolerance ?t }"
    turtle = endpoint(url, construct, TURTLE).queryAndConvert()
    graph = rdflib.Graph().parse(data=turtle, format="turtle")
    assert (rdflib.URIRef(HP + "UprightFull"), rdflib.URIRef(HP + "hasTolerance"), None) in graph
    as_jsonld = endpoint(url, construct, JSONLD).queryAndConvert()  # SPARQLWrapper parses it into a graph
    assert set(as_jsonld) == set(graph)
    refused = httpx.get(url, params={"query": TOLERANCES}, headers={"accept": "text/turtle"})
    assert refused.status_code == 406 and "offered: application/sparql-results+json" in refused.json()["error"]


def test_a_stored_tasks_graph_answers_per_step_as_the_rules_derived(server, stored):
    assert stored["steps"] == ["take_can", "place_can"]
    derived = httpx.post(f"{server}/constraints", json=TASK).json()
    for index, step in enumerate(stored["steps"]):
        url = f"{server}/tasks/{stored['id']}/steps/{step}/sparql"
        answer = kinds(endpoint(url, REQUIRED, JSON).queryAndConvert()["results"]["bindings"])
        assert answer == sorted({c["kind"] for c in derived["steps"][index]["derivation"]["constraints"]})
    first = endpoint(f"{server}/tasks/{stored['id']}/sparql", REQUIRED, JSON).queryAndConvert()
    assert kinds(first["results"]["bindings"]) == [  # the take: the can is not carried (upright) before it
        "ApproachCone",
        "ReceiverExclusionBox",
        "SharedWorkspaceBox",
    ]
    assert httpx.get(f"{server}/tasks/{stored['id']}/steps/nap/sparql", params={"query": REQUIRED}).status_code == 404
    assert httpx.get(f"{server}/tasks/nope/sparql", params={"query": REQUIRED}).json() == {
        "error": "no stored task 'nope'",
        "field": None,
    }


@pytest.mark.parametrize(
    ("query", "message"),
    [
        ("SELECT * WHERE { SERVICE <http://127.0.0.1:9/sparql> { ?s ?p ?o } }", "SERVICE is not supported"),
        ("SELECT * FROM <file:///etc/passwd> WHERE { ?s ?p ?o }", "FROM and FROM NAMED are not supported"),
        ("SELECT ?x WHERE { ?x hp:isNear ", "SPARQL syntax error at line 1"),
    ],
)
def test_refused_queries_are_400_with_the_reason(server, query, message):
    with pytest.raises(QueryBadFormed, match=message):
        endpoint(f"{server}/sparql", query, JSON).queryAndConvert()


def test_update_requests_and_other_datasets_are_refused(server):
    url = f"{server}/sparql"
    update = httpx.post(url, content="CLEAR ALL", headers={"content-type": "application/sparql-update"})
    form = httpx.post(url, data={"update": "INSERT DATA { hp:a hp:b hp:c }"})
    as_query = [httpx.get(url, params={"query": q}) for q in ("INSERT DATA { hp:a hp:b hp:c }", "CLEAR ALL")]
    for refused in (update, form, *as_query):  # 403 as other endpoints answer (was 400)
        assert refused.status_code == 403 and refused.json()["error"] == (
            "updates are not supported: the knowledge base is read-only"
        )
    dataset = httpx.get(url, params={"query": TOLERANCES, "default-graph-uri": "http://example.org/g"})
    assert dataset.status_code == 400 and "default-graph-uri" in dataset.json()["error"]
    assert httpx.post(url, content=TOLERANCES, headers={"content-type": "text/plain"}).status_code == 415


def test_the_service_description_says_what_is_offered(server):
    response = httpx.get(f"{server}/sparql", headers={"accept": "text/turtle"})
    assert response.status_code == 200 and response.headers["content-type"].startswith("text/turtle")
    graph = rdflib.Graph().parse(data=response.text, format="turtle")
    sd = rdflib.Namespace("http://www.w3.org/ns/sparql-service-description#")
    service = rdflib.URIRef(f"{server}/sparql")
    assert (service, rdflib.RDF.type, sd.Service) in graph and (service, sd.endpoint, service) in graph
    assert (service, sd.supportedLanguage, sd.SPARQL11Query) in graph
    assert {str(f).rsplit("/", 1)[1] for f in graph.objects(service, sd.resultFormat)} >= {
        "SPARQL_Results_JSON",
        "SPARQL_Results_TSV",
        "Turtle",
    }


def test_limits_give_clear_errors(server):
    timed_out = httpx.get(f"{server}/sparql", params={"query": CROSS_JOIN})
    assert timed_out.status_code == 504 and timed_out.json()["error"].startswith(
        "the query ran past its time limit of 1 s"
    )
    too_many = httpx.get(f"{server}/sparql", params={"query": "SELECT * WHERE { ?s ?p ?o }"})  # ~1000 triples
    assert too_many.status_code == 400 and "more than 100 rows (the row limit)" in too_many.json()["error"]
    assert (
        len(
            httpx.get(f"{server}/sparql", params={"query": "SELECT * WHERE { ?s ?p ?o } LIMIT 100"}).json()["results"][
                "bindings"
            ]
        )
        == 100
    )


def test_graph_results_with_the_clients_defaults_rdf_xml_and_n_triples(server):
    url, construct = f"{server}/sparql", "CONSTRUCT { ?k hp:hasTolerance ?t } WHERE { ?k hp:hasTolerance ?t }"
    expected = {(rdflib.URIRef(HP + k), rdflib.URIRef(HP + "hasTolerance")) for k in ("UprightFull", "UprightPartial")}
    client = SPARQLWrapper(url)  # its default return format: XML, so RDF/XML for a graph (was 406)
    client.setQuery(construct)
    by_default = client.queryAndConvert()
    assert expected <= {(s, p) for s, p, _ in by_default}
    store = rdflib.Graph(store="SPARQLStore")  # rdflib's own client, with its defaults
    store.open(url)
    from_store = store.query(construct).graph
    assert set(from_store) == set(by_default)
    for accept in ("application/n-triples", "application/rdf+xml"):
        answer = httpx.get(url, params={"query": construct}, headers={"accept": accept})
        syntax = {"application/n-triples": "nt", "application/rdf+xml": "xml"}[accept]
        assert answer.headers["content-type"].startswith(accept)
        assert set(rdflib.Graph().parse(data=answer.text, format=syntax)) == set(by_default)
