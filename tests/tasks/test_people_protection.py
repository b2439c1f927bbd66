"""Every person is protected in every step, whatever their role (issue 10)."""

import pytest

from hriplan.ontology.cache import ReasoningCache
from hriplan.ontology.knowledge_base import KnowledgeBase
from hriplan.ontology.situation import Situation
from hriplan.planner.constraints.spec import BoxConstraint, CylinderConstraint
from hriplan.rules.infer import derive


@pytest.fixture(scope="module")
def cache(tmp_path_factory) -> ReasoningCache:
    return ReasoningCache(tmp_path_factory.getbasetemp() / "kb-cache-people")


def knife_past(role: str, target: str | None = None, kind: str = "Transport") -> Situation:
    """MADAR's right arm carries a knife; dana (role given) waits at 0.9 m, eve takes things."""
    return Situation.model_validate(
        {
            "task": {"name": "carry", "kind": kind, "arms": ["right"], "carries": {"knife": "right"}, "human": target},
            "objects": [{"name": "knife", "kind": "Knife"}],
            "humans": [
                {"name": "dana", "role": role, "position": [0.6, 0.7], "yaw": 3.14},
                {"name": "eve", "role": "Receiver", "position": [0.0, 1.45], "yaw": -1.5708},
            ],
        }
    )


def by_anchor(derivation, anchor: str) -> list:
    return [c for c in derivation.constraints if c.anchor == anchor]


@pytest.mark.parametrize("role", ["Receiver", "Giver"])
def test_a_knife_carried_past_a_waiting_partner_keeps_every_link_out(cache, role):
    derivation = derive(KnowledgeBase(knife_past(role), cache=cache))
    (keep_out,) = by_anchor(derivation, "dana")
    assert keep_out.kind == "KeepOutWaitingPartner"
    spec = keep_out.spec
    assert isinstance(spec, CylinderConstraint) and spec.region == "outside" and spec.keep_out_all_links
    assert spec.frame.entity == "dana/base" and spec.radius == pytest.approx(0.45)
    assert "keep_out_waiting_" + role.lower() in keep_out.rules


def test_the_counterpart_keeps_the_body_exclusion_and_the_other_receiver_is_kept_out(cache):
    derivation = derive(KnowledgeBase(knife_past("Receiver", target="eve", kind="RobotToHumanHandover"), cache=cache))
    eve = {c.kind for c in by_anchor(derivation, "eve")}
    assert {"ReceiverExclusionBox", "ApproachCone", "SharedWorkspaceBox"} <= eve
    assert "KeepOutWaitingPartner" not in eve
    exclusion = next(c.spec for c in by_anchor(derivation, "eve") if c.kind == "ReceiverExclusionBox")
    assert isinstance(exclusion, BoxConstraint) and exclusion.keep_out_all_links
    assert [c.kind for c in by_anchor(derivation, "dana")] == ["KeepOutWaitingPartner"]


@pytest.mark.parametrize(
    "role, kind",
    [("Bystander", "KeepOutBystander"), ("Supervisor", "KeepOutSupervisor"), ("Collaborator", "HeadKeepOutSphere")],
)
def test_every_other_role_keeps_its_own_protection(cache, role, kind):
    derivation = derive(KnowledgeBase(knife_past(role), cache=cache))
    assert [c.kind for c in by_anchor(derivation, "dana")] == [kind]
    assert all(c.spec.keep_out_all_links for c in by_anchor(derivation, "dana"))
