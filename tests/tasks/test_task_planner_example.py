"""examples/task_planner_handover.py: the symbolic planner (unified-planning, pyperplan) hands the
cup over when hriplan says it can, and puts it on the table for alice when hriplan says a person
beside her hand makes the handover infeasible, with hriplan's reason."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

from hriplan.api import PlanningSession

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "task_planner_handover.py"


@pytest.fixture(scope="module")
def example():
    spec = importlib.util.spec_from_file_location("task_planner_handover", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclass looks its module up
    spec.loader.exec_module(module)
    yield module
    del sys.modules[spec.name]


@pytest.fixture(scope="module")
def session(example):
    world = example.load_task(example.WORLD)
    return PlanningSession(world.robot, hands=dict(world.hands))


def choose(example, session, bob):
    session.set_scene(session.checker.scene.model_copy(update={"humans": [bob]}))
    return example.deliver(session)


def test_with_the_handover_feasible_the_planner_hands_the_cup_over(example, session):
    choice = choose(example, session, example.BOB_AWAY)
    assert choice.plan == ["hand_over(cup, alice)"]
    handover, place = choice.answers["hand_over(cup, alice)"], choice.answers["place(cup, table)"]
    assert handover.ok and place.ok and handover.cost > 0.5 and place.cost > 0.5
    assert "UprightFull" in {c.kind for c in handover.constraints} & {c.kind for c in place.constraints}


def test_with_a_person_beside_alices_hand_the_planner_puts_the_cup_on_the_table(example, session):
    choice = choose(example, session, example.BOB_BESIDE_ALICE)
    assert choice.plan == ["place(cup, table)", "take_from_table(alice, cup, table)"]
    handover = choice.answers["hand_over(cup, alice)"]
    assert not handover.ok and handover.status == "unreachable_goal"
    assert handover.reason.startswith("no valid IK solution for the goal pose") and "keep_out_bob" in handover.reason
    assert choice.answers["place(cup, table)"].ok


def test_the_symbolic_plan_follows_hriplans_answer_not_the_domain(example, session, monkeypatch):
    """With every robot action refused, the planner finds no plan: the choice is hriplan's."""
    refused = example.Feasibility(step="x", ok=False, status="unreachable_goal", reason="refused")
    monkeypatch.setattr(example, "feasible", lambda *args: refused)
    assert choose(example, session, example.BOB_AWAY).plan == []
