"""SPARQL over the reasoned graph: query forms, result formats, errors, shipped examples."""

import csv
import io
import json

import pytest
import rdflib

from hriplan import HriplanError
from hriplan.ontology.cache import ReasoningCache
from hriplan.ontology.knowledge_base import KnowledgeBase
from hriplan.ontology.situation import EXAMPLES_DIR, load_situation
from hriplan.ontology.sparql import example_queries

SELECT = "SELECT ?kind WHERE { sit:handover hp:requiresConstraint ?kind } ORDER BY ?kind"


@pytest.fixture(scope="module")
def kb(tmp_path_factory) -> KnowledgeBase:
    cache = ReasoningCache(tmp_path_factory.getbasetemp() / "kb-cache")
    return KnowledgeBase(load_situation(EXAMPLES_DIR / "handover_can.json"), cache=cache)


def test_select_sees_inferred_facts_with_predefined_prefixes(kb):
    result = kb.query(SELECT)
    assert result.form == "SELECT" and result.variables == ["kind"]
    kinds = [row[0].removeprefix("https://hriplan.org/ontology#") for row in result.rows]
    assert kinds == ["ApproachCone", "KeepOutSupervisor", "ReceiverExclusionBox", "SharedWorkspaceBox", "UprightFull"]


def test_select_renders_as_table_json_and_csv(kb):
    result = kb.query(SELECT)
    table = result.render("table").splitlines()
    assert table[0] == "kind" and set(table[1]) == {"-"} and table[2] == "hp:ApproachCone"
    bindings = json.loads(result.render("json"))["results"]["bindings"]
    assert bindings[0]["kind"] == {"type": "uri", "value": "https://hriplan.org/ontology#ApproachCone"}
    rows = list(csv.reader(io.StringIO(result.render("csv"))))
    assert rows[0] == ["kind"] and rows[-1] == ["https://hriplan.org/ontology#UprightFull"]


def test_ask_answers_true_and_false(kb):
    assert kb.query("ASK { sit:can1 a hp:FullOpenContainer }").answer is True
    result = kb.query("ASK { sit:can1 a hp:EmptyContainer }")
    assert result.answer is False and result.render() == "false"
    assert json.loads(result.render("json")) == {"head": {}, "boolean": False}
    assert result.render("csv").split() == ["boolean", "false"]


def test_construct_returns_a_graph_as_turtle_or_triples(kb):
    result = kb.query(
        "CONSTRUCT { ?o hp:mustStayUpright true } WHERE { ?o hp:isConstrainedBy ?k . ?k a hp:UprightKind }"
    )
    assert result.form == "CONSTRUCT" and len(result.graph) == 1
    graph = rdflib.Graph().parse(data=result.render("turtle"), format="turtle")
    assert (rdflib.URIRef("https://hriplan.org/situation#can1"), None, None) in graph
    assert result.render("table").splitlines()[2].split() == ["sit:can1", "hp:mustStayUpright", "true"]
    assert json.loads(result.render("json"))[0]["@id"] == "https://hriplan.org/situation#can1"


@pytest.mark.parametrize(
    ("query", "message"),
    [
        ("SELECT ?x WHERE { ?x hp:isNear ?y ", r"SPARQL syntax error at line 1, column \d+: Expected"),
        ("SELECT ?x\nWHERE { ?x hp:isNear ?y . FILTER( }", r"SPARQL syntax error at line 2, column \d+"),
        ("SELEC ?x WHERE { }", "SPARQL syntax error at line 1, column 1"),
        ("SELECT ?x WHERE { ?x foo:bar ?y }", "invalid SPARQL query: Unknown namespace prefix : foo"),
    ],
)
def test_malformed_queries_are_one_line_errors_with_a_position(kb, query, message):
    with pytest.raises(HriplanError, match=message) as info:
        kb.query(query)
    assert "\n" not in str(info.value)


def test_unsuitable_formats_are_refused(kb):
    with pytest.raises(HriplanError, match="turtle is for CONSTRUCT and DESCRIBE results"):
        kb.query(SELECT).render("turtle")
    with pytest.raises(HriplanError, match="unknown result format 'xml'"):
        kb.query(SELECT).render("xml")  # type: ignore[arg-type]


def test_every_example_query_runs_and_answers(kb):
    queries = example_queries()
    assert {"required_constraints", "objects_near_humans", "constraint_parameters", "upright_required"} <= set(queries)
    answers = {name: kb.query(text) for name, text in queries.items()}
    assert all(a.rows or a.answer or (a.graph is not None and len(a.graph)) for a in answers.values())
    near = {(str(r[0]).split("#")[1], str(r[1]).split("#")[1]) for r in answers["objects_near_humans"].rows}
    assert near == {("can1", "bob"), ("can1", "sue")}
    parameters = {(str(r[0]).split("#")[1], str(r[1])): r[2].toPython() for r in answers["constraint_parameters"].rows}
    assert float(parameters[("UprightFull", "hasTolerance")]) == 0.05
