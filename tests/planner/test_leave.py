"""The leave phase (planner/leave.py) through the session API: a start inside a person's S_0 or
a keep-out volume first moves out, coming closer to no one, then the motion plans from there; a
start with no way out is one line. Re-checked apart from the planner: URDF meshes and coal
(tests/independent.py), S_0 from the ISO/TS 15066 formula with the ontology's values written here.

Before: every such start failed "start is in collision: ... keep-out:..." or "start is inside a
person's minimum separation of ISO/TS 15066 (the robot would have to stand still)"."""

import functools
import math
import re

import numpy as np
import pytest

from hriplan import HriplanError
from hriplan.cli.solve import solve_problem_file
from hriplan.planner.constraints.spec import BoxConstraint, FrameRef, SphereConstraint
from hriplan.planner.motion import JointTarget
from hriplan.planner.options import PlanOptions
from hriplan.planner.problem import PlanningProblem
from hriplan.planner.session import PlanningSession
from hriplan.planner.trajectory import load_trajectory
from hriplan.robots.descriptions.registry import posture
from hriplan.robots.human import HumanSpec
from hriplan.robots.scene import Scene
from hriplan.robots.spatial import Pose
from hriplan.safety.approach import ApproachMonitor
from hriplan.safety.policy import default_policy
from hriplan.service import jobs
from hriplan.service.schemas import PlanResponse
from independent import UrdfRobot, constraint_violations, person_distances

READY = posture("madar", "ready")
HOME = {j: v for j, v in posture("madar", "home").items() if j.startswith("right_")}
# A bystander 0.65 m in front of the waiting right hand (at about (0.25, 0.6, 1.0)), facing it.
KIM = HumanSpec(name="kim", position=(0.25, 1.25), yaw=-math.pi / 2)
BYSTANDER_S0 = 1.6 * (0.1 + 0.2) + 0.0 + 0.05 + 0.02  # v_h (T_r + T_s) + C + Z_d + Z_r


@functools.cache
def kim_session() -> PlanningSession:
    return PlanningSession("madar", Scene(humans=[KIM]), hands={"right": "power"})


@functools.cache
def leave_home():
    return kim_session().plan(READY, JointTarget(values=HOME), group="right_arm", safety=default_policy("madar", [KIM]))


def test_a_start_inside_a_bystanders_s0_leaves_then_plans_from_where_it_left():
    result = leave_home()
    assert result.solved and result.leave is not None, result.message
    leave, motion = result.leave, result.trajectory
    d = person_distances(leave, "kim")
    assert d[0] < BYSTANDER_S0 < d[-1]  # from inside her S_0 to outside it
    assert np.diff(d).min() > -1e-5  # no link comes closer at any written point (spline: 10 um)
    end = dict(zip(leave.joint_names, leave.points[-1].positions))
    assert max(abs(motion.start[j] - v) for j, v in end.items()) < 1e-9  # the motion starts where it left
    assert constraint_violations(leave) == [] and constraint_violations(motion) == []
    # the motion after it keeps her S_0 on the meshes too (the planner's zones: S_0 + 5 mm on capsules)
    assert person_distances(motion, "kim").min() > BYSTANDER_S0 - 0.01


def test_the_monitor_lets_a_part_inside_s0_move_away_and_refuses_it_moving_closer():
    session, leave = kim_session(), leave_home().leave
    q0 = session.robot.configuration(leave.start)
    monitor = ApproachMonitor(session.robot, session.checker, default_policy("madar", [KIM]), "right_arm", q0)
    x0, x1 = (np.array(p.positions) for p in leave.points[:2])
    away = (x1 - x0) / np.abs(x1 - x0).max()
    (sample,) = monitor.samples(x0, away)
    # the binding pair is inside her S_0 (allowed speed 0) and moves away: no error, not stopped
    assert sample.body_separation < BYSTANDER_S0 and sample.allowed == 0.0 and sample.approach < 0.0
    with pytest.raises(HriplanError, match=r"inside the minimum protective separation 0\.550 m .*stand still there"):
        monitor.samples(x0, -away)


def keep_out_box(robot, ahead: float = 0.12) -> BoxConstraint:
    """A 30 cm keep-out box centred `ahead` m in front of the waiting right hand, no one near."""
    hand = robot.frame_pose("right_tool", robot.configuration(READY))[:3, 3]
    return BoxConstraint(
        id="keep_out_box",
        joints=robot.group_joints("right_arm"),
        target_link="right_tool",
        frame=FrameRef(offset=Pose(xyz=tuple(hand + [0.0, ahead, 0.0]))),
        region="outside",
        keep_out_all_links=True,
        size=(0.3, 0.3, 0.3),
    )


@pytest.mark.parametrize("ahead", [0.12, 0.0])
def test_a_keep_out_box_the_hand_is_in_with_no_one_near_is_left_and_the_motion_keeps_it(ahead):
    # 0.12: the fingers reach into it; 0.0: the hand at its centre, each part nearest another face
    # (before the relaxed step: "every motion of right_arm away comes closer")
    session = PlanningSession("madar", Scene(), hands={"right": "power"})
    box = keep_out_box(session.robot, ahead)
    session.set_constraints([box])
    result = session.plan(READY, JointTarget(values=HOME), group="right_arm")
    assert result.solved and result.leave is not None, result.message
    urdf, frame = UrdfRobot("madar", {"right": "power"}), box.frame.offset.matrix()
    depth = []
    for point in result.leave.points:
        urdf.configure(dict(result.leave.start) | dict(zip(result.leave.joint_names, point.positions)))
        depth.append(urdf.surface_distance(box, frame, "")[0])
    assert depth[0] < 0.0 < depth[-1], (depth[0], depth[-1])  # from inside the box to outside it
    assert constraint_violations(result.trajectory) == []  # then every link stays out of it


def test_the_service_answers_the_leave_phase_with_the_trajectory_that_starts_where_it_ends():
    robot = PlanningSession("madar", Scene(), hands={"right": "power"}).robot
    problem = PlanningProblem(
        robot="madar",
        hands={"right": "power"},
        constraints={"constraints": [keep_out_box(robot)]},
        group="right_arm",
        start=READY,
        goal=JointTarget(values=HOME),
        options=PlanOptions(seed=1),
    )
    body, _ = jobs.solve({"problem": problem.model_dump(mode="json")})
    answer = PlanResponse.model_validate_json(body)
    assert answer.solved and answer.leave is not None, answer.message
    end = dict(zip(answer.leave.joint_names, answer.leave.points[-1].positions))
    assert max(abs(answer.trajectory.start[j] - v) for j, v in end.items()) < 1e-9
    assert answer.leave.start["right_elbow_joint"] == READY["right_elbow_joint"]


def test_a_start_with_no_way_out_is_refused_in_one_line_naming_the_volume_and_how_deep():
    # a keep-out sphere around the LEFT hand while the right arm plans: nothing it does gets out
    session = PlanningSession("madar", Scene(), hands={"right": "power"})
    robot = session.robot
    left = robot.frame_pose("left_tool", robot.configuration(READY))[:3, 3]
    sphere = SphereConstraint(
        id="keep_out_left",
        joints=robot.group_joints("right_arm"),
        target_link="right_tool",
        frame=FrameRef(offset=Pose(xyz=tuple(left))),
        region="outside",
        keep_out_all_links=True,
        radius=0.1,
    )
    session.set_constraints([sphere])
    result = session.plan(READY, JointTarget(values=HOME), group="right_arm")
    assert result.status == "invalid_start" and result.leave is None and "\n" not in result.message
    found = re.fullmatch(
        r"the start is inside a keep-out volume: (left_\w+) in keep-out:keep_out_left by (0\.\d{3}) m, "
        r"which right_arm does not move",
        result.message,
    )
    assert found, result.message
    # independently: that link's URDF meshes are inside the sphere, about as deep as said
    urdf = UrdfRobot("madar", {"right": "power"})
    urdf.configure(READY)
    depth, _ = urdf.surface_distance(sphere, sphere.frame.offset.matrix(), "left_")
    assert 0.0 < -depth < 0.1 and abs(-depth - float(found[2])) < 0.03, (depth, found[2])


def test_solve_writes_the_leave_phase_beside_the_trajectory(tmp_path, capsys):
    problem = PlanningProblem(
        name="kim_at_the_hand",
        robot="madar",
        hands={"right": "power"},
        scene=Scene(humans=[KIM]),
        group="right_arm",
        start=READY,
        goal=JointTarget(values=HOME),
        options=PlanOptions(seed=1),
    )
    (tmp_path / "p.json").write_text(problem.model_dump_json())
    assert solve_problem_file(tmp_path / "p.json", tmp_path / "out.json", None, False) == 0
    said = capsys.readouterr().out.splitlines()
    leave = load_trajectory(tmp_path / "out.leave.json")
    motion = load_trajectory(tmp_path / "out.json")
    assert said[0].startswith("kim_at_the_hand: the start lay in a keep-out volume or a person's minimum separation")
    assert said[0].endswith(f"coming closer to no one (written to {tmp_path / 'out.leave.json'})")
    d = person_distances(leave, "kim")
    assert d[0] < BYSTANDER_S0 < d[-1] and np.diff(d).min() > -1e-5
    end = dict(zip(leave.joint_names, leave.points[-1].positions))
    assert max(abs(motion.start[j] - v) for j, v in end.items()) < 1e-9
