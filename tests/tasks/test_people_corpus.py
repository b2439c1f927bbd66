"""The authored corpus of people-first situations (tests/data/people/, issue 10).

Fast path (always): every situation derives the constraint kinds expected per step. Planning
path (HRIPLAN_CORPUS=plan, minutes on a loaded machine): every situation plans, and every
trajectory is checked against its constraints with geometry written here, apart from the
planner's evaluator: tool and link positions by forward kinematics on the written points.
"""

import os
from pathlib import Path

import numpy as np
import pytest
import yaml

from hriplan.planner.constraints.spec import (
    BoxConstraint,
    ConeConstraint,
    CylinderConstraint,
    OrientationConstraint,
    SphereConstraint,
)
from hriplan.planner.replay import PlannedWorld
from hriplan.robots.spatial import Pose
from hriplan.tasks.load import load_task
from hriplan.tasks.pipeline import TaskRunner

DATA = Path(__file__).parents[1] / "data" / "people"
EXPECTED = yaml.safe_load((DATA / "expected.yaml").read_text())
TASKS = sorted(p.stem for p in DATA.glob("*.yaml") if p.stem != "expected")
SLACK = 1e-3  # link origins and tool positions, against the planner's 1e-4 on its own geometry


def test_the_corpus_is_complete_and_varied():
    assert len(TASKS) >= 30 and set(TASKS) == set(EXPECTED)
    tasks = [load_task(DATA / f"{name}.yaml") for name in TASKS]
    roles = {h.role for t in tasks for h in t.humans}
    assert roles == {"Receiver", "Giver", "Supervisor", "Collaborator", "Bystander"}
    assert any(len(t.humans) > 1 for t in tasks) and any(h.posture == "seated" for t in tasks for h in t.humans)
    assert {"hot", "fragile", "sharp", "full"} <= {p for t in tasks for o in t.objects for p in _properties(o)}
    assert any(s.goals for t in tasks for s in t.steps) and any(s.goal for t in tasks for s in t.steps)


def _properties(obj) -> set[str]:
    return {
        p
        for p, on in (
            ("hot", obj.hot),
            ("fragile", obj.kind == "Glass"),
            ("sharp", obj.kind in ("Knife", "Scissors")),
            ("full", obj.fill_level == "Full"),
        )
        if on
    }


@pytest.mark.parametrize("name", TASKS)
def test_each_situation_derives_the_expected_constraints_per_step(name):
    outcome = TaskRunner(load_task(DATA / f"{name}.yaml")).run(plan=False)
    derived = {
        s.name: sorted({c.kind for c in s.derivation.constraints} | {v.kind for v in s.derivation.velocity})
        for s in outcome.steps
    }
    assert derived == EXPECTED[name]["steps"]


def link_origins(robot, q: np.ndarray, arms: list[str]) -> np.ndarray:
    """World origins of every link of the moving arms and their hands."""
    import pinocchio as pin

    pin.framesForwardKinematics(robot.model, robot.data, q)
    prefixes = tuple(robot.arms[a][0] for a in arms)
    return np.array(
        [
            robot.data.oMf[i].translation
            for i, f in enumerate(robot.model.frames)
            if f.type == pin.FrameType.BODY and f.name.startswith(prefixes)
        ]
    )


def violation(
    spec,
    frame: np.ndarray,
    points: np.ndarray,
    rotation: np.ndarray | None,
    grasp_z: np.ndarray,
    goal: np.ndarray | None,
) -> float:
    """How far the worst point breaks the constraint (<= 0 holds), by its own geometry."""
    local = (points - frame[:3, 3]) @ frame[:3, :3]
    if isinstance(spec, OrientationConstraint):
        target = frame[:3, :3] @ spec.target.rotation() @ grasp_z
        axis = rotation @ grasp_z
        allowed = spec.tolerance + spec.tolerance_gradient * (0.0 if goal is None else np.linalg.norm(points[0] - goal))
        return float(np.arccos(np.clip(axis @ target, -1.0, 1.0)) - allowed)
    if isinstance(spec, ConeConstraint):
        z, r = local[:, 2], np.linalg.norm(local[:, :2], axis=1)
        outside = np.maximum.reduce([-z, z - spec.height, r - spec.radius * np.clip(z, 0.0, None) / spec.height])
    elif isinstance(spec, BoxConstraint):
        outside = np.max(np.abs(local) - np.array(spec.size) / 2.0, axis=1)
    elif isinstance(spec, CylinderConstraint):
        r = np.linalg.norm(local[:, :2], axis=1)
        outside = np.maximum.reduce([r - spec.radius, -local[:, 2], local[:, 2] - spec.height])
    elif isinstance(spec, SphereConstraint):
        outside = np.linalg.norm(local, axis=1) - spec.radius
    else:
        raise AssertionError(f"no independent check for {type(spec).__name__}")
    return float(outside.max() if spec.region == "inside" else -outside.min())


def check_independently(robot, trajectory) -> None:
    grasps = {a.arm: a.grasp.rotation()[:, 2] for a in trajectory.scene.attached}
    for point in trajectory.points:
        q = robot.configuration(dict(trajectory.start) | dict(zip(trajectory.joint_names, point.positions)))
        for c in trajectory.constraints:
            arm = next(a for a in robot.arms if robot.tool_frame(a) == c.spec.target_link)
            tool = robot.frame_pose(c.spec.target_link, q)
            keep_out = getattr(c.spec, "keep_out_all_links", False)
            points = np.vstack([tool[:3, 3], link_origins(robot, q, [arm])]) if keep_out else tool[:3, 3][None]
            goal = None if c.goal_position is None else np.array(c.goal_position)
            worst = violation(
                c.spec,
                c.frame_in_world.matrix(),
                points,
                tool[:3, :3],
                grasps.get(arm, np.array([0.0, 1.0, 0.0])),
                goal,
            )
            assert worst <= SLACK, (
                f"{trajectory.step}: {c.spec.id} broken by {worst:.4f} at t={point.time_from_start:.2f}"
            )


@pytest.mark.skipif(
    os.environ.get("HRIPLAN_CORPUS") != "plan", reason="planning the whole corpus takes minutes: HRIPLAN_CORPUS=plan"
)
@pytest.mark.parametrize("name", TASKS)
def test_each_situation_plans_and_every_trajectory_holds_its_constraints(name):
    expected = EXPECTED[name]
    runner = TaskRunner(load_task(DATA / f"{name}.yaml"))
    outcome = runner.run()
    if "refused" in expected:
        failed = next(s for s in outcome.steps if s.status != "solved")
        assert (failed.status, expected["refused"]["says"] in failed.message) == (
            expected["refused"]["status"],
            True,
        ), failed.message
        return
    if expected.get("plans", True) is not True:
        assert not outcome.solved, f"{name} plans now: drop its `plans` entry from expected.yaml"
        pytest.xfail(expected["plans"])
    assert outcome.solved, [f"{s.name}: {s.status}: {s.message}" for s in outcome.steps]
    for step in outcome.steps:
        assert PlannedWorld.load(step.trajectory).validate().valid
        check_independently(runner.session.robot, step.trajectory)
    if "planned_velocity_scale" in expected:
        assert outcome.steps[-1].trajectory.report.velocity_scale == expected["planned_velocity_scale"]


def test_the_independent_check_sees_a_broken_keep_out_and_a_tilted_cup():
    keep_out = CylinderConstraint(
        id="k",
        joints=["j"],
        target_link="right_tool",
        region="outside",
        keep_out_all_links=True,
        radius=0.5,
        height=2.0,
    )
    inside, outside = np.array([[0.3, 0.0, 1.0]]), np.array([[0.6, 0.0, 1.0]])
    assert violation(keep_out, np.eye(4), inside, None, np.zeros(3), None) == pytest.approx(0.2)
    assert violation(keep_out, np.eye(4), outside, None, np.zeros(3), None) < 0.0
    upright = OrientationConstraint(
        id="u",
        joints=["j"],
        target_link="right_tool",
        target={"rpy": (-np.pi / 2, 0.0, 0.0)},
        tolerance=0.05,
        free_axes=["y"],
    )
    tilted = Pose(rpy=(-np.pi / 2 + 0.2, 0.0, 0.0)).rotation()
    # the target puts the grasp axis (tool +y) up; tilted by 0.2 rad it is 0.15 beyond the tolerance
    assert violation(upright, np.eye(4), inside, tilted, np.array([0.0, 1.0, 0.0]), None) == pytest.approx(
        0.15, abs=1e-6
    )
