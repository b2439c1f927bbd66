"""The knowledge base: reasoning with Pellet, Turtle export, the cache, inconsistencies, bad input.

Pellet is the reference, so these tests run with it (the in-process reasoner: test_kb_fast)."""

import owlready2
import pytest
import rdflib
from pydantic import ValidationError

from hriplan import HriplanError
from hriplan.ontology import pellet as reasoner
from hriplan.ontology.assertions import situation_assertions
from hriplan.ontology.cache import ReasoningCache, default_cache, default_cache_dir, reasoning_key
from hriplan.ontology.knowledge_base import KnowledgeBase
from hriplan.ontology.pellet import InconsistentSituation
from hriplan.ontology.reasoners import use_reasoner
from hriplan.ontology.ruleset import load_rules
from hriplan.ontology.situation import EXAMPLES_DIR, Situation, load_situation
from hriplan.ontology.vocabulary import NAMESPACE, SITUATION_NAMESPACE, ontology_source
from hriplan.robots.spatial import Pose

HP, SIT = rdflib.Namespace(NAMESPACE), rdflib.Namespace(SITUATION_NAMESPACE)


@pytest.fixture(scope="module", autouse=True)
def pellet():
    use_reasoner("pellet")
    yield
    use_reasoner("fast")


@pytest.fixture(scope="module")
def cache(tmp_path_factory) -> ReasoningCache:
    """One on-disk cache for the whole test session: each situation is reasoned about once."""
    return ReasoningCache(tmp_path_factory.getbasetemp() / "kb-cache")


@pytest.fixture(scope="module")
def handover() -> Situation:
    return load_situation(EXAMPLES_DIR / "handover_can.json")


@pytest.fixture(scope="module")
def kb(handover, cache) -> KnowledgeBase:
    return KnowledgeBase(handover, cache=cache)


@pytest.fixture
def no_java(monkeypatch):
    """Fail the test if anything starts the reasoner (and so the JVM)."""

    def forbidden(*args, **kwargs):
        raise AssertionError("the reasoner ran although the result was cached")

    monkeypatch.setattr(owlready2, "sync_reasoner_pellet", forbidden)
    monkeypatch.setattr(reasoner, "explain_inconsistency", forbidden)


def test_the_reasoner_classifies_what_the_situation_never_states(kb):
    assert "FullOpenContainer" in kb.facts.types["can1"]
    assert "FragileObject" in kb.facts.types["glass1"]  # every glass is fragile (ontology axiom + definition rule)
    assert "Receiver" in kb.facts.types["bob"] and "Supervisor" in kb.facts.types["sue"]
    assert kb.facts.get("handover", "movesObject") == ["can1"]  # property chain usesArm o carries
    assert kb.facts.get("can1", "isCarriedBy") == ["madar_right"]  # inverse property


def test_rules_conclusions_and_the_derived_task_requirements(kb):
    assert kb.facts.get("can1", "isConstrainedBy") == ["UprightFull"]
    assert kb.facts.get("sue", "isConstrainedBy") == ["KeepOutSupervisor"]
    assert set(kb.facts.get("handover", "requiresConstraint")) == {
        "UprightFull",
        "ApproachCone",
        "SharedWorkspaceBox",
        "ReceiverExclusionBox",
        "KeepOutSupervisor",
    }
    # computed from the geometry before reasoning: carried objects against NearHuman's 1.2 m
    assert kb.facts.get("can1", "isNear") == ["bob", "sue"]  # 0.74 m from bob, 0.85 m from sue
    assert kb.facts.get("glass1", "isNear") == []  # not carried
    assert kb.facts.get("can1", "hasX") == []  # no rule reads coordinates: the reasoner never sees them


def test_turtle_export_reparses_and_holds_asserted_and_inferred_triples(kb):
    graph = rdflib.Graph().parse(data=kb.turtle(), format="turtle")
    assert (SIT.can1, rdflib.RDF.type, HP.Can) in graph  # asserted
    assert (SIT.can1, rdflib.RDF.type, HP.FullOpenContainer) in graph  # inferred by classification
    assert (SIT.handover, HP.requiresConstraint, HP.UprightFull) in graph  # inferred from a rule and a chain
    assert (SIT.can1, HP.isNear, SIT.bob) in graph  # computed from the geometry
    assert (HP.UprightFull, HP.hasTolerance, None) in graph  # the ontology travels with the facts
    rule_names = {
        str(o)
        for s in graph.subjects(rdflib.RDF.type, rdflib.URIRef("http://www.w3.org/2003/11/swrl#Imp"))
        for o in graph.objects(s, rdflib.RDFS.label)
    }
    assert {"upright_full_open_container", "define_full_open_container"} <= rule_names
    assert "@prefix hp: <https://hriplan.org/ontology#> ." in kb.turtle().splitlines()  # among the prefixes


def test_a_cached_situation_never_starts_the_jvm_again(kb, handover, cache, no_java):
    again = KnowledgeBase(handover, cache=cache)  # no_java fails the test if the reasoner starts
    assert again.facts == kb.facts


def test_the_disk_cache_serves_a_new_process(kb, handover, cache, no_java):
    fresh = ReasoningCache(cache.directory)  # what another process would see
    again = KnowledgeBase(handover, cache=fresh)  # no_java fails the test if the reasoner starts
    assert again.facts == kb.facts
    assert (cache.directory / f"{kb.key}.json").exists() and (cache.directory / f"{kb.key}.nt").exists()
    graph = again.graph  # the reasoned graph comes from disk too
    assert (SIT.can1, rdflib.RDF.type, HP.FullOpenContainer) in graph


def test_the_key_follows_the_facts_not_the_geometry(kb, handover, cache, no_java):
    people = [h.model_copy(update={"height": 1.6, "reach": {}}) for h in handover.humans]
    tilted = [
        o.model_copy(update={"pose": Pose(xyz=o.pose.xyz, rpy=(0.1, 0.0, 0.0)), "size": None}) for o in handover.objects
    ]
    same_facts = handover.model_copy(update={"humans": people, "objects": tilted})
    assert KnowledgeBase(same_facts, cache=cache).key == kb.key  # a cache hit: no JVM
    closed = handover.model_copy(update={"objects": [o.model_copy(update={"open": False}) for o in handover.objects]})
    assert reasoning_key(ontology_source().digest, load_rules(), situation_assertions(closed), "pellet") != kb.key


def test_a_damaged_cache_entry_is_a_miss_not_an_error(tmp_path):
    cache = ReasoningCache(tmp_path)
    (tmp_path / "abc.json").write_text("{not json")
    assert cache.get("abc") is None


def test_the_cache_directory_follows_xdg(monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert default_cache_dir() == tmp_path / "hriplan" / "reasoning"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert default_cache_dir() == tmp_path / "home" / ".cache" / "hriplan" / "reasoning"


def test_the_default_cache_follows_xdg_and_home_as_they_change(monkeypatch, tmp_path):
    for xdg, home in ((None, "h1"), (None, "h2"), ("x1", "h2"), ("x2", "h2"), (None, "h1"), ("x1", "h1")):
        if xdg is None:
            monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
        else:
            monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / xdg))
        monkeypatch.setenv("HOME", str(tmp_path / home))
        assert default_cache().directory == default_cache_dir()


@pytest.fixture(scope="module")
def full_and_empty(handover) -> Situation:
    return handover.model_copy(update={"facts": [("can1", "hasFillLevel", "Empty")]})


def test_an_inconsistent_situation_names_the_clash(full_and_empty, cache):
    with pytest.raises(InconsistentSituation) as info:
        KnowledgeBase(full_and_empty, cache=cache)
    message = str(info.value)
    assert message.startswith("inconsistent situation: ") and "\n" not in message
    assert 'can1 hasFillLevel "Full"' in message and 'can1 hasFillLevel "Empty"' in message
    assert "Functional hasFillLevel" in message
    assert "java" not in message.lower() and "exception" not in message.lower()


def test_an_inconsistency_is_cached_too(full_and_empty, cache, no_java):
    with pytest.raises(InconsistentSituation, match="hasFillLevel"):
        KnowledgeBase(full_and_empty, cache=cache)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        # The robots it knows are the registry's: robot files loaded by earlier tests add theirs.
        ({"robot": "pr2"}, r"unknown robot 'pr2'; the ontology knows: (.*, )?madar, (.*, )?ur5(, .*)?$"),
        ({"task": {"kind": "Juggling", "arms": ["right"]}}, "task 'task' has kind 'Juggling', not a Task class"),
        ({"task": {"kind": "Transport", "arms": ["middle"]}}, "robot 'madar' has no arm 'middle'; arms: left, right"),
        ({"objects": [{"name": "can1", "kind": "Mug"}]}, "object 'can1' has kind 'Mug', not a PhysicalObject class"),
        (
            {
                "humans": [{"name": "UprightFull", "role": "Bystander"}],
                "task": {"kind": "Transport", "arms": ["right"]},
            },
            "'UprightFull' is a term of the ontology",
        ),
        ({"facts": [["can1", "hasColour", "red"]]}, "'hasColour' is not a property of the ontology"),
        ({"facts": [["nobody", "isHot", True]]}, "'nobody' is neither in the situation nor an individual"),
    ],
)
@pytest.mark.parametrize("reasoner", ["fast", "pellet"])
def test_bad_situations_are_one_line_errors_before_any_reasoning(handover, change, message, reasoner, no_java):
    situation = Situation.model_validate({**handover.model_dump(), **change})
    with pytest.raises(HriplanError, match=message) as info:
        KnowledgeBase(situation, cache=ReasoningCache(None), reasoner=reasoner)
    assert "\n" not in str(info.value)


def test_body_part_names_must_not_collide(handover):
    situation = Situation.model_validate(
        {
            **handover.model_dump(),
            "objects": [{"name": "bob_head", "kind": "Cup"}],
            "task": {"kind": "RobotToHumanHandover", "arms": ["right"], "human": "bob"},
        }
    )
    with pytest.raises(HriplanError, match="'bob_head' is taken by bob's head"):
        KnowledgeBase(situation, cache=ReasoningCache(None))


@pytest.mark.parametrize(
    ("task", "message"),
    [
        (
            {"kind": "Transport", "arms": ["right"], "carries": {"ghost": "right"}},
            "carries 'ghost', which is not among the objects",
        ),
        (
            {"kind": "Transport", "arms": ["right"], "carries": {"can1": "left"}},
            "carried by arm 'left', which the task does not use",
        ),
        ({"kind": "Transport", "arms": ["right"], "human": "zed"}, "task human 'zed' is not among the humans"),
    ],
)
def test_situation_references_are_checked_by_the_model(handover, task, message):
    with pytest.raises(ValidationError, match=message):
        Situation.model_validate({**handover.model_dump(), "task": task})


def test_situation_files_report_the_file_and_field(tmp_path):
    with pytest.raises(HriplanError, match="cannot read situation .*missing.json"):
        load_situation(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text('{"task": {"kind": "Transport", "arms": []}}')
    with pytest.raises(HriplanError, match=r"bad.json: task.arms: List should have at least 1 item"):
        load_situation(bad)
