"""The SOMA/DUL alignment: hriplan (with the robot individuals), the alignment and SOMA
(tests/data/soma, SOMA-HOME's import closure) together are consistent under HermiT, and every
SOMA or DUL term the alignment names exists in SOMA (a misspelt IRI would be a new, empty class).

That every hriplan class is satisfiable with SOMA is checked by one individual in each class that
has no subclass (then every class has an instance): HermiT needs 35 to 90 s for it on 2 shared
cores, against 10 to 25 s for the consistency alone, so it runs only with HRIPLAN_SLOW_CHECKS=1.
"""

import os
from pathlib import Path

import owlready2
import pyhornedowl
import pytest
import rdflib
from rdflib.namespace import OWL, RDF, RDFS

from hriplan.ontology.export import export_ontology
from independent import hermit_says_consistent

SOMA_DIR = Path(__file__).parents[1] / "data" / "soma"
HP = "https://hriplan.org/ontology#"
UPPER = ("http://www.ontologydesignpatterns.org/ont/dul/DUL.owl#", "http://www.ease-crc.org/ont/SOMA.owl#")


@pytest.fixture(scope="module")
def soma() -> rdflib.Graph:
    """SOMA-HOME's import closure, read from its functional syntax by horned-owl, as one graph."""
    graph = rdflib.Graph()
    for path in sorted(SOMA_DIR.glob("*.owl")):
        graph.parse(data=pyhornedowl.open_ontology(path.read_text(), "ofn").save_to_string("owl"), format="xml")
    return graph


def merged(soma: rdflib.Graph, exported: str, probes: bool = False) -> rdflib.Graph:
    """hriplan's export and SOMA in one ontology (no imports to fetch); with `probes`, a new
    individual in each hriplan class that has no hriplan subclass."""
    graph = rdflib.Graph()
    graph += soma
    graph.parse(data=exported, format="turtle")
    graph.remove((None, OWL.imports, None))
    for ontology in set(graph.subjects(RDF.type, OWL.Ontology)):
        graph.remove((ontology, None, None))
    graph.add((rdflib.URIRef("urn:hriplan-test:merged"), RDF.type, OWL.Ontology))
    own = {c for c in graph.subjects(RDF.type, OWL.Class) if str(c).startswith(HP)}
    leaves = {c for c in own if not any(s in own for s in graph.subjects(RDFS.subClassOf, c))}
    for cls in leaves if probes else ():
        probe = rdflib.URIRef(f"urn:hriplan-test:probe-{cls.split('#')[1]}")
        graph.add((probe, RDF.type, OWL.NamedIndividual))
        graph.add((probe, RDF.type, cls))
    return graph


def test_every_upper_term_of_the_alignment_is_declared_in_soma(soma):
    alignment = rdflib.Graph().parse(data=export_ontology("ttl", alignment="soma"), format="turtle")
    named = {t for triple in alignment for t in triple if isinstance(t, rdflib.URIRef) and str(t).startswith(UPPER)}
    declared = {s for s, _, o in soma.triples((None, RDF.type, None)) if o in (OWL.Class, OWL.ObjectProperty)}
    assert len(named) >= 35
    assert named - declared == set()


def test_hriplan_with_the_alignment_and_soma_is_consistent_under_hermit(soma, tmp_path):
    exported = export_ontology("ttl", with_robots=True, alignment="soma")
    graph = merged(soma, exported)
    assert (rdflib.URIRef(HP + "Pick"), rdflib.RDFS.subClassOf, None) in graph
    graph.serialize(tmp_path / "aligned.owl", format="xml")
    world = owlready2.World()  # owlready2 loads it (its HermiT run would classify SOMA: minutes)
    world.get_ontology((tmp_path / "aligned.owl").as_uri()).load()
    pick, picking_up = world[HP + "Pick"], world["http://www.ease-crc.org/ont/SOMA.owl#PickingUp"]
    assert any(getattr(c, "value", None) is picking_up for c in pick.is_a)
    assert world[HP + "Cup"] in world["http://www.ease-crc.org/ont/SOMA.owl#Crockery"].descendants()
    assert hermit_says_consistent(tmp_path / "aligned.owl")


@pytest.mark.skipif(os.environ.get("HRIPLAN_SLOW_CHECKS") != "1", reason="35-90 s of HermiT; HRIPLAN_SLOW_CHECKS=1")
def test_every_hriplan_class_is_satisfiable_with_soma(soma, tmp_path):
    graph = merged(soma, export_ontology("ttl", alignment="soma"), probes=True)
    assert len(set(graph.subjects(RDF.type, OWL.NamedIndividual))) > 50
    graph.serialize(tmp_path / "probed.owl", format="xml")
    assert hermit_says_consistent(tmp_path / "probed.owl")
