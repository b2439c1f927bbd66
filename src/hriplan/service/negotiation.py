"""SPARQL Protocol content negotiation: which syntax answers which Accept header.

A SELECT or ASK result is served as SPARQL results JSON, XML, CSV or TSV; a CONSTRUCT or
DESCRIBE graph as Turtle, JSON-LD, N-Triples or RDF/XML (what SPARQLWrapper's and rdflib
SPARQLStore's defaults ask for). `format=` (what SPARQLWrapper and browsers
send) overrides the header.
"""

from __future__ import annotations

from hriplan import HriplanError

RESULT_TYPES: dict[str, tuple[str, ...]] = {
    "json": ("application/sparql-results+json", "application/json"),
    "xml": ("application/sparql-results+xml", "application/xml", "text/xml"),
    "csv": ("text/csv",),
    "tsv": ("text/tab-separated-values",),
}
GRAPH_TYPES: dict[str, tuple[str, ...]] = {
    "turtle": ("text/turtle", "application/x-turtle", "application/turtle"),
    "json-ld": ("application/ld+json", "application/json", "application/x-json+ld"),
    "nt": ("application/n-triples", "text/plain"),
    "xml": ("application/rdf+xml",),
}
FORMAT_NAMES = {
    "json": ("json", "json-ld"),
    "xml": ("xml", "xml"),
    "rdf+xml": (None, "xml"),
    "rdfxml": (None, "xml"),
    "csv": ("csv", None),
    "tsv": ("tsv", None),
    "turtle": (None, "turtle"),
    "json-ld": (None, "json-ld"),
    "jsonld": (None, "json-ld"),
    "nt": (None, "nt"),
    "ntriples": (None, "nt"),
    "n-triples": (None, "nt"),
}


class NotAcceptable(HriplanError):
    """No syntax the client accepts can carry this result (HTTP 406)."""


def _accepted(header: str) -> list[tuple[str, float]]:
    """Media ranges of an Accept header, best first (by q, then as written)."""
    ranges = []
    for index, part in enumerate(p for p in header.split(",") if p.strip()):
        media, *params = (x.strip() for x in part.split(";"))
        q = 1.0
        for param in params:
            name, _, value = param.partition("=")
            if name.strip() == "q":
                try:
                    q = float(value)
                except ValueError:
                    q = 0.0
        ranges.append((media.lower(), q, index))
    return [(m, q) for m, q, _ in sorted(ranges, key=lambda r: (-r[1], r[2])) if q > 0]


def choose(graph_result: bool, accept: str | None, fmt: str | None = None) -> tuple[str, str]:
    """The (syntax, media type) to answer with; raises NotAcceptable naming what is offered."""
    table = GRAPH_TYPES if graph_result else RESULT_TYPES
    if fmt:
        syntax = FORMAT_NAMES.get(fmt.lower(), (None, None))[1 if graph_result else 0]
        if syntax is None:
            raise NotAcceptable(f"format={fmt} cannot carry this result; use one of {', '.join(table)}")
        return syntax, table[syntax][0]
    for media, _ in _accepted(accept or "*/*"):
        for syntax, types in table.items():
            if media in types or media == "*/*" or (media.endswith("/*") and types[0].startswith(media[:-1])):
                return syntax, types[0] if media in ("*/*",) or media.endswith("/*") else media
    offered = ", ".join(t for types in table.values() for t in types[:1])
    raise NotAcceptable(f"none of the accepted types ({accept}) can carry this result; offered: {offered}")
