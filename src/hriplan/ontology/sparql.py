"""SPARQL 1.1 queries (SELECT, ASK, CONSTRUCT, DESCRIBE) on a reasoned graph, with rdflib.

The ontology's prefixes (hp:, sit:, rule:, rdf:, rdfs:, owl:, xsd:, swrl:, swrlb:) are
predefined. Results render as an aligned table, SPARQL results JSON or CSV; graph results
(CONSTRUCT, DESCRIBE) as Turtle, JSON-LD, or a subject/predicate/object table or CSV.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import Literal

import pyparsing
import rdflib
from rdflib.plugins.sparql import prepareQuery
from rdflib.query import Result

from hriplan import HriplanError

from .vocabulary import PREFIXES

QueryFormat = Literal["table", "json", "csv", "turtle"]
FORMATS: tuple[str, ...] = ("table", "json", "csv", "turtle")
QUERIES_DIR = Path(__file__).with_name("queries")


class QueryResult:
    """One query's answer: rows (SELECT), a boolean (ASK) or a graph (CONSTRUCT, DESCRIBE)."""

    def __init__(self, result: Result, namespaces: rdflib.namespace.NamespaceManager) -> None:
        self._result = result
        self._namespaces = namespaces
        self.form: str = result.type
        self.variables: list[str] = [str(v) for v in result.vars or []] if self.form == "SELECT" else []
        self.rows: list[tuple[rdflib.term.Node | None, ...]] = list(result) if self.form == "SELECT" else []
        self.answer: bool | None = bool(result.askAnswer) if self.form == "ASK" else None
        self.graph: rdflib.Graph | None = result.graph if self.form in ("CONSTRUCT", "DESCRIBE") else None

    def render(self, fmt: QueryFormat = "table") -> str:
        if fmt not in FORMATS:
            raise HriplanError(f"unknown result format {fmt!r}; choose one of {', '.join(FORMATS)}")
        if self.graph is not None:
            return self._render_graph(fmt)
        if fmt == "turtle":
            raise HriplanError(f"turtle is for CONSTRUCT and DESCRIBE results; a {self.form} result renders as table, json or csv")
        if fmt == "json":
            return self._result.serialize(format="json").decode()
        if self.answer is not None:
            return _csv([["boolean"], [str(self.answer).lower()]]) if fmt == "csv" else str(self.answer).lower()
        if fmt == "csv":
            return self._result.serialize(format="csv").decode()
        return _table(self.variables, [[self._short(t) for t in row] for row in self.rows])

    def _render_graph(self, fmt: QueryFormat) -> str:
        assert self.graph is not None
        for prefix, namespace in PREFIXES.items():
            self.graph.bind(prefix, namespace)
        if fmt == "turtle":
            return self.graph.serialize(format="turtle")
        if fmt == "json":
            return self.graph.serialize(format="json-ld")
        triples = sorted([self._short(t) for t in triple] for triple in self.graph)
        return _csv([["subject", "predicate", "object"], *triples]) if fmt == "csv" else _table(["subject", "predicate", "object"], triples)

    def _short(self, term: rdflib.term.Node | None) -> str:
        if term is None:
            return ""
        if isinstance(term, rdflib.URIRef):
            return self._namespaces.normalizeUri(term)
        return str(term)


def run_query(graph: rdflib.Graph, text: str) -> QueryResult:
    """Run one query; a malformed query is a one-line error with its line and column."""
    try:
        query = prepareQuery(text, initNs=PREFIXES)
    except pyparsing.ParseBaseException as exc:
        raise HriplanError(f"SPARQL syntax error at line {exc.lineno}, column {exc.col}: {exc.msg}") from None
    except Exception as exc:  # noqa: BLE001 - rdflib reports e.g. unknown prefixes with a bare Exception
        raise HriplanError(f"invalid SPARQL query: {exc}") from None
    try:
        result = graph.query(query)
    except Exception as exc:  # noqa: BLE001 - evaluation errors come from deep inside rdflib
        raise HriplanError(f"SPARQL query failed: {exc}") from None
    return QueryResult(result, graph.namespace_manager)


def example_queries() -> dict[str, str]:
    """The shipped example queries (`queries/*.rq`), by file stem."""
    return {path.stem: path.read_text(encoding="utf-8") for path in sorted(QUERIES_DIR.glob("*.rq"))}


def _table(header: list[str], rows: list[list[str]]) -> str:
    widths = [max([len(h), *(len(r[i]) for r in rows)]) for i, h in enumerate(header)]
    lines = ["  ".join(c.ljust(w) for c, w in zip(line, widths)).rstrip() for line in [header, *rows]]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def _csv(rows: list[list[str]]) -> str:
    out = io.StringIO()
    csv.writer(out).writerows(rows)
    return out.getvalue()
