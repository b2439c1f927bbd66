"""A planned handover keeps ISO/TS 15066 with room to spare: a person model grown by up to the
padding is still approached within the standard's own limits.

Everything here is apart from `hriplan.safety`: the robot's collision meshes from the URDF
(tests/independent.py), the carried can as a coal cylinder, the person's capsules grown in the
test, point velocities by finite differences of the URDF's kinematics, and the SSM and PFL
formulas written from the standard in tests/independent.py (as test_approach_batch.py uses them).
"""

from __future__ import annotations

import math
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin

from hriplan.robots.human import Human
from hriplan.robots.model import arms_of
from hriplan.safety.separation import NO_MARGIN, SafetyMargin
from hriplan.tasks.load import load_task
from hriplan.tasks.pipeline import TaskRunner
from independent import UrdfRobot, iso_allowed

EXAMPLES = Path(__file__).parents[2] / "examples"
STEP = 1e-4  # s: the finite difference that gives each point's velocity


def _handover(margin: SafetyMargin):
    """The README demo: MADAR takes a full can from a giver, alice, and puts it down; leaving her
    hand it is held to the contact cap at her lower arm (a limit that binds)."""
    task = load_task(EXAMPLES / "handover_full_can.yaml")
    planning = task.planning.model_copy(update={"safety_margin": margin})
    outcome = TaskRunner(task.model_copy(update={"planning": planning}), EXAMPLES).run()
    assert outcome.solved, [s.message for s in outcome.steps]
    return outcome.steps


def _moving_parts(urdf: UrdfRobot, step) -> list[tuple[coal.ShapeBase, pin.SE3]]:
    """The moving arm's collision meshes and the carried objects, placed at the configured state."""
    trajectory = step.trajectory
    prefix, tool = arms_of(trajectory.robot)[step.arms[0]]
    parts = [
        (g.geometry, pin.SE3(placed))
        for g, placed in zip(urdf.geometry.geometryObjects, urdf.geometry_data.oMg)
        if g.name.startswith(prefix)
    ]
    for held in trajectory.scene.attached:
        shape = held.shape
        solid = coal.Cylinder(shape.radius, shape.height) if shape.type == "cylinder" else coal.Box(*shape.size)
        grasp = held.grasp.matrix()
        parts.append((solid, urdf.pose(tool) * pin.SE3(grasp[:3, :3], grasp[:3, 3])))
    return parts


def _worst_iso_margins(steps, paddings: list[float]) -> dict[float, float]:
    """Per padding: the least (ISO/TS 15066 allowed - actual) speed of any moving part towards any
    grown capsule of any person at any written point of any step (m/s; >= 0: kept)."""
    worst = dict.fromkeys(paddings, math.inf)
    for step in steps:
        for padding, value in _step_worst(step, paddings).items():
            worst[padding] = min(worst[padding], value)
    return worst


def _step_worst(step, paddings: list[float]) -> dict[float, float]:
    trajectory, policy = step.trajectory, step.derivation.separation
    urdf = UrdfRobot(trajectory.robot, dict(trajectory.hands))
    people = {p.name: Human(p) for p in trajectory.scene.humans}
    worst = dict.fromkeys(paddings, math.inf)
    request = coal.DistanceRequest()
    for point in trajectory.points:
        here = dict(trajectory.start) | dict(zip(trajectory.joint_names, point.positions))
        ahead = here | {j: x + STEP * v for j, x, v in zip(trajectory.joint_names, point.positions, point.velocities)}
        urdf.configure(ahead)
        later = [placement.copy() for _, placement in _moving_parts(urdf, step)]
        urdf.configure(here)
        for (shape, placement), moved in zip(_moving_parts(urdf, step), later):
            for name, human in people.items():
                person = policy.person(name)
                for capsule, at in zip(human.capsules, human.capsule_placements()):
                    for padding in paddings:
                        result = coal.DistanceResult()
                        d = coal.distance(
                            shape,
                            coal.Transform3s(placement.rotation, placement.translation),
                            coal.Capsule(capsule.radius + padding, capsule.length),
                            coal.Transform3s(at.rotation, at.translation),
                            request,
                            result,
                        )
                        robot_point = result.getNearestPoint1()
                        local = placement.actInv(robot_point)
                        velocity = (moved.act(local) - robot_point) / STEP
                        contact = person.contact_region(capsule.name) is not None
                        if contact or d <= 1e-6:
                            approach = float(np.linalg.norm(velocity))
                        else:
                            approach = float(velocity @ (result.getNearestPoint2() - robot_point) / d)
                        allowed = iso_allowed(policy.robot, person, d, capsule.name)
                        worst[padding] = min(worst[padding], allowed - approach)
    return worst


def test_a_handover_timed_with_the_margin_keeps_iso_for_a_person_grown_by_the_padding():
    steps = _handover(SafetyMargin())  # the defaults: 0.05 m padding, 0.95 of every cap
    for step in steps:
        margin = step.trajectory.report.safety_margin
        assert (margin.padding, margin.speed_factor) == (0.05, 0.95)  # recorded in the trajectory file
    worst = _worst_iso_margins(steps, [0.0, 0.025, 0.05])
    assert all(w >= 0.01 for w in worst.values()), worst  # room to spare, even for the grown person
    traces = [t for s in steps for t in s.trajectory.report.separation]
    assert min(t.iso_worst_margin for t in traces) > min(t.worst_margin for t in traces) >= -1e-3


def test_without_the_margin_the_motion_rides_on_the_limit():
    """The same task timed exactly on ISO/TS 15066's limits (no margin) has no room at all: the
    test above has something to catch."""
    steps = _handover(NO_MARGIN)
    assert all(s.trajectory.report.safety_margin == NO_MARGIN for s in steps)
    worst = _worst_iso_margins(steps, [0.0])
    assert worst[0.0] < 0.005


def test_validate_rechecks_with_the_margin_the_file_records(tmp_path):
    """`hriplan validate` applies the margin written in the trajectory file: the same motion passes
    with the margin it was timed with and fails if the file asked for half the speed caps."""
    from typer.testing import CliRunner

    from hriplan.cli.main import app
    from hriplan.planner.trajectory import load_trajectory

    task = (EXAMPLES / "handover_full_can.yaml").read_text()
    (tmp_path / "t.yaml").write_text(task.replace("planning: {", "planning: {safety_margin: {padding: 0.08}, "))
    assert "safety_margin: {padding: 0.08}" in (tmp_path / "t.yaml").read_text()
    runner = CliRunner()
    planned = runner.invoke(app, ["plan", str(tmp_path / "t.yaml"), "-o", str(tmp_path / "t.json"), "-q"])
    assert planned.exit_code == 0, planned.output
    leaving = tmp_path / "t.place_can.json"  # leaving alice's hand, held to 0.95 of the contact cap
    trajectory = load_trajectory(leaving)
    assert trajectory.report.safety_margin == SafetyMargin(padding=0.08, speed_factor=0.95)
    kept = runner.invoke(app, ["validate", str(leaving)])
    assert kept.exit_code == 0 and "(ISO/TS 15066, padding 0.08 m, speed factor 0.95): kept" in kept.output
    stricter = trajectory.report.model_copy(update={"safety_margin": SafetyMargin(padding=0.08, speed_factor=0.5)})
    trajectory.model_copy(update={"report": stricter}).save(tmp_path / "strict.json")
    refused = runner.invoke(app, ["validate", str(tmp_path / "strict.json")])
    assert refused.exit_code == 1 and "speed factor 0.5): EXCEEDED" in refused.output
    # A file written before margins were recorded is held to ISO/TS 15066's limits exactly.
    older = trajectory.report.model_copy(update={"safety_margin": None})
    trajectory.model_copy(update={"report": older}).save(tmp_path / "older.json")
    iso = runner.invoke(app, ["validate", str(tmp_path / "older.json")])
    assert iso.exit_code == 0 and "(ISO/TS 15066, padding 0 m, speed factor 1): kept" in iso.output
