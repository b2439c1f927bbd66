"""A third robot the code was not written for: Rethink's Baxter from example-robot-data's URDF
(tests/data/robots/baxter.yaml: two 7-joint arms by base and tip links, its electric grippers,
numeric IK; its SRDF is pinocchio's, not MoveIt's: see the file). Its tool frames agree with
pinocchio built here from the URDF file, and plans of each arm and of both arms at once (joint
goals, tool-pose goals, the gripper kept pointing down, a person nearby) are re-checked point by
point by this file's own forward kinematics, the URDF's limits and tests/independent.py."""

from __future__ import annotations

import math
import time
from pathlib import Path

import coal
import example_robot_data
import numpy as np
import pinocchio as pin
import pytest

from hriplan.planner.constraints.spec import OrientationConstraint
from hriplan.planner.motion import JointTarget, ToolTarget
from hriplan.planner.options import PlanOptions
from hriplan.planner.session import PlanningSession
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.descriptions.registry import load_robot_file
from hriplan.robots.human import HumanSpec
from hriplan.robots.ik import solve_ik
from hriplan.robots.model import load_robot
from hriplan.robots.robot_geometry import robot_parts
from hriplan.robots.scene import Scene
from hriplan.robots.spatial import Pose
from independent import UrdfFile, constraint_violations, person_distances, trajectory_speed_margins

FILE = Path(__file__).parents[1] / "data" / "robots" / "baxter.yaml"
URDF = Path(example_robot_data.getModelPath("baxter_description/urdf/baxter.urdf")) / (
    "baxter_description/urdf/baxter.urdf"
)
BASE_Z = 0.93  # the file's base_pose: the base link 0.93 m above the floor, not turned
ARMS = {"right": "right_gripper", "left": "left_gripper"}  # each arm's tip link, the tool frame
TIMES: dict[str, float] = {}  # planning times, printed with -s

pytestmark = pytest.mark.usefixtures("module_robot_registry")


class Urdf(UrdfFile):
    """Baxter's URDF as this test reads it, its base lifted by BASE_Z as the robot file stands it."""

    def pose(self, frame: str, values: dict[str, float]) -> np.ndarray:
        pose = super().pose(frame, values)
        pose[2, 3] += BASE_Z
        return pose


@pytest.fixture(scope="module")
def baxter():
    return load_robot(load_robot_file(FILE).name)


@pytest.fixture(scope="module")
def urdf():
    return Urdf(URDF)


def ready(robot) -> dict[str, float]:
    return dict(zip(robot.joint_names, robot.configuration(robot.description.postures["ready"]).tolist()))


def check_trajectory(trajectory, urdf: Urdf, start: dict[str, float]) -> np.ndarray:
    """The URDF's position and velocity limits at every point, the start where asked; the positions."""
    positions = np.array([p.positions for p in trajectory.points])
    times = np.array([p.time_from_start for p in trajectory.points])
    limits = np.array([urdf.limits[j] for j in trajectory.joint_names])
    assert np.all(positions >= limits[:, 0] - 1e-9) and np.all(positions <= limits[:, 1] + 1e-9)
    steps = np.abs(np.diff(positions, axis=0)) / np.diff(times)[:, None]
    assert np.all(steps <= limits[:, 2] * 1.01)  # no jump faster than the URDF velocity
    assert positions[0] == pytest.approx([start[j] for j in trajectory.joint_names], abs=1e-9)
    return positions


def end_pose(trajectory, urdf: Urdf, arm: str) -> np.ndarray:
    values = dict(trajectory.start) | dict(zip(trajectory.joint_names, trajectory.points[-1].positions))
    return urdf.pose(ARMS[arm], values)


def planned(session, start, goal, group, **kwargs):
    began = time.perf_counter()
    result = session.plan(start, goal, PlanOptions(seed=1, time_limit=10.0), group=group, **kwargs)
    assert result.solved, result.message
    TIMES[f"{group} {goal.type}"] = time.perf_counter() - began
    print(
        f"baxter {group} {goal.type}: planned in {result.motion.planning_time:.2f} s, {TIMES[f'{group} {goal.type}']:.2f} s with timing"
    )
    return result.trajectory


def test_baxter_is_two_arms_with_mirrored_gripper_fingers(baxter, urdf):
    assert baxter.group_joints("right") == [f"right_{j}" for j in ("s0", "s1", "e0", "e1", "w0", "w1", "w2")]
    assert baxter.group_joints("left") == [f"left_{j}" for j in ("s0", "s1", "e0", "e1", "w0", "w1", "w2")]
    assert baxter.default_group == "all_arms" and len(baxter.group_joints("all_arms")) == 14
    assert {arm: baxter.tool_frame(arm) for arm in ARMS} == ARMS
    # Was: every listed finger took the open value, so each right finger (a mimic, multiplier -1,
    # limits [-0.0208, 0]) stood outside its URDF limits, both fingers on one side.
    fingers = dict(baxter.finger_values)
    for side in "rl":
        driver, follower = f"{side}_gripper_l_finger_joint", f"{side}_gripper_r_finger_joint"
        assert urdf.mimic[follower] == (driver, -1.0)
        assert fingers[driver] == urdf.limits[driver][1] and fingers[follower] == -fingers[driver]
        lower, upper, _ = urdf.limits[follower]
        assert lower <= fingers[follower] <= upper


def test_parts_contain_the_urdf_cylinders(baxter):
    """Was: a URDF <cylinder> gave no points to fit (Baxter's arm links are all cylinders) and the
    capsule fit stopped on a failed SVD. Each capsule holds every point of its link's collision
    cylinders' surfaces, sampled here (200 around, 3 heights)."""
    model, geometry = baxter.model, baxter.collision_meshes
    parts = {p.name: p for p in robot_parts(baxter)}
    angle = np.linspace(0.0, 2.0 * np.pi, 200, endpoint=False)
    checked = 0
    for geom in geometry.geometryObjects:
        shape = geom.geometry
        if type(shape).__name__ != "Cylinder":
            continue
        link = model.frames[geom.parentFrame].name
        part = parts[link]
        assert part.joint == geom.parentJoint
        r, h = shape.radius, shape.halfLength
        rim = np.column_stack([r * np.cos(angle), r * np.sin(angle)])
        points = np.vstack([np.column_stack([rim, np.full(len(angle), z)]) for z in (-h, 0.0, h)])
        points = points @ geom.placement.rotation.T + geom.placement.translation  # in the joint frame
        local = (points - part.placement.translation) @ part.placement.rotation
        half = part.geometry.halfLength
        along = np.clip(local[:, 2], -half, half)
        distance = np.linalg.norm(local - np.column_stack([0 * along, 0 * along, along]), axis=1)
        assert distance.max() <= part.geometry.radius + 1e-9, link
        checked += 1
    assert checked >= 20


@pytest.mark.parametrize("arm", list(ARMS))
def test_tool_frames_equal_forward_kinematics_of_the_urdf(baxter, urdf, arm):
    lower, upper = baxter.limits(arm)
    for values in np.random.default_rng(0).uniform(lower, upper, (30, len(lower))):
        named = dict(zip(baxter.group_joints(arm), values))
        ours = baxter.frame_pose(baxter.tool_frame(arm), values, arm)
        assert np.abs(ours - urdf.pose(ARMS[arm], named)).max() < 1e-9


@pytest.mark.parametrize("arm", list(ARMS))
def test_numeric_ik_reaches_its_targets_by_the_urdf(baxter, urdf, arm):
    lower, upper = baxter.limits(arm)
    failures = 0
    for values in np.random.default_rng(1).uniform(lower, upper, (50, len(lower))):
        target = urdf.pose(ARMS[arm], dict(zip(baxter.group_joints(arm), values)))
        result = solve_ik(baxter, arm, target)
        if not result.success:
            failures += 1
            continue
        solved = dict(zip(baxter.group_joints(arm), result.q))
        assert np.abs(urdf.pose(ARMS[arm], solved) - target).max() < 1e-5
        assert all(urdf.limits[j][0] <= v <= urdf.limits[j][1] for j, v in solved.items())
    assert failures <= 1


def test_a_joint_goal_of_the_right_arm(baxter, urdf):
    start = ready(baxter)
    goal = JointTarget(values={"right_s0": 0.6, "right_s1": -0.2, "right_e1": 1.4, "right_w1": 0.8})
    trajectory = planned(PlanningSession(str(FILE)), start, goal, "right")
    assert trajectory.robot == "baxter" and trajectory.joint_names == baxter.group_joints("right")
    positions = check_trajectory(trajectory, urdf, start)
    last = dict(zip(trajectory.joint_names, positions[-1]))
    assert [last[j] for j in goal.values] == pytest.approx(list(goal.values.values()), abs=1e-6)


def test_a_tool_pose_goal_of_the_left_arm(baxter, urdf):
    start = ready(baxter)
    # A pose the left arm reaches (the URDF's forward kinematics of a configuration), IK'd by hriplan.
    target = urdf.pose("left_gripper", start | {"left_s0": 0.5, "left_s1": -0.3, "left_e1": 1.2, "left_w0": 0.4})
    goal = ToolTarget(arm="left", pose=Pose.from_matrix(target))
    trajectory = planned(PlanningSession(str(FILE)), start, goal, "left")
    check_trajectory(trajectory, urdf, start)
    assert np.abs(end_pose(trajectory, urdf, "left") - target).max() < 1e-5


def test_the_gripper_kept_pointing_down_to_a_tool_pose(baxter, urdf):
    """The right gripper's z (its approach) within 0.2 rad of straight down at every point, spin free."""
    start = ready(baxter)
    session = PlanningSession(str(FILE))
    down = OrientationConstraint(
        id="down",
        joints=baxter.group_joints("right"),
        target_link="right_gripper",
        target=Pose(rpy=(math.pi, 0.0, 0.0)),
        free_axes=["z"],
        tolerance=0.2,
    )
    session.set_constraints([down])
    here = urdf.pose("right_gripper", start)
    target = np.diag([1.0, -1.0, -1.0, 1.0])  # z straight down
    target[:3, 3] = here[:3, 3] + (0.1, 0.3, -0.1)
    goal = ToolTarget(arm="right", pose=Pose.from_matrix(target), free_axes=["z"])
    trajectory = planned(session, start, goal, "right")
    positions = check_trajectory(trajectory, urdf, start)
    angles = []
    for x in positions:
        tool = urdf.pose("right_gripper", start | dict(zip(trajectory.joint_names, x)))
        angles.append(math.acos(np.clip(-tool[2, 2], -1.0, 1.0)))
    assert max(angles) <= 0.2 + 1e-3
    reached = end_pose(trajectory, urdf, "right")
    assert np.linalg.norm(reached[:3, 3] - target[:3, 3]) < 1e-5 and reached[2, 2] < math.cos(1e-5) * -1
    assert constraint_violations(trajectory) == []  # tests/independent.py's reading of the constraint


def test_a_motion_near_a_person_keeps_clear_and_slow(baxter, urdf):
    """A supervisor 1.8 m in front of Baxter, on its right; the right arm swings out towards her:
    ISO/TS 15066 by default, re-checked by tests/independent.py's formulas and meshes."""
    start = ready(baxter)
    sam = HumanSpec(name="sam", position=(1.8, -0.9), yaw=math.pi)
    session = PlanningSession(str(FILE), Scene(humans=[sam]), roles={"sam": "Supervisor"})
    goal = JointTarget(values={"right_s0": 0.5, "right_s1": -0.1, "right_e1": 0.6, "right_w1": 1.0})
    trajectory = planned(session, start, goal, "right")
    check_trajectory(trajectory, urdf, start)
    assert [s.person for s in trajectory.report.separation] == ["sam"]
    distances = person_distances(trajectory, "sam")
    assert distances.min() > 0.0
    speed, gap = trajectory_speed_margins(trajectory, session.policy(), 0.05, 0.95)
    assert speed >= -0.02 and gap > 0.0
    print(f"baxter near sam: closest {distances.min():.3f} m, speed margin {speed:.3f} m/s")


def test_both_arms_to_tool_poses_in_one_motion(baxter, urdf):
    start = ready(baxter)
    session = PlanningSession(str(FILE))
    targets = {
        "right": urdf.pose("right_gripper", start | {"right_s0": -0.3, "right_s1": -0.2, "right_e1": 1.0}),
        "left": urdf.pose("left_gripper", start | {"left_s0": 0.3, "left_s1": -0.2, "left_e1": 1.0}),
    }
    goals = [ToolTarget(arm=arm, pose=Pose.from_matrix(t)) for arm, t in targets.items()]
    goal = session.joint_goal(goals, start)  # IK for both arms, clear of each other
    trajectory = planned(session, start, goal, "all_arms")
    assert trajectory.joint_names == baxter.group_joints("all_arms")
    check_trajectory(trajectory, urdf, start)
    for arm, target in targets.items():
        assert np.abs(end_pose(trajectory, urdf, arm) - target).max() < 1e-5


def test_the_allowed_collision_matrix_of_baxter(baxter):
    """Was: the torso and each upper shoulder (joined through `*_arm_mount`, a link without
    geometry) were checked on meshes that always overlap, as were the covers against the links
    they cover: the ready posture and the zero configuration were in collision."""
    from hriplan.robots.acm import load_acm
    from hriplan.robots.collision import CollisionChecker

    acm = load_acm(baxter, robot_parts(baxter))
    reason = {frozenset(k.split("|")): v for k, v in acm.items()}
    for side in ARMS:
        assert reason[frozenset(("torso", f"{side}_upper_shoulder"))] == "adjacent"
        assert reason[frozenset((f"{side}_upper_elbow_visual", f"{side}_lower_elbow"))] == "user"
    checker = CollisionChecker(baxter, Scene())
    assert not checker.in_collision(baxter.configuration(baxter.description.postures["ready"]))
    assert not checker.in_collision(np.zeros(baxter.model.nq))


def test_arm_cylinders_that_overlap_in_an_aligned_pose_collide(baxter):
    """Baxter's upper shoulder and upper elbow are URDF cylinders checked as themselves (acm.MESH).
    At this elbow they overlap by 4.5 mm (coal's distance, asked independently), a pose where coal's
    GJK, asked only whether they collide, said they do not."""
    q = baxter.configuration({"left_s0": 0.3163, "left_s1": -1.3162, "left_e0": 2.0761, "left_e1": 1.3093})
    checker = CollisionChecker(baxter)
    objects = checker.geom_model.geometryObjects
    shapes = {objects[i].name: i for i in range(len(objects))}
    a, b = shapes["left_upper_shoulder (mesh)"], shapes["left_upper_elbow (mesh)"]
    pin.updateGeometryPlacements(baxter.model, baxter.data, checker.geom_model, checker.geom_data, q)
    placed = [checker.geom_data.oMg[i] for i in (a, b)]
    depth = coal.distance(
        objects[a].geometry,
        coal.Transform3s(placed[0].rotation, placed[0].translation),
        objects[b].geometry,
        coal.Transform3s(placed[1].rotation, placed[1].translation),
        coal.DistanceRequest(),
        coal.DistanceResult(),
    )
    assert depth == pytest.approx(-0.0045, abs=5e-4)
    assert checker.in_collision(q)
    assert ("left_upper_shoulder (mesh)", "left_upper_elbow (mesh)") in [(c.a, c.b) for c in checker.contacts(q)]
