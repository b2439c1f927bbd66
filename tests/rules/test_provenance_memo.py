"""Explanations remembered by reasoning key: a remembered one is the one worked out afresh, with
the measurements of the situation asked about, never of the situation it was first made for."""

import dataclasses
import math

import pytest

from hriplan.ontology.cache import ReasoningCache
from hriplan.ontology.knowledge_base import KnowledgeBase
from hriplan.ontology.relations import NEAR_HUMAN
from hriplan.ontology.situation import EXAMPLES_DIR, Situation, load_situation
from hriplan.rules.infer import CONSTRAINED_BY, _requirements, derive
from hriplan.rules.provenance import Provenance


@pytest.fixture(scope="module")
def cache(tmp_path_factory) -> ReasoningCache:
    return ReasoningCache(tmp_path_factory.getbasetemp() / "memo-cache")


def _moved(situation: Situation, person: str, dx: float) -> Situation:
    moved = situation.model_copy(deep=True)
    human = moved.human(person)
    human.position = (human.position[0] + dx, human.position[1])
    return moved


def _afresh(kb: KnowledgeBase) -> Provenance:
    return Provenance(kb.rules, kb.facts, kb.assertions, kb.relations)  # no key: nothing remembered


@pytest.mark.parametrize("name", sorted(p.stem for p in EXAMPLES_DIR.glob("*.json")))
def test_every_example_is_explained_as_afresh_when_asked_first_and_again(name, cache):
    kb = KnowledgeBase(load_situation(EXAMPLES_DIR / f"{name}.json"), cache=cache)
    remembering = Provenance(kb.rules, kb.facts, kb.assertions, kb.relations, kb.key)
    for anchor, kind in _requirements(kb):
        fresh = _afresh(kb).why(anchor, CONSTRAINED_BY, kind)
        assert fresh.rules  # something explains every requirement
        for _ in range(2):  # the miss, then the hit
            assert remembering.why(anchor, CONSTRAINED_BY, kind) == fresh


def test_a_person_who_moves_without_crossing_the_threshold_gets_the_new_distance_in_words(cache):
    """Same reasoning key (the cup stays near col), so the explanation is remembered: its
    measurement must be the new one."""
    situation = load_situation(EXAMPLES_DIR / "transport_hot_cup.json")
    cup = situation.object("cup1")
    worded = []
    for dx in (0.0, 0.07):
        moved = _moved(situation, "col", dx)
        kb = KnowledgeBase(moved, cache=cache)
        (hot,) = derive(kb).velocity
        distance = math.dist(cup.pose.xyz[:2], moved.human("col").position)
        words = f"cup1 is {distance:.2f} m from col, below NearHuman 1.2 m"
        assert words in hot.facts and hot.rules == [
            "slow_hot_object_near_human",
            "define_hot_object",
            "carried_object_near_human",
        ]
        assert hot.facts == _afresh(kb).why("cup1", CONSTRAINED_BY, "ReducedVelocityHot").facts
        worded.append((kb.key, words))
    assert worded[0][0] == worded[1][0] and worded[0][1] != worded[1][1]


def test_a_person_who_moves_away_is_not_given_the_near_explanation(cache):
    situation = load_situation(EXAMPLES_DIR / "transport_hot_cup.json")
    derive(KnowledgeBase(situation, cache=cache))  # remembered near
    far = derive(KnowledgeBase(_moved(situation, "col", 5.0), cache=cache))
    assert not far.velocity
    assert not any("from col" in f for c in far.constraints for f in c.facts)


def test_the_same_assertion_measured_by_another_relation_names_that_relation(cache):
    situation = load_situation(EXAMPLES_DIR / "transport_hot_cup.json")
    renamed = dataclasses.replace(NEAR_HUMAN, name="near_by_another_measure")
    for kind in (NEAR_HUMAN, renamed):
        (hot,) = derive(KnowledgeBase(situation, cache=cache, relations=(kind,))).velocity
        assert hot.rules[-1] == kind.name
