"""The ontology as a published vocabulary: its IRIs and metadata, and a QUDT unit on every
property whose values are physical quantities."""

import re
import subprocess
import sys
from pathlib import Path

import rdflib
from rdflib.namespace import OWL, RDF, RDFS

import hriplan
from hriplan.ontology.sparql import example_queries, run_query

TTL = Path(hriplan.__file__).parent / "ontology" / "hriplan.ttl"
HP = rdflib.Namespace("https://hriplan.org/ontology#")
DCTERMS = rdflib.Namespace("http://purl.org/dc/terms/")
QUDT_UNIT = rdflib.URIRef("http://qudt.org/schema/qudt/unit")
UNIT = "http://qudt.org/vocab/unit/"
NUMERIC = {rdflib.XSD.decimal, rdflib.XSD.integer, rdflib.XSD.double, rdflib.XSD.float}
# Numbers without a unit: a factor, a fraction of an object's length, a count, an order.
DIMENSIONLESS = {"hasVelocityScale", "hasTransientFactor", "hasGraspOffset", "hasChainIndex", "hasPreference"}
# How the comments write units, read here apart from the annotations they must agree with.
COMMENT_UNITS = {"m": "M", "rad": "RAD", "rad/m": "RAD-PER-M", "s": "SEC", "kg": "KiloGM", "N": "N"}
COMMENT_UNITS |= {"N/m": "N-PER-M", "m/s": "M-PER-SEC"}


def graph() -> rdflib.Graph:
    return rdflib.Graph().parse(TTL, format="turtle")


def test_metadata_names_the_version_licence_and_creator():
    g = graph()
    ontology = rdflib.URIRef("https://hriplan.org/ontology")
    assert (ontology, RDF.type, OWL.Ontology) in g
    version = hriplan.__version__
    assert re.search(r'^version = "(.+)"$', (TTL.parents[3] / "pyproject.toml").read_text(), re.M)[1] == version
    assert g.value(ontology, OWL.versionIRI) == rdflib.URIRef(f"https://hriplan.org/ontology/{version}")
    assert str(g.value(ontology, OWL.versionInfo)) == version
    assert g.value(ontology, DCTERMS.license) == rdflib.URIRef("https://spdx.org/licenses/BSD-3-Clause")
    assert "BSD 3-Clause" in (TTL.parents[3] / "LICENSE").read_text()
    assert all(g.value(ontology, DCTERMS[p]) for p in ("title", "description", "creator"))
    # Every term stays in the namespace the ontology IRI names, as before.
    terms = {s for s in g.subjects(RDF.type, None) if isinstance(s, rdflib.URIRef) and s != ontology}
    own = {t for t in terms if str(t).startswith(str(HP))}
    assert len(own) > 150 and all(str(t).startswith(("http://purl.org/", "http://qudt.org/")) for t in terms - own)


def test_version_iri_answers_the_query_command():
    out = subprocess.run(
        [sys.executable, "-m", "hriplan.cli", "query", "SELECT ?v WHERE { ?o owl:versionIRI ?v }", "--format", "csv"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["v", f"https://hriplan.org/ontology/{hriplan.__version__}"]


def test_every_physical_quantity_has_its_unit_and_the_comment_agrees():
    g = graph()
    numeric = {p for p in g.subjects(RDF.type, OWL.DatatypeProperty) if g.value(p, RDFS.range) in NUMERIC}
    names = {str(p).split("#")[1] for p in numeric}
    assert DIMENSIONLESS <= names and len(names) > 30
    for prop in numeric:
        name, units = str(prop).split("#")[1], list(g.objects(prop, QUDT_UNIT))
        if name in DIMENSIONLESS:
            assert units == [], name
            continue
        assert len(units) == 1 and str(units[0]).startswith(UNIT), name
        written = re.findall(r"\(([A-Za-z/]+)[);]", str(g.value(prop, RDFS.comment)))  # the last "(m)"
        assert written and UNIT + COMMENT_UNITS.get(written[-1], "?") == str(units[0]), name
    non_numeric = set(g.subjects(RDF.type, OWL.DatatypeProperty)) - numeric
    assert {p for p in non_numeric if (p, QUDT_UNIT, None) in g} == set()


def test_the_units_query_lists_them():
    answer = run_query(graph(), example_queries()["units"])
    units = {str(row[0]).split("#")[1]: str(row[1]).removeprefix(UNIT) for row in answer.rows}
    assert units["hasApproachSpeed"] == "M-PER-SEC" and units["hasToleranceGradient"] == "RAD-PER-M"
    assert units["hasMovingMass"] == "KiloGM" and units["hasSpringConstant"] == "N-PER-M"
    assert len(units) == 29 and DIMENSIONLESS.isdisjoint(units)


def test_an_ontology_file_is_hashed_again_only_when_it_changed(tmp_path, monkeypatch):
    """The digest (which keys the reasoning cache) is the hash of the file and the robots'
    Turtle, kept while the file's identity is the same: unchanged, the file is not read again;
    rewritten with other text of the same length (a later modification time), it is hashed anew."""
    import hashlib
    import os

    from hriplan.ontology.robot_individuals import robot_turtle
    from hriplan.ontology.vocabulary import ontology_source

    path = tmp_path / "hriplan.ttl"
    path.write_text(TTL.read_text())
    first = ontology_source(path).digest
    assert first == hashlib.sha256(path.read_bytes() + b"\0" + robot_turtle().encode()).hexdigest()
    with monkeypatch.context() as patched:
        patched.setattr(Path, "read_bytes", lambda self: (_ for _ in ()).throw(AssertionError("read again")))
        assert ontology_source(path).digest == first
    stat = path.stat()
    text = path.read_text()
    path.write_text(text.replace("hriplan", "HRIPLAN", 1))  # the same length
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns + 1_000_000))
    again = ontology_source(path).digest
    assert again != first
    assert again == hashlib.sha256(path.read_bytes() + b"\0" + robot_turtle().encode()).hexdigest()
