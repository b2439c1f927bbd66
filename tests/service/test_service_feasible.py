"""POST /sessions/{id}/feasible on the real server (uvicorn, loopback port): a task planner's
question answered in the session's perceived world, the motions re-checked with the tests' own
geometry, perception updates changing the answer, and errors as one line."""

from pathlib import Path

import httpx
import numpy as np
import pytest
import yaml
from service_server import shared_server

from hriplan.planner.trajectory import TrajectoryFile
from independent import constraint_violations

ROOT = Path(__file__).resolve().parents[2]
WORLD = yaml.safe_load((ROOT / "examples" / "task_planner" / "deliver_cup.yaml").read_text())
BOB = {"name": "bob", "position": [-0.25, 1.4], "yaw": 1.5708}  # beside alice's hand


@pytest.fixture(scope="module")
def client():
    with httpx.Client(base_url=shared_server(), timeout=120) as c:
        created = c.post("/sessions", json={"id": "asker", "robot": "madar", "hands": {"right": "power"}})
        assert created.status_code == 201, created.text
        yield c
        c.delete("/sessions/asker")


def ask(client: httpx.Client, step, **params) -> httpx.Response:
    return client.post("/sessions/asker/feasible", json={"state": WORLD, "step": step}, params=params)


def test_a_person_perceived_beside_the_receiver_makes_the_handover_infeasible_until_he_leaves(client):
    assert client.put("/sessions/asker/humans/bob", json=BOB).status_code == 200
    blocked = ask(client, "hand_over_cup")
    assert blocked.status_code == 200, blocked.text
    answer = blocked.json()
    assert (answer["ok"], answer["status"], answer["cost"], answer["trajectories"]) == (
        False,
        "unreachable_goal",
        None,
        [],
    )
    assert "keep-out:keep_out_bob" in answer["reason"] and "\n" not in answer["reason"]
    kinds = {c["spec"]["id"]: c["kind"] for c in answer["constraints"]}
    assert kinds["keep_out_bob"] == "KeepOutBystander" and kinds["upright_cup"] == "UprightFull"
    assert client.delete("/sessions/asker/humans/bob").status_code == 200
    free = ask(client, "hand_over_cup").json()
    assert free["ok"] and free["status"] == "solved" and free["reason"] == "" and free["cost"] > 0.5
    assert "keep_out_bob" not in {c["spec"]["id"] for c in free["constraints"]}


def test_a_feasible_place_gives_its_cost_and_on_request_its_validated_motions(client):
    place = {"name": "put_down", "goal": {"place": "cup", "at": {"xyz": [0.5, 0.8, 0.77]}}}
    lean = ask(client, place).json()
    full = ask(client, place, trajectories="true").json()
    assert lean["ok"] and lean["trajectories"] == [] and lean["motions"] == ["put_down", "put_down_release"]
    trajectories = [TrajectoryFile.model_validate(t) for t in full["trajectories"]]
    assert [t.step for t in trajectories] == lean["motions"]
    assert full["cost"] == lean["cost"] == pytest.approx(sum(t.points[-1].time_from_start for t in trajectories))
    for trajectory in trajectories:
        assert constraint_violations(trajectory) == []
        assert np.all(np.diff([p.time_from_start for p in trajectory.points]) > 0)


def test_a_robot_configuration_in_the_request_is_where_the_motion_starts(client):
    place = {"name": "put_down", "goal": {"place": "cup", "at": {"xyz": [0.5, 0.8, 0.77]}}}
    first = ask(client, place, trajectories="true").json()["trajectories"][0]
    start = dict(first["start"]) | {"right_shoulder_pan_joint": first["start"]["right_shoulder_pan_joint"] + 0.1}
    body = {"state": WORLD, "step": place, "configuration": start}
    moved = client.post("/sessions/asker/feasible", json=body, params={"trajectories": "true"}).json()
    assert moved["ok"], moved["reason"]
    assert moved["trajectories"][0]["start"]["right_shoulder_pan_joint"] == pytest.approx(
        start["right_shoulder_pan_joint"]
    )


@pytest.mark.parametrize(
    ("path", "body", "status", "error"),
    [
        (
            "/sessions/asker/feasible",
            {"state": WORLD, "step": "fly"},
            400,
            "task 'deliver_cup' has no step 'fly'; steps: hand_over_cup, place_cup",
        ),
        (
            "/sessions/asker/feasible",
            {"state": WORLD, "step": "place_cup", "time_limit": 0},
            422,
            "time_limit: Input should be greater than 0",
        ),
        ("/sessions/nobody/feasible", {"state": WORLD, "step": "place_cup"}, 404, "no session 'nobody'"),
    ],
)
def test_a_bad_question_is_one_line_with_its_status(client, path, body, status, error):
    response = client.post(path, json=body)
    assert (response.status_code, response.json()["error"]) == (status, error)
