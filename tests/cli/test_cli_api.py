"""The plug-in API: a tool goal's arm is the group, what an integrator needs is exported, and
run_task says what it does to the session it is given."""

from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
import pytest

from hriplan import HriplanError, api
from hriplan.api import (
    Box,
    BoxConstraint,
    HumanSpec,
    Obstacle,
    PlanningSession,
    PlanOptions,
    Pose,
    Scene,
    Status,
    TaskFile,
    ToolTarget,
    load_task,
    posture,
    run_task,
)
from independent import UrdfRobot, clearance, constraint_violations


def test_a_tool_goal_without_group_moves_its_arm_only():
    session = PlanningSession("madar", hands={"right": "power"})
    start = posture("madar", "ready")
    tool = session.robot.frame_pose("right_tool", start)
    goal = ToolTarget(arm="right", pose=Pose(xyz=tuple(tool[:3, 3] + (0.0, 0.05, 0.0)), quat_xyzw=_quat(tool[:3, :3])))
    result = session.plan(start, goal, PlanOptions(seed=1, time_limit=20))
    assert result.solved, result.message
    trajectory = result.trajectory
    assert trajectory.joint_names == session.robot.group_joints("right_arm")
    end = session.robot.configuration(
        trajectory.start | dict(zip(trajectory.joint_names, trajectory.points[-1].positions))
    )
    assert np.allclose(session.robot.frame_pose("right_tool", end)[:3, 3], goal.pose.xyz, atol=2e-3)


def _quat(rotation: np.ndarray) -> tuple[float, float, float, float]:
    import pinocchio as pin

    q = pin.Quaternion(rotation)
    return (q.x, q.y, q.z, q.w)


TASK = {
    "name": "api",
    "robot": "ur5",
    "humans": [{"name": "bob", "role": "Bystander", "position": [1.5, 0.0], "yaw": 3.14}],
    "steps": [{"name": "move", "goal": {"joints": {"elbow_joint": 1.0}}}],
    "planning": {"time_limit": 5, "seed": 1},
}


def test_run_task_plans_in_the_sessions_world_and_leaves_it_as_the_task_does():
    zoe = HumanSpec(name="zoe", position=(0.0, -1.5), yaw=1.57)
    session = PlanningSession("ur5", Scene(humans=[zoe]))
    joints = session.robot.group_joints("arm")
    mine = BoxConstraint(id="mine", joints=joints, target_link="tool", size=(2.0, 2.0, 2.0))
    session.set_constraints([mine])
    outcome = run_task(TaskFile.model_validate(TASK), session, advance=False)
    assert outcome.solved, [(s.name, s.message) for s in outcome.steps]
    step = outcome.steps[0]
    assert [h.name for h in step.trajectory.scene.humans] == ["bob", "zoe"]  # the task's and the session's
    assert {p.name: p.role for p in step.derivation.separation.people} == {"bob": "Bystander", "zoe": "Bystander"}
    assert "keep_out_zoe" in {c.spec.id for c in step.derivation.constraints}  # the rules protect her too
    assert [h.name for h in session.checker.scene.humans] == ["zoe"] and list(session.constraints) == ["mine"]
    assert session.configuration is None
    run_task(TaskFile.model_validate(TASK), session)  # advance: the world as the task leaves it
    assert [h.name for h in session.checker.scene.humans] == ["bob", "zoe"] and list(session.constraints) == ["mine"]
    assert session.configuration["elbow_joint"] == pytest.approx(1.0) and session.roles == {"bob": "Bystander"}


def test_api_exports_postures_and_person_frames():
    assert "ready" in api.POSTURES["madar"] and api.posture("ur5", "home")
    assert {"right_hand", "torso", "head"} <= set(api.PERSON_FRAMES)
    assert all(hasattr(api, name) for name in api.__all__)


# -- a task and a motion in the session's world -------------------------------------------------
EXAMPLES = Path(__file__).parents[2] / "examples"
HANDOVER = load_task(EXAMPLES / "handover_full_can.yaml")
CRATE_SIZE = (0.1, 0.1, 0.16)  # standing on the table (top 0.72)
BESIDE = (0.25, 0.85, 0.80)  # where the can passes on its way to the place spot
ON_THE_SPOT = (0.45, 0.75, 0.80)  # where the can is to be placed


def _crate(at: tuple[float, float, float]) -> Obstacle:
    return Obstacle(name="crate", shape=Box(size=CRATE_SIZE), pose=Pose(xyz=at))


def _crate_clearance(trajectory, at: tuple[float, float, float]) -> float:
    """The trajectory's distance to the crate: coal on the URDF meshes and the held can."""
    return clearance(trajectory, coal.Box(*CRATE_SIZE), pin.SE3(np.eye(3), np.array(at)))[0]


def test_a_task_on_a_session_plans_around_the_crate_the_session_has_seen():
    """Was: the task planned in its file's world, the place solved through the crate (every point)."""
    session = PlanningSession("madar", Scene(obstacles=[_crate(BESIDE)]), hands={"right": "power"})
    outcome = run_task(HANDOVER, session, EXAMPLES, advance=False)
    assert outcome.solved, [(s.name, s.message) for s in outcome.steps]
    assert [s.name for s in outcome.steps] == ["take_can", "place_can", "place_can_release"]
    for step in outcome.steps:
        assert "crate" in {o.name for o in step.trajectory.scene.obstacles}
        assert _crate_clearance(step.trajectory, BESIDE) > 0.0, step.name
        assert constraint_violations(step.trajectory) == []
    # The file's world alone puts the can through the crate: the crate is in the way.
    alone = run_task(HANDOVER, PlanningSession("madar", hands={"right": "power"}), EXAMPLES, advance=False)
    assert _crate_clearance(alone.steps[1].trajectory, BESIDE) < -0.02


def test_a_crate_on_the_place_spot_fails_the_place_with_the_reason():
    session = PlanningSession("madar", hands={"right": "power"})
    session.set_scene(Scene(obstacles=[_crate(ON_THE_SPOT)]))
    outcome = run_task(HANDOVER, session, EXAMPLES)
    take, place = outcome.steps
    assert take.status == Status.SOLVED and _crate_clearance(take.trajectory, ON_THE_SPOT) > 0.0
    assert place.status == Status.UNREACHABLE_GOAL and place.trajectory is None
    assert "- crate (" in place.message and place.message.startswith("no valid IK solution for the goal pose")
    # The session is where the take left it: holding the can, at the take's end.
    assert [(a.name, a.arm) for a in session.checker.scene.attached] == [("coke_can", "right")]
    last = take.trajectory.points[-1].positions
    assert session.configuration == take.trajectory.start | dict(zip(take.trajectory.joint_names, last))


def test_a_task_continues_from_its_second_step_with_what_the_session_holds():
    """Take the can, find the place spot taken, move the crate, continue from place_can: the same
    steps, constraints and kind of result as the whole task, from where the take ended."""
    session = PlanningSession("madar", Scene(obstacles=[_crate(ON_THE_SPOT)]), hands={"right": "power"})
    first = run_task(HANDOVER, session, EXAMPLES)
    assert [s.status for s in first.steps] == [Status.SOLVED, Status.UNREACHABLE_GOAL]
    session.move_obstacle("crate", Pose(xyz=BESIDE))
    rest = run_task(HANDOVER, session, EXAMPLES, from_step="place_can")
    whole = run_task(HANDOVER, PlanningSession("madar", hands={"right": "power"}), EXAMPLES)
    assert rest.solved and whole.solved, [(s.name, s.message) for s in rest.steps]
    assert [(s.name, s.kind) for s in rest.steps] == [(s.name, s.kind) for s in whole.steps[1:]]
    for mine, theirs in zip(rest.steps, whole.steps[1:]):
        assert {c.spec.id for c in mine.derivation.constraints} == {c.spec.id for c in theirs.derivation.constraints}
        assert constraint_violations(mine.trajectory) == [] and _crate_clearance(mine.trajectory, BESIDE) > 0.0
    place, taken = rest.steps[0].trajectory, first.steps[0].trajectory
    assert place.start == taken.start | dict(zip(taken.joint_names, taken.points[-1].positions))
    assert place.scene.attached == whole.steps[1].trajectory.scene.attached  # held as the take held it
    # Independently: the can (URDF tool frame and its grasp) ends 4 cm above its place, to be let go.
    robot = UrdfRobot("madar", {"right": "power"})
    robot.configure(place.start | dict(zip(place.joint_names, place.points[-1].positions)))
    can = robot.pose("right_tool") * pin.SE3(place.scene.attached[0].grasp.matrix())
    assert np.allclose(can.translation, (0.45, 0.75, 0.785 + 0.04), atol=5e-3)
    assert [o.name for o in session.checker.scene.obstacles if o.name == "coke_can"] == ["coke_can"]
    assert session.checker.scene.attached == []  # placed and let go


def test_continuing_needs_a_known_step_and_configuration():
    session = PlanningSession("madar", hands={"right": "power"})
    with pytest.raises(HriplanError, match="^the session does not know where the robot is"):
        run_task(HANDOVER, session, from_step="place_can")
    session.set_configuration(posture("madar", "ready"))
    with pytest.raises(
        HriplanError, match="^task 'handover_full_can' has no step 'place'; steps: take_can, place_can$"
    ):
        run_task(HANDOVER, session, from_step="place")
    with pytest.raises(HriplanError, match="^continuing a task \\(from_step\\) needs the session"):
        run_task(HANDOVER, from_step="place_can")


def test_a_person_the_session_sees_elsewhere_is_where_the_task_takes_from():
    """Alice stands 8 cm further along x than the file says (her hand too): the take ends 8 cm
    further along x (the tool by the URDF), and the file's alice is in no scene."""
    alice = HANDOVER.humans[0]
    seen = HumanSpec(
        **alice.model_dump(include=set(HumanSpec.model_fields))
        | {"position": (alice.position[0] + 0.08, alice.position[1]), "reach": {"right": (0.13, 1.05, 1.05)}}
    )
    moved = run_task(HANDOVER, PlanningSession("madar", Scene(humans=[seen]), hands={"right": "power"}), EXAMPLES)
    as_filed = run_task(HANDOVER, PlanningSession("madar", hands={"right": "power"}), EXAMPLES)
    assert moved.solved and as_filed.solved
    assert [h.position for h in moved.steps[0].trajectory.scene.humans] == [seen.position]
    robot = UrdfRobot("madar", {"right": "power"})

    def take_end(outcome) -> np.ndarray:
        take = outcome.steps[0].trajectory
        robot.configure(take.start | dict(zip(take.joint_names, take.points[-1].positions)))
        return robot.pose("right_tool").translation.copy()

    assert np.allclose(take_end(moved) - take_end(as_filed), (0.08, 0.0, 0.0), atol=2e-3)
