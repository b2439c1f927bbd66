"""The real server (uvicorn in a subprocess, 2 workers) over HTTP with httpx: tasks, problems,
sessions, ROS trajectories, error statuses, and the worker pool under crashes and load."""

import concurrent.futures
import copy
import json
import os
import signal
import threading
import time
from pathlib import Path

import httpx
import numpy as np
import pytest
import yaml
from service_server import shared_server, wait_for_workers

from hriplan.planner.problem import PlanningProblem
from hriplan.planner.replay import PlannedWorld
from hriplan.planner.session import PlanningSession
from hriplan.planner.trajectory import TrajectoryFile
from hriplan.robots import kernel_switch
from independent import constraint_violations

ROOT = Path(__file__).resolve().parents[2]
TASK_YAML = (ROOT / "examples" / "handover_full_can.yaml").read_text()
PROBLEM = json.loads((ROOT / "benchmarks" / "scenarios" / "b_madar_handover.json").read_text())
YAML = {"content-type": "application/yaml"}


def slow_problem(seconds: float) -> dict:
    """A problem that runs for its whole time limit: rejection sampling never meets a 0.002 rad upright band."""
    problem = copy.deepcopy(PROBLEM)
    problem["options"].update(planner="RRTConnect", space="rejection", time_limit=seconds, seed=1)
    for constraint in problem["constraints"]["constraints"]:  # a band too thin for rejection sampling to meet
        if constraint["type"] == "orientation":
            constraint["tolerance"] = 0.002
    return problem


@pytest.fixture(scope="module")
def server():
    return shared_server()  # --workers 2 --queue 2 --query-time-limit 1 --row-limit 100


@pytest.fixture(scope="module")
def client(server):
    with httpx.Client(base_url=server, timeout=120) as c:
        yield c


def _seconds(stamp: dict) -> float:
    assert set(stamp) == {"sec", "nanosec"} and 0 <= stamp["nanosec"] < 1_000_000_000
    return stamp["sec"] + stamp["nanosec"] * 1e-9


def check_joint_trajectory(ros: dict, trajectory: dict) -> None:
    """The ROS message carries the file's motion exactly, and its velocities integrate to its positions."""
    assert set(ros) == {"header", "joint_names", "points"} and ros["header"] == {
        "stamp": {"sec": 0, "nanosec": 0},
        "frame_id": "",
    }
    assert ros["joint_names"] == trajectory["joint_names"] and len(ros["points"]) == len(trajectory["points"]) > 2
    times = np.array([_seconds(p["time_from_start"]) for p in ros["points"]])
    assert np.allclose(times, [p["time_from_start"] for p in trajectory["points"]], atol=1e-9) and np.all(
        np.diff(times) > 0
    )
    q = np.array([p["positions"] for p in ros["points"]])
    v = np.array([p["velocities"] for p in ros["points"]])
    assert q.shape == v.shape == (len(times), len(ros["joint_names"])) and all(p["effort"] == [] for p in ros["points"])
    assert all(len(p["accelerations"]) == len(ros["joint_names"]) for p in ros["points"])
    integrated = q[0] + np.concatenate(
        [np.zeros((1, q.shape[1])), np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(times)[:, None], axis=0)]
    )
    assert np.abs(integrated - q).max() < 0.02 * max(np.ptp(q, axis=0).max(), 1e-3)


def test_a_yaml_task_is_planned_validated_and_given_as_joint_trajectories(client):
    response = client.post("/plan", params={"ros": "true"}, content=TASK_YAML, headers=YAML)
    assert response.status_code == 200, response.text
    body = response.json()
    assert body["task"] == "handover_full_can" and body["solved"] is True
    names = ["take_can", "place_can", "place_can_release"]
    assert [s["name"] for s in body["steps"]] == names and set(body["joint_trajectories"]) == set(names)
    for step in body["steps"]:
        check_joint_trajectory(body["joint_trajectories"][step["name"]], step["trajectory"])
        trajectory = TrajectoryFile.model_validate(step["trajectory"])
        assert PlannedWorld.load(trajectory).validate().valid  # the replay validator, not the planner's own result
        assert constraint_violations(trajectory) == []  # geometry apart from the planner's
        assert {c["spec"]["id"] for c in step["trajectory"]["constraints"]} == {
            c["spec"]["id"] for c in step["derivation"]["constraints"]
        }


def test_constraints_and_explain_answer_the_same_for_json_and_yaml(client):
    from_yaml = client.post("/constraints", content=TASK_YAML, headers=YAML)
    from_json = client.post("/constraints", json=yaml.safe_load(TASK_YAML))
    assert from_yaml.status_code == from_json.status_code == 200 and from_yaml.json() == from_json.json()
    take = from_json.json()["steps"][0]
    assert take["status"] == "derived" and "trajectory" in take and take["trajectory"] is None
    kinds = {c["kind"] for c in take["derivation"]["constraints"]}
    # the can is carried (kept upright) from the take on, not while the empty hand reaches for it
    assert "ApproachCone" in kinds and "UprightFull" not in kinds
    assert "UprightFull" in {c["kind"] for c in from_json.json()["steps"][1]["derivation"]["constraints"]}
    explained = client.post("/explain", content=TASK_YAML, headers=YAML).json()
    assert [s["name"] for s in explained["steps"]] == ["take_can", "place_can"]
    assert "velocity scale for the trajectory: 1" in explained["steps"][0]["explanation"]
    assert all(c["spec"]["id"] in explained["steps"][0]["explanation"] for c in take["derivation"]["constraints"])


def test_a_planning_problem_is_solved_and_a_failure_is_a_200_with_its_reason(client):
    solved = client.post("/solve", params={"ros": "true"}, json=PROBLEM).json()
    assert (
        solved["solved"] is True
        and solved["status"] == "solved"
        and solved["trajectory"]["schema"] == "hriplan.trajectory"
    )
    check_joint_trajectory(solved["joint_trajectory"], solved["trajectory"])
    names = solved["trajectory"]["joint_names"]
    assert solved["trajectory"]["points"][0]["positions"] == pytest.approx(
        [PROBLEM["start"][j] for j in names], abs=1e-9
    )
    failed = client.post("/solve", json=slow_problem(0.5))
    assert failed.status_code == 200
    assert failed.json()["solved"] is False and failed.json()["message"].startswith("planning failed (timeout): ")
    assert failed.json()["trajectory"] is None and failed.json()["joint_trajectory"] is None


def test_a_session_follows_perception_updates_and_plans_against_them(client):
    created = client.post(
        "/sessions",
        json={
            "id": "cell",
            "robot": "madar",
            "hands": PROBLEM["hands"],
            "scene": PROBLEM["scene"],
            "constraints": PROBLEM["constraints"],
            "roles": PROBLEM["roles"],  # the receiver's speed limits (others: a bystander's)
        },
    )
    assert created.status_code == 201, created.text
    assert created.json()["roles"] == PROBLEM["roles"] != {}
    assert client.post("/sessions", json={"id": "cell"}).status_code == 409
    request = {k: PROBLEM[k] for k in ("start", "goal", "options", "group")}
    first = client.post("/sessions/cell/plan", json=request).json()
    assert first["solved"] and first["trajectory"]["scene"]["obstacles"] == created.json()["scene"]["obstacles"]
    assert [s["person"] for s in first["trajectory"]["report"]["separation"]] == list(
        PROBLEM["roles"]
    )  # timed near them
    # A box appears on the straight path's tool positions: the next plan has it in its scene and stays clear of it.
    box = {"name": "crate", "shape": {"type": "box", "size": [0.3, 0.3, 0.3]}, "pose": {"xyz": [-2.0, 2.0, 0.3]}}
    moved = client.put("/sessions/cell/obstacles/crate", json=box)
    assert moved.status_code == 200 and moved.json()["version"] == 1
    person = {"name": "dana", "position": [1.5, 1.5], "yaw": 3.14}
    assert client.put("/sessions/cell/humans/dana", json=person).json()["version"] == 2
    second = client.post("/sessions/cell/plan", json=request).json()
    assert second["solved"] and {o["name"] for o in second["trajectory"]["scene"]["obstacles"]} >= {"crate"}
    assert [h["name"] for h in second["trajectory"]["scene"]["humans"]][-1] == "dana"
    assert PlannedWorld.load(TrajectoryFile.model_validate(second["trajectory"])).validate().valid
    assert constraint_violations(TrajectoryFile.model_validate(second["trajectory"])) == []
    clash = client.put("/sessions/cell/obstacles/dana", json={**box, "name": "dana"})
    assert clash.status_code == 409 and "repeated: dana" in clash.json()["error"]
    assert client.delete("/sessions/cell/obstacles/crate").json()["version"] == 3
    assert client.delete("/sessions/cell/obstacles/crate").status_code == 404
    assert client.delete("/sessions/cell").status_code == 204
    gone = client.post("/sessions/cell/plan", json=request)
    assert gone.status_code == 404 and gone.json() == {"error": "no session 'cell'", "field": None}


@pytest.mark.parametrize(
    ("path", "body", "status", "error", "field"),
    [
        ("/constraints", {"steps": [{}]}, 422, "steps.0: Value error, a step has either `goal` or `goals`", "steps.0"),
        (
            "/constraints",
            {"robot": "r2d2", "steps": [{"goal": {"joints": {}}}]},
            422,
            "robot: Value error, unknown robot 'r2d2'; known robots: madar, ur5",
            "robot",
        ),
        ("/solve", {"goal": {"type": "joints", "values": []}}, 422, "start: Field required", "start"),
        ("/solve", {**PROBLEM, "robot": "r2d2"}, 400, "unknown robot 'r2d2'; known robots: madar, ur5", None),
        ("/sessions", {"robot": "madar", "hands": {"right": "fist"}}, 400, "unknown hand posture", None),
    ],
)
def test_errors_are_one_json_line_with_the_right_status(client, path, body, status, error, field):
    response = client.post(path, json=body)
    assert response.status_code == status and response.headers["content-type"] == "application/json"
    assert response.json()["error"].startswith(error) and response.json()["field"] == field
    assert "\n" not in response.json()["error"] and "Traceback" not in response.text


def test_bad_yaml_or_json_is_a_400_saying_so(client):
    response = client.post("/constraints", content="name: t\nsteps:\n  - goal: [a\n", headers=YAML)
    assert response.status_code == 400 and response.json()["error"].startswith("body: line 4: not valid YAML")
    response = client.post("/solve", content="{bad json", headers={"content-type": "application/json"})
    assert response.status_code == 400 and response.json()["error"].startswith("body: line 1: not valid JSON (")


def test_a_worker_killed_mid_plan_fails_only_its_request_and_is_replaced(server, client):
    before = wait_for_workers(server, 2)
    results = {}
    slow = threading.Thread(target=lambda: results.update(slow=client.post("/solve", json=slow_problem(20))))
    slow.start()
    busy = []
    deadline = time.monotonic() + 10
    while not busy and time.monotonic() < deadline:
        busy = [w["pid"] for w in client.get("/health").json()["workers"] if w["busy"]]
        time.sleep(0.05)
    assert len(busy) == 1
    other = client.post("/constraints", content=TASK_YAML, headers=YAML)  # served by the other worker meanwhile
    os.kill(busy[0], signal.SIGKILL)
    slow.join(30)
    assert other.status_code == 200
    crashed = results["slow"]
    assert crashed.status_code == 500 and crashed.json()["error"].startswith(
        "the worker serving this request died (exit code -9)"
    )
    after = wait_for_workers(server, 2)
    assert busy[0] not in after and set(before) - {busy[0]} <= set(after)
    assert client.post("/solve", json=PROBLEM).json()["solved"]
    health = client.get("/health").json()  # the replacement loaded the compiled kernels too; query workers never
    assert [w["kernels"] for w in health["workers"]] == [True, True]
    assert [w["kernels"] for w in health["query_workers"]] == [False]


def test_a_served_plan_is_the_plan_made_here_with_the_compiled_kernels(client, compiled_route):
    """The workers plan with the kernels on (the default), so a plan is reproduced in-process with them
    on (HRIPLAN_KERNELS=1 for the CLI). This UR5 problem plans another motion with them off: margins
    rounded ~1e-16 apart from the Python route's steer its projections elsewhere."""
    raw = json.loads((ROOT / "benchmarks" / "scenarios" / "a_ur5_upright_box.json").read_text())
    raw["options"]["seed"] = 3
    served = client.post("/solve", json=raw).json()
    problem = PlanningProblem.model_validate(raw)
    session = PlanningSession(problem.robot, problem.scene, hands=problem.hands, roles=dict(problem.roles))
    session.set_constraints(problem.constraints)
    here = session.plan(problem.start, problem.goal, problem.options, problem.group)
    kernel_switch.use_kernels(False)  # the fixture turns them back on, then restores the switch
    without = session.plan(problem.start, problem.goal, problem.options, problem.group)
    assert served["solved"] and here.solved and without.solved
    positions = np.array([p.positions for p in here.trajectory.points])
    assert positions == pytest.approx(np.array([p["positions"] for p in served["trajectory"]["points"]]), abs=1e-12)
    other = np.array([p.positions for p in without.trajectory.points])  # so the test tells the two apart
    assert other.shape != positions.shape or np.abs(other - positions).max() > 1e-6


def test_a_client_that_goes_away_cancels_its_plan(server, client):
    before = wait_for_workers(server, 2)
    with pytest.raises(httpx.ReadTimeout):
        httpx.post(f"{server}/solve", json=slow_problem(30), timeout=1.5)
    deadline = time.monotonic() + 30
    while set(after := wait_for_workers(server, 2)) == set(before) and time.monotonic() < deadline:
        time.sleep(0.2)  # the server notices the disconnect, stops the worker and starts another
    assert len(set(before) - set(after)) == 1


def test_a_full_queue_answers_503_with_retry_after(server):
    wait_for_workers(server, 2)
    with concurrent.futures.ThreadPoolExecutor(8) as pool:
        futures = [pool.submit(httpx.post, f"{server}/solve", json=slow_problem(2), timeout=60) for _ in range(6)]
        statuses = sorted(f.result().status_code for f in futures)
        refused = [f.result() for f in futures if f.result().status_code == 503]
    assert statuses == [200] * 4 + [503] * 2  # 2 planning + 2 waiting (--queue 2), the rest refused
    assert all(r.headers["retry-after"] == "1" and "workers are busy" in r.json()["error"] for r in refused)


def test_mixed_concurrent_requests_never_mix_up_answers(server):
    """A small load test (the benchmark runs 200): every answer belongs to its request."""
    wait_for_workers(server, 2)
    task = yaml.safe_load(TASK_YAML)

    def one(k: int) -> tuple[bool, dict]:
        with httpx.Client(base_url=server, timeout=120) as c:
            if k % 3 == 0:
                body = c.post("/constraints", json={**task, "name": f"load{k}"}).json()
                return body.get("task") == f"load{k}", body
            if k % 3 == 1:
                problem = copy.deepcopy(PROBLEM)
                problem["start"]["right_shoulder_pan_joint"] += k * 1e-4  # a start of its own, well inside every band
                body = c.post("/solve", json=problem).json()
                if not body.get("solved"):
                    return False, body
                first = dict(zip(body["trajectory"]["joint_names"], body["trajectory"]["points"][0]["positions"]))
                return first["right_shoulder_pan_joint"] == pytest.approx(
                    problem["start"]["right_shoulder_pan_joint"], abs=1e-9
                ), {}
            answer = c.get("/sparql", params={"query": f'SELECT ?tag WHERE {{ BIND("tag{k}" AS ?tag) }}'}).json()
            return [b["tag"]["value"] for b in answer["results"]["bindings"]] == [f"tag{k}"], answer

    with concurrent.futures.ThreadPoolExecutor(4) as pool:
        answers = list(pool.map(one, range(24)))
    assert [body for ok, body in answers if not ok] == []


def test_a_worker_plans_every_session_request_in_its_own_world_on_its_one_session(monkeypatch):
    """A worker's jobs share one planning session per robot and hands (a task plan, another
    session): a session request plans in its own scene and constraints whatever ran before."""
    from hriplan.planner import session as session_module
    from hriplan.robots.scene import Scene
    from hriplan.service import jobs
    from hriplan.service.schemas import SessionState

    monkeypatch.setattr(session_module, "_WORKER_SESSIONS", {})
    crate = {"name": "crate", "shape": {"type": "box", "size": [0.3, 0.3, 0.3]}, "pose": {"xyz": [-2.0, 2.0, 0.3]}}
    cell = SessionState.model_validate({"id": "cell", "robot": "ur5", "scene": {"obstacles": [crate]}})
    other = SessionState.model_validate({"id": "other", "robot": "ur5"})
    session = jobs._session(cell)
    assert [o.name for o in session.checker.scene.obstacles] == ["crate"]
    assert jobs._session(other) is session and session.checker.scene.obstacles == []
    assert jobs._session(cell) is session and [o.name for o in session.checker.scene.obstacles] == ["crate"]
    session.set_scene(Scene())  # what a task job on this worker does
    assert [o.name for o in jobs._session(cell).checker.scene.obstacles] == ["crate"]
    assert jobs._session(SessionState.model_validate({"id": "c", "robot": "madar"})) is not session


@pytest.mark.parametrize(
    ("body", "content_type", "error"),
    [
        # The CLI refuses these files; before, the service kept the last key and derived no upright constraint.
        (
            "name: t\nfill_level: Full\nfill_level: Empty\n",
            "application/yaml",
            "body: line 3: key 'fill_level' is given twice (first at line 2)",
        ),
        ('{"name": "t", "name": "u"}', "application/json", "body: key 'name' is given twice"),
        # Valid YAML that JSON has no type for was a 500.
        ("name: t\nwhen: 2026-12-02\n", "application/yaml", "body: when: a date value, which JSON has no type for"),
        ("name: !!binary aGVsbG8=\n", "application/yaml", "body: name: a bytes value, which JSON has no type for"),
        ("name: t\nsteps: !!set {a, b}\n", "application/yaml", "body: steps: a set value, which JSON has no type for"),
        ("name: t\nsteps: " + "[" * 5000 + "]" * 5000 + "\n", "application/yaml", "body: nested too deeply"),
    ],
)
def test_a_body_is_read_like_a_file(client, body: str, content_type: str, error: str):
    response = client.post("/constraints", content=body, headers={"content-type": content_type})
    assert response.status_code == 400 and response.json()["error"] == error


def _until_done(client: httpx.Client, job: str) -> dict:
    deadline = time.monotonic() + 120
    while (state := client.get(f"/jobs/{job}").json())["status"] == "running" and time.monotonic() < deadline:
        time.sleep(0.1)
    return state


def test_a_long_plan_as_a_job_is_submitted_polled_and_its_result_fetched(server, client):
    wait_for_workers(server, 2)
    problem = copy.deepcopy(PROBLEM)
    problem["start"]["right_shoulder_pan_joint"] += 1e-4  # a marker of this request
    submitted = client.post("/jobs/solve", json=problem, params={"ros": True})
    job = submitted.json()
    assert submitted.status_code == 202 and submitted.headers["location"] == f"/jobs/{job['id']}"
    assert job["status"] == "running" and job["kind"] == "solve"
    assert _until_done(client, job["id"]) == {**job, "status": "done", "result_status": 200}
    result = client.get(f"/jobs/{job['id']}/result").json()
    assert result["solved"] and result["joint_trajectory"]["joint_names"] == result["trajectory"]["joint_names"]
    first = result["trajectory"]["points"][0]["positions"][
        result["trajectory"]["joint_names"].index("right_shoulder_pan_joint")
    ]
    assert abs(first - problem["start"]["right_shoulder_pan_joint"]) < 1e-9
    task = client.post("/jobs/plan", content=TASK_YAML, headers=YAML).json()
    assert _until_done(client, task["id"])["result_status"] == 200
    assert client.get(f"/jobs/{task['id']}/result").json()["task"] == "handover_full_can"
    refused = client.post("/jobs/plan", content="name: x\nsteps: 3\n", headers=YAML)
    assert refused.status_code == 422 and refused.json()["field"] == "steps"  # checked before it is queued


def test_a_cancelled_job_stops_its_worker_and_an_unknown_one_is_404(server, client):
    before = wait_for_workers(server, 2)
    job = client.post("/jobs/solve", json=slow_problem(60)).json()
    while not any(w["busy"] for w in client.get("/health").json()["workers"]):
        time.sleep(0.05)
    unfinished = client.get(f"/jobs/{job['id']}/result")
    assert unfinished.status_code == 409 and unfinished.json()["error"].startswith(
        f"job {job['id']!r} is still running"
    )
    assert client.delete(f"/jobs/{job['id']}").status_code == 204
    deadline = time.monotonic() + 30
    while set(after := wait_for_workers(server, 2)) == set(before) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert len(set(before) - set(after)) == 1  # its worker was stopped, not left planning for 60 s
    gone = client.get(f"/jobs/{job['id']}")
    assert gone.status_code == 404 and gone.json() == {"error": f"no job {job['id']!r}", "field": None}
