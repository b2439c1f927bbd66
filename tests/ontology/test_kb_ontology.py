"""The ontology file itself: valid Turtle, documented terms, the classes and parameters the rules use."""

from dataclasses import replace

import pytest
import rdflib
from rdflib.namespace import OWL, RDF, RDFS

from hriplan.ontology.ruleset import load_rules
from hriplan.ontology.vocabulary import NAMESPACE, ONTOLOGY_IRI, ontology_source
from hriplan.robots.descriptions.registry import DESCRIPTIONS
from hriplan.robots.model import load_robot

HP = rdflib.Namespace(NAMESPACE)


@pytest.fixture(scope="module")
def graph() -> rdflib.Graph:
    return ontology_source().graph  # the file and the robot individuals generated with it


def _terms(graph: rdflib.Graph, kind: rdflib.URIRef) -> set[rdflib.URIRef]:
    return {s for s in graph.subjects(RDF.type, kind) if isinstance(s, rdflib.URIRef) and s.startswith(NAMESPACE)}


def test_ontology_header_has_a_stable_iri_and_version(graph):
    ontology = rdflib.URIRef(ONTOLOGY_IRI)
    assert (ontology, RDF.type, OWL.Ontology) in graph
    assert graph.value(ontology, OWL.versionInfo) is not None


@pytest.mark.parametrize("kind", [OWL.Class, OWL.ObjectProperty, OWL.DatatypeProperty, RDFS.Datatype])
def test_every_class_and_property_has_a_label_and_a_comment(graph, kind):
    terms = _terms(graph, kind)
    assert terms
    undocumented = sorted(
        str(t) for t in terms if graph.value(t, RDFS.label) is None or graph.value(t, RDFS.comment) is None
    )
    assert undocumented == []


def test_the_issue_vocabulary_is_present(graph):
    classes = {t.removeprefix(NAMESPACE) for t in _terms(graph, OWL.Class)}
    required = {
        "RobotToHumanHandover",
        "HumanToRobotHandover",
        "Pick",
        "Place",
        "Transport",
        "Insertion",
        "Pouring",
        "Inspection",
        "Can",
        "Cup",
        "Glass",
        "Bottle",
        "Bowl",
        "Tool",
        "SharpTool",
        "FragileObject",
        "HotObject",
        "Peg",
        "Hole",
        "Table",
        "Human",
        "Receiver",
        "Giver",
        "Supervisor",
        "Collaborator",
        "Bystander",
        "Head",
        "Torso",
        "HumanHand",
        "Robot",
        "Arm",
        "RobotHand",
        "Link",
        "SharedWorkspace",
        "HumanSafetyZone",
        "UprightKind",
        "AlignmentKind",
        "ApproachConeKind",
        "WorkspaceBoxKind",
        "KeepOutCylinderKind",
        "KeepOutSphereKind",
    }
    assert required - classes == set()


def test_full_open_container_is_derived_from_the_same_conditions_in_ontology_and_rule(graph):
    (condition,) = [c for c in graph.objects(HP.FullOpenContainer, RDFS.subClassOf) if isinstance(c, rdflib.BNode)]
    members = list(rdflib.collection.Collection(graph, graph.value(condition, OWL.intersectionOf)))
    restricted = {(graph.value(m, OWL.onProperty), graph.value(m, OWL.hasValue)) for m in members[1:]}
    assert members[0] == HP.Container
    assert restricted == {(HP.hasFillLevel, rdflib.Literal("Full")), (HP.isOpen, rdflib.Literal(True))}
    (definition,) = [r for r in load_rules() if r.name == "define_full_open_container"]
    assert definition.swrl() == 'Container(?o), hasFillLevel(?o, "Full"), isOpen(?o, true) -> FullOpenContainer(?o)'


def test_every_derived_class_has_a_definition_rule(graph):
    derived = {
        s.removeprefix(NAMESPACE)
        for s in _terms(graph, OWL.Class)
        if str(graph.value(s, RDFS.comment)).startswith("Derived (rule ")
    }
    defined = {r.head[0].predicate for r in load_rules() if r.name.startswith("define_")}
    assert len(derived) == 11 and derived == defined


def test_fill_levels_are_distinct_values_of_a_functional_property(graph):
    assert (HP.hasFillLevel, RDF.type, OWL.FunctionalProperty) in graph
    levels = rdflib.collection.Collection(graph, graph.value(graph.value(HP.FillLevel, OWL.equivalentClass), OWL.oneOf))
    assert [str(v) for v in levels] == ["Full", "Partial", "Empty"]


def test_containers_and_tools_are_disjoint(graph):
    groups = [
        list(rdflib.collection.Collection(graph, graph.value(g, OWL.members)))
        for g in graph.subjects(RDF.type, OWL.AllDisjointClasses)
    ]
    assert any(HP.Container in g and HP.Tool in g for g in groups)


@pytest.mark.parametrize(
    ("kind", "prop", "value"),
    [
        ("UprightFull", "hasTolerance", 0.05),
        ("UprightPartial", "hasTolerance", 0.1),
        ("InsertionAlignment", "hasTolerance", 0.02),
        ("InsertionAlignment", "hasToleranceGradient", 0.3),
        ("KeepOutSupervisor", "hasSeparationDistance", 0.5),
        ("KeepOutBystander", "hasSeparationDistance", 0.8),
        ("ReducedVelocityFragile", "hasVelocityScale", 0.5),
        ("ReducedVelocityHot", "hasVelocityScale", 0.5),
        ("ApproachCone", "hasRadius", 0.3),
        ("ApproachCone", "hasHeight", 0.55),
    ],
)
def test_constraint_parameters_are_data_in_the_ontology(graph, kind, prop, value):
    literal = graph.value(HP[kind], HP[prop])
    assert literal is not None and literal.datatype == rdflib.namespace.XSD.decimal
    assert float(literal) == pytest.approx(value)


def test_the_robot_individuals_are_the_robot_descriptions(graph):
    # Generated from robots/descriptions: each arm's joints (chain order), tool link and hand.
    for name, description in DESCRIPTIONS.items():
        robot = HP[name]
        assert (robot, RDF.type, HP.Robot) in graph and str(graph.value(robot, HP.hasUrdfName)) == name
        arms = {str(graph.value(a, HP.hasArmName)): a for a in graph.objects(robot, HP.hasArm)}
        assert arms.keys() == description.arms.keys()
        model = load_robot(name)
        for arm, individual in arms.items():
            joints = sorted(graph.objects(individual, HP.hasJoint), key=lambda j: int(graph.value(j, HP.hasChainIndex)))
            assert [str(graph.value(j, HP.hasUrdfName)) for j in joints] == model.group_joints(model.arm_group(arm))
            assert str(graph.value(graph.value(individual, HP.hasToolLink), HP.hasUrdfName)) == model.tool_frame(arm)
            assert (graph.value(individual, HP.hasRobotHand) is not None) == (arm in description.hands)
    assert str(graph.value(HP.madar, RDFS.comment)) == "Dual-arm mobile robot: two UR5 arms with Allegro hands."


def test_a_changed_robot_description_is_a_new_ontology_version(monkeypatch):
    # The reasoning cache is keyed by the digest: a description that changes the facts changes it.
    before = ontology_source()
    ur5 = DESCRIPTIONS["ur5"]
    arm = replace(ur5.arms["arm"], object_axis="+z")
    monkeypatch.setitem(DESCRIPTIONS, "ur5", replace(ur5, arms={"arm": arm}))
    after = ontology_source()
    assert after.digest != before.digest
    assert (HP.ur5_arm, HP.hasObjectAxisInTool, rdflib.Literal("+z")) in after.graph
    assert (HP.ur5_arm, HP.hasObjectAxisInTool, rdflib.Literal("-z")) in before.graph
