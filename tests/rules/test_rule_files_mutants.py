"""Situations that tell the rule files' mutants apart (benchmarks/mutate_rules.py): each body atom of
a rule must matter on some situation, so a variant of an example situation removes the one fact an
atom requires and the rule must stop firing."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from hriplan.ontology.cache import ReasoningCache
from hriplan.ontology.knowledge_base import KnowledgeBase
from hriplan.ontology.situation import EXAMPLES_DIR, load_situation
from hriplan.rules.infer import Derivation, derive


@pytest.fixture(scope="module")
def cache(tmp_path_factory) -> ReasoningCache:
    return ReasoningCache(tmp_path_factory.getbasetemp() / "kb-cache")


def _variant(tmp_path: Path, cache: ReasoningCache, name: str, obj: str, **fields: object) -> Derivation:
    """The derivation of example situation `name` with some fields of object `obj` changed."""
    data = json.loads((EXAMPLES_DIR / f"{name}.json").read_text())
    (target,) = [o for o in data["objects"] if o["name"] == obj]
    target.update(fields)
    (tmp_path / "s.json").write_text(json.dumps(data))
    return derive(KnowledgeBase(load_situation(tmp_path / "s.json"), cache=cache))


def _kinds(derivation: Derivation, anchor: str) -> list[str]:
    return [c.kind for c in derivation.constraints if c.anchor == anchor]


def test_a_closed_partially_full_bottle_need_not_stay_upright(tmp_path, cache):
    """Kills dropping isOpen(?o, true) from define_partially_full_open_container."""
    closed = _variant(tmp_path, cache, "transport_hot_cup", "bottle1", fill_level="Partial", open=False)
    assert not [k for k in _kinds(closed, "bottle1") if k.startswith("Upright")]
    opened = _variant(tmp_path, cache, "transport_hot_cup", "bottle1", fill_level="Partial", open=True)
    assert "UprightPartial" in _kinds(opened, "bottle1")


def test_a_sharp_object_that_is_not_a_tool_gets_no_tool_rules(tmp_path, cache):
    """Kills dropping Tool(?o) from define_sharp_tool: a sharp glass is no SharpTool (no handle
    grasp, no sharp end to point away), a knife is."""
    sharp_glass = _variant(tmp_path, cache, "handover_knife_glass", "glass4", sharp=True)
    assert "SharpEndAway" not in _kinds(sharp_glass, "glass4")
    assert "SharpEndAway" in _kinds(sharp_glass, "knife1")


def test_a_giver_handing_to_the_robot_gets_the_handover_constraints_and_a_receiver_does_not(tmp_path, cache):
    """Kills dropping define_giver or an atom of the take_* rules: no example situation has a giver."""
    data = json.loads((EXAMPLES_DIR / "handover_can.json").read_text())
    data["task"]["kind"] = "HumanToRobotHandover"
    person = data["humans"][0]  # bob, the task's human
    for role, expected in (("Giver", True), ("Receiver", False)):
        person["role"] = role
        (tmp_path / "s.json").write_text(json.dumps(data))
        kinds = set(_kinds(derive(KnowledgeBase(load_situation(tmp_path / "s.json"), cache=cache)), person["name"]))
        assert ({"ApproachCone", "SharedWorkspaceBox", "ReceiverExclusionBox"} <= kinds) == expected, role
