"""Using hriplan from a higher-level system: one session, perception updates, re-planning, a task
planned in what the session sees and continued from where it stopped.

Run: .venv/bin/python examples/plugin_api.py
"""

from pathlib import Path

import numpy as np

from hriplan.api import (
    Box,
    ConeConstraint,
    FrameRef,
    HumanSpec,
    Obstacle,
    OrientationConstraint,
    PlanningSession,
    PlanOptions,
    Pose,
    Scene,
    ToolTarget,
    load_task,
    posture,
    run_task,
    table,
)

EXAMPLES = Path(__file__).parent

# Build once: robot, collision model, scene; alice is a giver (her ISO/TS 15066 speed limits).
person = HumanSpec(name="alice", position=(0.0, 1.45), yaw=-np.pi / 2, reach={"right": (0.05, 1.05, 1.05)})
session = PlanningSession(
    "madar",
    Scene(obstacles=[table(position=(0.45, 0.85), size=(0.5, 0.5, 0.04), top=0.72)], humans=[person]),
    hands={"right": "power"},
    roles={"alice": "Giver"},
)

# A motion with hand-written constraints: keep the can upright, approach alice's hand in a cone.
joints = session.robot.group_joints("right_arm")
upright = Pose(rpy=(np.pi / 2, 0.0, np.pi))  # tool y (the can's axis) up, tool z towards +y
session.set_constraints(
    [
        OrientationConstraint(
            id="upright", joints=joints, target_link="right_tool", free_axes=["y"], target=upright, tolerance=0.1
        ),
        ConeConstraint(
            id="approach",
            joints=joints,
            target_link="right_tool",
            radius=0.3,
            height=0.55,
            frame=FrameRef(entity="alice/right_hand", offset=Pose(rpy=(0.0, np.pi / 2, 0.0))),
        ),
    ]
)
start = posture("madar", "ready")
hand = session.checker.humans["alice"].frame("right_hand").translation
goal = ToolTarget(
    arm="right", pose=Pose(xyz=tuple(hand + (0.0, -0.19, 0.0)), rpy=(np.pi / 2, 0.0, np.pi)), free_axes=["y"]
)
result = session.plan(start, goal, PlanOptions(seed=1))  # timed to alice's speed limits (the default)
print(
    "first plan:",
    result.status,
    f"{result.trajectory.report.planning_time:.3f} s,",
    f"{len(result.trajectory.points)} points, worst margins {result.trajectory.report.max_violation}",
)

# Perception: alice moved her hand a little; re-plan without rebuilding anything.
session.pose_human(person.model_copy(update={"reach": {"right": (0.07, 1.05, 1.07)}}))
hand = session.checker.humans["alice"].frame("right_hand").translation
goal = goal.model_copy(update={"pose": Pose(xyz=tuple(hand + (0.0, -0.19, 0.0)), rpy=(np.pi / 2, 0.0, np.pi))})
again = session.plan(start, goal, PlanOptions(seed=1))
print("after alice moved:", again.status, f"{again.trajectory.report.planning_time:.3f} s")

# A whole task on the same session: the rules derive the constraints of every step, planned in
# what the session sees (alice where perception has her, and a crate on the place spot).
crate = Obstacle(name="crate", shape=Box(size=(0.1, 0.1, 0.16)), pose=Pose(xyz=(0.45, 0.75, 0.8)))
session.set_scene(session.checker.scene.model_copy(update={"obstacles": [*session.checker.scene.obstacles, crate]}))
task = load_task(EXAMPLES / "handover_full_can.yaml")
outcome = run_task(task, session, EXAMPLES)
for step in outcome.steps:
    print(f"task step {step.name}: {step.status}, constraints: {[c.spec.id for c in step.derivation.constraints]}")
    if not step.trajectory:
        print(f"  why: {step.message}")

# The session is where the take left it, holding the can; the crate is moved away: continue.
session.move_obstacle("crate", Pose(xyz=(0.25, 0.95, 0.8)))
rest = run_task(task, session, EXAMPLES, from_step="place_can")
for step in rest.steps:
    print(f"continued {step.name}: {step.status}")
