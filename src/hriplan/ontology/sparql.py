"""SPARQL 1.1 queries (SELECT, ASK, CONSTRUCT, DESCRIBE) on a reasoned graph, with rdflib.

The ontology's prefixes (hp:, sit:, rule:, rdf:, rdfs:, owl:, xsd:, swrl:, swrlb:, and dcterms:,
qudt:, unit: for its metadata and units) are predefined. Results render as an aligned table, SPARQL results JSON or CSV; graph results
(CONSTRUCT, DESCRIBE) as Turtle, JSON-LD, or a subject/predicate/object table or CSV.

Read-only and closed, for the command line and the HTTP endpoint alike: updates are refused,
and so are SERVICE and FROM / FROM NAMED (rdflib would fetch those URLs or read those files);
a query stops at a time limit, a row limit and a byte limit on its answer (`QueryLimits`).
The time limit is checked at every triple lookup; work that looks nothing up (a regex, a
VALUES join, string functions) is stopped by whoever runs the query: the HTTP service runs it
in a worker process that it kills at the limit, with its memory capped.
"""

from __future__ import annotations

import csv
import io
import time
from collections.abc import Iterator
from itertools import islice
from pathlib import Path
from typing import Literal

import pyparsing
import rdflib
from pydantic import BaseModel, Field
from rdflib.plugins.sparql import prepareQuery
from rdflib.plugins.sparql.parser import parseUpdate
from rdflib.plugins.sparql.parserutils import CompValue
from rdflib.plugins.sparql.sparql import Query
from rdflib.query import Result

from hriplan import HriplanError
from hriplan.ontology.vocabulary import PREFIXES

QueryFormat = Literal["table", "json", "csv", "turtle"]
FORMATS: tuple[str, ...] = ("table", "json", "csv", "turtle")
RESULT_SYNTAXES: tuple[str, ...] = ("json", "xml", "csv", "tsv")
GRAPH_SYNTAXES: tuple[str, ...] = ("turtle", "json-ld", "nt", "xml")
UPDATES_REFUSED = "updates are not supported: the knowledge base is read-only"
QUERIES_DIR = Path(__file__).with_name("queries")


class QueryLimits(BaseModel):
    """How long a query may run, how many rows (or triples) and bytes it may answer: the row
    limit alone lets a few rows of string functions grow to gigabytes."""

    time_limit: float = Field(default=10.0, gt=0.0, le=3600.0)
    row_limit: int = Field(default=10_000, gt=0)
    byte_limit: int = Field(default=16 << 20, gt=0)


class QueryTimeout(HriplanError):
    """The query ran past its time limit (the HTTP endpoint answers 504 to it)."""


class UpdateRefused(HriplanError):
    """A SPARQL update (the HTTP endpoint answers 403 to it)."""


def time_limit_message(time_limit: float) -> str:
    return f"the query ran past its time limit of {time_limit:g} s; narrow it or add a LIMIT"


class QueryResult:
    """One query's answer: rows (SELECT), a boolean (ASK) or a graph (CONSTRUCT, DESCRIBE)."""

    def __init__(
        self, result: Result, namespaces: rdflib.namespace.NamespaceManager, limits: QueryLimits | None = None
    ) -> None:
        limits = limits or QueryLimits()
        row_limit, self._byte_limit = limits.row_limit, limits.byte_limit
        self._result = result
        self._namespaces = namespaces
        self.form: str = result.type
        self.variables: list[str] = [str(v) for v in result.vars or []] if self.form == "SELECT" else []
        self.rows: list[tuple[rdflib.term.Node | None, ...]] = (
            list(islice(result, row_limit + 1)) if self.form == "SELECT" else []
        )
        self.answer: bool | None = bool(result.askAnswer) if self.form == "ASK" else None
        self.graph: rdflib.Graph | None = result.graph if self.form in ("CONSTRUCT", "DESCRIBE") else None
        size = len(self.rows) if self.graph is None else len(self.graph)
        if size > row_limit:
            unit = "rows" if self.graph is None else "triples"
            raise HriplanError(
                f"the query answers more than {row_limit} {unit} (the row limit); add a LIMIT or narrow it"
            )
        terms = (t for row in (self.rows if self.graph is None else self.graph) for t in row if t is not None)
        self._check_bytes(sum(len(t) for t in terms))
        if self.form == "SELECT":
            self._result.bindings = [dict(zip(result.vars, row)) for row in self.rows]  # serialize the rows kept

    def render(self, fmt: QueryFormat = "table") -> str:
        if fmt not in FORMATS:
            raise HriplanError(f"unknown result format {fmt!r}; choose one of {', '.join(FORMATS)}")
        if self.graph is not None:
            return self._render_graph(fmt)
        if fmt == "turtle":
            raise HriplanError(
                f"turtle is for CONSTRUCT and DESCRIBE results; a {self.form} result renders as table, json or csv"
            )
        if fmt == "json":
            return self._result.serialize(format="json").decode()
        if self.answer is not None:
            return _csv([["boolean"], [str(self.answer).lower()]]) if fmt == "csv" else str(self.answer).lower()
        if fmt == "csv":
            return self._result.serialize(format="csv").decode()
        return _table(self.variables, [[self._short(t) for t in row] for row in self.rows])

    def serialize(self, syntax: str) -> str:
        """The answer in a SPARQL Protocol syntax: json, xml, csv, tsv (SELECT, ASK) or
        turtle, json-ld, nt, xml (RDF/XML; CONSTRUCT, DESCRIBE), within the byte limit."""
        allowed = GRAPH_SYNTAXES if self.graph is not None else RESULT_SYNTAXES
        if syntax not in allowed:
            raise HriplanError(f"a {self.form} result is served as {', '.join(allowed)}, not {syntax}")
        text = self._syntax(syntax)
        self._check_bytes(len(text.encode()))
        return text

    def _syntax(self, syntax: str) -> str:
        if self.graph is not None:
            for prefix, namespace in PREFIXES.items():
                self.graph.bind(prefix, namespace)
            return self.graph.serialize(format=syntax)
        if syntax in ("json", "xml"):
            out = self._result.serialize(format=syntax)
            return out.decode() if isinstance(out, bytes) else out
        if syntax == "csv":
            return self.render("csv")
        header = ["?" + v for v in self.variables] if self.answer is None else ["?boolean"]
        rows = (
            [[t.n3() if t is not None else "" for t in row] for row in self.rows]
            if self.answer is None
            else [[str(self.answer).lower()]]
        )
        return "\n".join("\t".join(line) for line in [header, *rows]) + "\n"

    def _check_bytes(self, size: int) -> None:
        if size > self._byte_limit:
            raise HriplanError(
                f"the query answers more than {self._byte_limit} bytes (the byte limit); narrow it or add a LIMIT"
            )

    def _render_graph(self, fmt: QueryFormat) -> str:
        assert self.graph is not None
        for prefix, namespace in PREFIXES.items():
            self.graph.bind(prefix, namespace)
        if fmt == "turtle":
            return self.graph.serialize(format="turtle")
        if fmt == "json":
            return self.graph.serialize(format="json-ld")
        triples = sorted([self._short(t) for t in triple] for triple in self.graph)
        return (
            _csv([["subject", "predicate", "object"], *triples])
            if fmt == "csv"
            else _table(["subject", "predicate", "object"], triples)
        )

    def _short(self, term: rdflib.term.Node | None) -> str:
        if term is None:
            return ""
        if isinstance(term, rdflib.URIRef):
            return self._namespaces.normalizeUri(term)
        return str(term)


def run_query(graph: rdflib.Graph, text: str, limits: QueryLimits | None = None) -> QueryResult:
    """Run one read-only query within `limits`; any refusal or failure is a one-line error."""
    limits = limits or QueryLimits()
    query = prepare_query(text)
    guarded = _DeadlineGraph(graph, time.monotonic() + limits.time_limit, limits.time_limit)
    try:
        return QueryResult(guarded.query(query), graph.namespace_manager, limits)
    except (HriplanError, MemoryError):
        raise
    except Exception as exc:
        raise HriplanError(f"SPARQL query failed: {exc}") from None


def prepare_query(text: str) -> Query:
    """Parse a query and refuse what would write or reach outside the graph; errors give a position."""
    if not text.strip():
        raise HriplanError("empty SPARQL query: give a SELECT, ASK, CONSTRUCT or DESCRIBE query")
    try:
        query = prepareQuery(text, initNs=PREFIXES)
    except pyparsing.ParseBaseException as exc:
        if _is_update(text):
            raise UpdateRefused(UPDATES_REFUSED) from None
        raise HriplanError(f"SPARQL syntax error at line {exc.lineno}, column {exc.col}: {exc.msg}") from None
    except Exception as exc:
        raise HriplanError(f"invalid SPARQL query: {exc}") from None
    if query.algebra.get("datasetClause"):
        raise HriplanError("FROM and FROM NAMED are not supported: the dataset is fixed and nothing is fetched")
    if _contains(query.algebra, "ServiceGraphPattern"):
        raise HriplanError("SERVICE is not supported: hriplan never sends requests to other endpoints")
    return query


def _is_update(text: str) -> bool:
    try:
        parseUpdate(text)
    except Exception:
        return False
    return True


def _contains(node: object, name: str) -> bool:
    """Whether the query algebra has a node called `name` anywhere."""
    if isinstance(node, CompValue):
        return node.name == name or any(_contains(v, name) for v in node.values())
    if isinstance(node, (list, tuple)):
        return any(_contains(v, name) for v in node)
    return False


class _DeadlineGraph(rdflib.Graph):
    """The same triples, but every pattern lookup checks a deadline: rdflib evaluates joins,
    filters and paths by looking triples up, so a runaway query stops within a few lookups."""

    def __init__(self, graph: rdflib.Graph, deadline: float, time_limit: float) -> None:
        super().__init__(store=graph.store, identifier=graph.identifier, namespace_manager=graph.namespace_manager)
        self._deadline, self._time_limit = deadline, time_limit

    def triples(self, triple, *args, **kwargs) -> Iterator:
        for count, found in enumerate(super().triples(triple, *args, **kwargs)):
            if count % 256 == 0:
                self._check()
            yield found
        self._check()

    def _check(self) -> None:
        if time.monotonic() > self._deadline:
            raise QueryTimeout(time_limit_message(self._time_limit))


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
