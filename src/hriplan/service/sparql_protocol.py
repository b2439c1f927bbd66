"""SPARQL 1.1 Protocol endpoints: the ontology alone, and each stored task's reasoned graph
(its first step, or a named step). GET ?query=, POST application/sparql-query or form-encoded;
GET without a query answers the service description. Updates, other datasets and SERVICE
are refused (ontology/sparql.py holds the query rules; the worker evaluates within its limits).
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import Any
from urllib.parse import parse_qs

import rdflib
from fastapi import FastAPI, Request, Response

from hriplan.ontology.sparql import UPDATES_REFUSED
from hriplan.service.errors import RequestError
from hriplan.service.negotiation import GRAPH_TYPES, RESULT_TYPES, choose

SD = rdflib.Namespace("http://www.w3.org/ns/sparql-service-description#")
FORMATS = rdflib.Namespace("http://www.w3.org/ns/formats/")
FORMAT_IRIS = (
    "SPARQL_Results_JSON",
    "SPARQL_Results_XML",
    "SPARQL_Results_CSV",
    "SPARQL_Results_TSV",
    "Turtle",
    "JSON-LD",
    "N-Triples",
)
FORM = "application/x-www-form-urlencoded"
QUERY = "application/sparql-query"

Run = Callable[[Request, dict[str, Any]], Awaitable[Response]]
TaskLookup = Callable[[str], dict[str, Any]]


async def _parameters(request: Request) -> dict[str, list[str]]:
    """The protocol's parameters from the query string and, for POST, the body."""
    params = parse_qs(request.url.query, keep_blank_values=True)
    if request.method == "POST":
        media = request.headers.get("content-type", "").split(";")[0].strip().lower()
        body = (await request.body()).decode("utf-8", errors="replace")
        if media == QUERY:
            params.setdefault("query", []).append(body)
        elif media == FORM:
            for name, values in parse_qs(body, keep_blank_values=True).items():
                params.setdefault(name, []).extend(values)
        elif media == "application/sparql-update":
            raise RequestError(403, UPDATES_REFUSED)
        else:
            raise RequestError(415, f"POST a query as {QUERY} or {FORM} (query=...), not {media or 'no content type'}")
    if "update" in params:
        raise RequestError(403, UPDATES_REFUSED)
    if "default-graph-uri" in params or "named-graph-uri" in params:
        raise RequestError(
            400, "default-graph-uri and named-graph-uri are not supported: each endpoint's dataset is fixed"
        )
    if len(params.get("query", [])) > 1:
        raise RequestError(400, "give one query per request")
    return params


def service_description(endpoint: str, accept: str | None) -> Response:
    """What the endpoint offers, in the SPARQL 1.1 Service Description vocabulary."""
    graph, service = rdflib.Graph(), rdflib.URIRef(endpoint)
    graph.bind("sd", SD)
    graph.bind("formats", FORMATS)
    graph.add((service, rdflib.RDF.type, SD.Service))
    graph.add((service, SD.endpoint, service))
    graph.add((service, SD.supportedLanguage, SD.SPARQL11Query))
    for name in FORMAT_IRIS:
        graph.add((service, SD.resultFormat, FORMATS[name]))
    dataset, default = rdflib.BNode(), rdflib.BNode()
    graph.add((service, SD.defaultDataset, dataset))
    graph.add((dataset, rdflib.RDF.type, SD.Dataset))
    graph.add((dataset, SD.defaultGraph, default))
    graph.add((default, rdflib.RDF.type, SD.Graph))
    graph.add(
        (
            service,
            rdflib.RDFS.comment,
            rdflib.Literal(
                "Read-only: updates, SERVICE and FROM are refused; queries stop at a time limit and a row limit."
            ),
        )
    )
    syntax, media = choose(True, accept)
    return Response(graph.serialize(format=syntax), media_type=media)


def _own_url(request: Request) -> str:
    """The endpoint's URL from the address the client reached, never from its Host header (which
    a page could set to anything)."""
    host, port = request.scope["server"]
    return f"http://{f'[{host}]' if ':' in host else host}:{port}{request.url.path}"


def add_sparql_routes(app: FastAPI, run: Run, task: TaskLookup) -> None:
    """/sparql (the ontology), /tasks/{id}/sparql and /tasks/{id}/steps/{step}/sparql."""
    media = sorted({t for table in (RESULT_TYPES, GRAPH_TYPES) for types in table.values() for t in types})
    doc = {"responses": {"200": {"content": {m: {} for m in media}, "description": "The result, as negotiated."}}}

    async def answer(request: Request, target: dict[str, Any]) -> Response:
        params = await _parameters(request)
        if "query" not in params:
            return service_description(_own_url(request), request.headers.get("accept"))
        payload = {
            **target,
            "query": params["query"][0],
            "accept": request.headers.get("accept"),
            "format": (params.get("format") or params.get("output") or [None])[0],
        }
        return await run(request, payload)

    @app.get("/sparql", tags=["sparql"], openapi_extra=doc)
    @app.post("/sparql", tags=["sparql"], openapi_extra=doc)
    async def ontology_sparql(request: Request) -> Response:
        """SPARQL over the ontology alone (classes, properties, constraint kinds, parameters)."""
        return await answer(request, {"task": None})

    @app.get("/tasks/{task_id}/sparql", tags=["sparql"], openapi_extra=doc)
    @app.post("/tasks/{task_id}/sparql", tags=["sparql"], openapi_extra=doc)
    async def task_sparql(request: Request, task_id: str) -> Response:
        """SPARQL over a stored task's first step: ontology, rules, facts and what was inferred."""
        return await answer(request, {**task(task_id), "step": None})

    @app.get("/tasks/{task_id}/steps/{step}/sparql", tags=["sparql"], openapi_extra=doc)
    @app.post("/tasks/{task_id}/steps/{step}/sparql", tags=["sparql"], openapi_extra=doc)
    async def step_sparql(request: Request, task_id: str, step: str) -> Response:
        """SPARQL over one step's situation of a stored task (the facts as they are at that step)."""
        return await answer(request, {**task(task_id), "step": step})
