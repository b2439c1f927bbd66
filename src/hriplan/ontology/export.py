"""The ontology as a file for OWL tools: Turtle, RDF/XML (owlready2, Protégé, the OWL API) or OWL/XML.

The file is `hriplan.ttl`, optionally with the robot individuals generated from the robot
descriptions, and optionally with an alignment to another ontology (`alignment/NAME.ttl`). With
an alignment the file is one ontology, the alignment's (its IRI, version and imports of the
other ontology), with hriplan's axioms in it instead of an import of them.

rdflib writes Turtle and RDF/XML. OWL/XML comes from py-horned-owl (Rust's horned-owl): it reads
the RDF/XML and writes OWL/XML. Its RDF reader (py-horned-owl 2.0) drops every
`owl:AllDisjointClasses` axiom, so those are read from the graph and added back.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal, get_args

import rdflib
from rdflib.namespace import OWL, RDF

from hriplan import HriplanError
from hriplan.ontology.vocabulary import ONTOLOGY_IRI, PREFIXES, ontology_source

ExportFormat = Literal["ttl", "rdfxml", "owx"]
EXPORT_FORMATS: tuple[str, ...] = get_args(ExportFormat)
ALIGNMENT_DIR = Path(__file__).with_name("alignment")
ALIGNMENT_PREFIXES = {
    "dul": "http://www.ontologydesignpatterns.org/ont/dul/DUL.owl#",
    "soma": "http://www.ease-crc.org/ont/SOMA.owl#",
}


def alignments() -> list[str]:
    """The names of the shipped alignments (`alignment/*.ttl`)."""
    return sorted(path.stem for path in ALIGNMENT_DIR.glob("*.ttl"))


def ontology_graph(*, with_robots: bool = False, alignment: str | None = None) -> rdflib.Graph:
    """hriplan's ontology (with the robot individuals, with an alignment) as one ontology's graph."""
    source = ontology_source()
    graph = rdflib.Graph()
    graph.parse(source.path, format="turtle")
    if with_robots:
        graph.parse(data=source.robots, format="turtle")
    if alignment is not None:
        _align(graph, alignment)
    for prefix, namespace in {**PREFIXES, **ALIGNMENT_PREFIXES}.items():
        graph.bind(prefix, namespace)
    return graph


def export_ontology(fmt: str, *, with_robots: bool = False, alignment: str | None = None) -> str:
    """The ontology's text in `fmt` (ttl, rdfxml or owx)."""
    if fmt not in EXPORT_FORMATS:
        raise HriplanError(f"unknown ontology format {fmt!r}; choose one of {', '.join(EXPORT_FORMATS)}")
    graph = ontology_graph(with_robots=with_robots, alignment=alignment)
    if fmt == "ttl":
        return graph.serialize(format="turtle")
    rdfxml = graph.serialize(format="xml")
    return rdfxml if fmt == "rdfxml" else _owx(graph, rdfxml)


def _align(graph: rdflib.Graph, name: str) -> None:
    """Merge alignment `name` into hriplan's graph; its ontology header replaces hriplan's."""
    if name not in alignments():
        raise HriplanError(f"unknown alignment {name!r}; choose one of {', '.join(alignments())}")
    hriplan = rdflib.URIRef(ONTOLOGY_IRI)
    graph.remove((hriplan, None, None))
    graph.parse(ALIGNMENT_DIR / f"{name}.ttl", format="turtle")
    graph.remove((None, OWL.imports, hriplan))  # its axioms are in this file


def _owx(graph: rdflib.Graph, rdfxml: str) -> str:
    import pyhornedowl
    from pyhornedowl.model import DisjointClasses

    ontology = pyhornedowl.open_ontology(rdfxml, "owl")
    for node in graph.subjects(RDF.type, OWL.AllDisjointClasses):
        members = rdflib.collection.Collection(graph, graph.value(node, OWL.members))
        ontology.add_axiom(DisjointClasses([ontology.class_(str(member)) for member in members]))
    return ontology.save_to_string("owx")  # full IRIs: with prefixes, py-horned-owl 2.0 writes IRI="hp:Cup"
