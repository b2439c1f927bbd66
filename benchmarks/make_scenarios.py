"""Write the planner benchmark scenarios (benchmarks/scenarios/*.json).

Starts and goals are found with hriplan's own IK so that they satisfy the constraints; the
files are the data, this script is how they were made: `python benchmarks/make_scenarios.py`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin

from hriplan.planner.constraints import spec
from hriplan.planner.motion import JointTarget
from hriplan.planner.problem import PlanningProblem
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.human import HumanSpec
from hriplan.robots.ik import solve_ik, solve_two_arms
from hriplan.robots.model import Robot, load_robot
from hriplan.robots.scene import Box, Cylinder, Obstacle, Scene, table
from hriplan.robots.spatial import Pose

OUT = Path(__file__).parent / "scenarios"
# MADAR tool: y is the axis of a held cylinder; upright = tool y along world z, approach (z) +y.
MADAR_UPRIGHT = Pose.from_matrix(
    np.block(
        [
            [np.column_stack([(-1.0, 0, 0), (0, 0, 1.0), (0, 1.0, 0)]), np.zeros((3, 1))],
            [np.zeros((1, 3)), np.ones((1, 1))],
        ]
    )
)


def _pose(rotation: np.ndarray, xyz) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3], t[:3, 3] = rotation, xyz
    return t


def _ik(
    robot: Robot, checker: CollisionChecker, arm: str, target: np.ndarray, base: np.ndarray, ref=None, free=()
) -> np.ndarray:
    group = robot.arm_group(arm)
    res = solve_ik(
        robot,
        arm,
        target,
        base_q=base,
        reference=ref if ref is not None else robot.group_values(base, group),
        free_axes=free,
        is_valid=lambda q: not checker.in_collision(q),
    )
    if not res.success:
        raise SystemExit(f"scenario IK failed: {res.message}")
    return robot.configuration(res.q, group, base=base)


def _both_arms(
    robot: Robot, checker: CollisionChecker, right: np.ndarray, left: np.ndarray, base: np.ndarray
) -> np.ndarray:
    q = solve_two_arms(
        robot, ("right", right, ("y",)), ("left", left, ("y",)), base, lambda full: not checker.in_collision(full)
    )
    if q is None:
        raise SystemExit("scenario IK failed: no valid pair of arm configurations")
    return q


def _upright(joints: list[str], link: str, axis: str, target: Pose, **tolerance) -> spec.OrientationConstraint:
    """Keep the tool's orientation (a held cup upright), free to spin about `axis`."""
    tolerance = tolerance or {"tolerance": 0.1}
    return spec.OrientationConstraint(
        id="upright", joints=joints, target_link=link, free_axes=[axis], target=target, **tolerance
    )


def _box(name: str, joints: list[str], link: str, size, centre) -> spec.BoxConstraint:
    """Keep the tool inside an axis-aligned box centred at `centre` (world frame)."""
    return spec.BoxConstraint(
        id=name, joints=joints, target_link=link, size=size, frame=spec.FrameRef(offset=Pose(xyz=centre))
    )


def _ur5_block_scene(humans: list[HumanSpec] = ()) -> Scene:
    """Scenarios (a) and (e): a table under the UR5 and a block to carry the cup over."""
    return Scene(
        obstacles=[
            table(position=(0.5, 0.0), size=(0.6, 1.2, 0.04), top=-0.05),
            Obstacle(name="block", shape=Box(size=(0.3, 0.08, 0.35)), pose=Pose(xyz=(0.45, 0.0, 0.125))),
        ],
        humans=list(humans),
    )


def ur5_upright_box() -> PlanningProblem:
    robot = load_robot("ur5")
    scene = _ur5_block_scene([HumanSpec(name="human", position=(1.2, 0.0), yaw=np.pi)])
    checker = CollisionChecker(robot, scene)
    joints = robot.group_joints()
    down = Pose(rpy=(np.pi, 0.0, 0.0))
    constraints = [
        _upright(joints, "tool", "z", down),
        _box("workspace", joints, "tool", (0.8, 1.2, 0.6), (0.45, 0.0, 0.3)),
    ]
    home = robot.configuration([0.0, -1.2, 1.5, -1.9, -1.57, 0.0])
    start = _ik(robot, checker, "arm", _pose(down.rotation(), (0.45, -0.3, 0.12)), home)
    goal = _ik(robot, checker, "arm", _pose(down.rotation(), (0.45, 0.3, 0.12)), start)
    return _problem(
        "a_ur5_upright_box",
        "UR5 carries an upright cup over a block, inside a workspace box",
        robot,
        scene,
        constraints,
        start,
        goal,
        roles={"human": "Collaborator"},
    )


def madar_handover() -> PlanningProblem:
    hands = {"right": "power"}
    robot = load_robot("madar", hands)
    hand_point = (0.05, 1.05, 1.05)
    person = HumanSpec(name="receiver", position=(0.0, 1.45), yaw=-np.pi / 2, reach={"right": hand_point})
    scene = Scene(obstacles=[table(position=(0.45, 0.85), size=(0.5, 0.5, 0.04), top=0.72)], humans=[person])
    checker = CollisionChecker(robot, scene)
    joints = robot.group_joints("right_arm")
    # Approach cone: apex at the receiver's palm, axis along the receiver's front (to the robot).
    cone_frame = spec.FrameRef(entity="receiver/right_hand", offset=Pose(rpy=(0.0, np.pi / 2, 0.0)))
    constraints = [
        _upright(joints, "right_tool", "y", MADAR_UPRIGHT),
        _box("shared_workspace", joints, "right_tool", (1.0, 0.8, 0.8), (0.1, 0.75, 1.0)),
        spec.ConeConstraint(
            id="approach_cone", joints=joints, target_link="right_tool", radius=0.3, height=0.55, frame=cone_frame
        ),
    ]
    base = robot.configuration({"left_shoulder_lift_joint": -2.2, "left_elbow_joint": 1.2})
    up = MADAR_UPRIGHT.rotation()
    # The goal (at the hand) first, then the start in the same IK branch.
    goal = _ik(
        robot,
        checker,
        "right",
        _pose(up, (hand_point[0], hand_point[1] - 0.19, hand_point[2])),
        base,
        ref=np.array([0.8, 0.2, -0.3, -0.3, 0.6, -0.4]),
    )
    start = _ik(robot, checker, "right", _pose(up, (0.25, 0.6, 1.0)), goal)
    return _problem(
        "b_madar_handover",
        "MADAR's right arm brings a full can to a receiver's hand",
        robot,
        scene,
        constraints,
        start,
        goal,
        "right_arm",
        hands=hands,
        roles={"receiver": "Receiver"},
    )


def madar_peg_in_hole() -> PlanningProblem:
    hands = {"right": "power", "left": "power"}
    robot = load_robot("madar", hands)
    supervisor = HumanSpec(name="supervisor", position=(1.3, 0.9), yaw=np.pi)
    scene = Scene(
        obstacles=[
            table(position=(0.0, 0.85), size=(0.9, 0.5, 0.04), top=0.72),
            Obstacle(name="hole_block", shape=Cylinder(radius=0.05, height=0.1), pose=Pose(xyz=(0.0, 0.85, 0.79))),
        ],
        humans=[supervisor],
    )
    checker = CollisionChecker(robot, scene)
    # Pegs are held along the tool y axis: aligned = tool y along world -z, approach (z) forward.
    down = MADAR_UPRIGHT.rotation() @ np.diag([-1.0, -1.0, 1.0])
    constraints = []
    for side in ("right", "left"):
        joints = robot.group_joints(f"{side}_arm")
        constraints.append(
            spec.OrientationConstraint(
                id=f"{side}_alignment",
                joints=joints,
                target_link=f"{side}_tool",
                free_axes=["y"],
                target=Pose.from_matrix(_pose(down, (0, 0, 0))),
                tolerance=0.05,
                tolerance_gradient=0.3,
            )
        )
        constraints.append(
            spec.CylinderConstraint(
                id=f"{side}_keep_out_supervisor",
                joints=joints,
                target_link=f"{side}_tool",
                region="outside",
                radius=0.45,
                height=2.0,
                keep_out_all_links=True,
                frame=spec.FrameRef(entity="supervisor/base"),
            )
        )
    base = robot.configuration({})
    start = _both_arms(robot, checker, _pose(down, (0.35, 0.6, 1.05)), _pose(down, (-0.35, 0.6, 1.05)), base)
    goal = _both_arms(robot, checker, _pose(down, (0.06, 0.85, 0.98)), _pose(down, (-0.06, 0.85, 0.98)), start)
    return _problem(
        "c_madar_peg_in_hole",
        "MADAR brings two pegs above holes beside a supervising person",
        robot,
        scene,
        constraints,
        start,
        goal,
        "both_arms",
        hands=hands,
        roles={"supervisor": "Supervisor"},
    )


def madar_left_arm() -> PlanningProblem:
    """The left arm alone, the right arm folded at its side (not at zero, which is in the torso)."""
    hands = {"left": "power"}
    robot = load_robot("madar", hands)
    scene = Scene(
        obstacles=[
            table(position=(-0.35, 0.8), size=(0.6, 0.5, 0.04), top=0.72),
            Obstacle(name="box", shape=Box(size=(0.08, 0.3, 0.16)), pose=Pose(xyz=(-0.35, 0.8, 0.82))),
        ]
    )
    checker = CollisionChecker(robot, scene)
    joints = robot.group_joints("left_arm")
    constraints = [
        _upright(joints, "left_tool", "y", MADAR_UPRIGHT),
        _box("workspace", joints, "left_tool", (0.9, 0.8, 0.8), (-0.3, 0.7, 1.1)),
    ]
    base = robot.configuration(
        {
            "right_shoulder_lift_joint": -2.2,
            "right_elbow_joint": 1.2,
            "left_shoulder_lift_joint": -2.2,
            "left_elbow_joint": 1.2,
        }
    )
    up = MADAR_UPRIGHT.rotation()
    start = _ik(robot, checker, "left", _pose(up, (-0.15, 0.6, 1.0)), base)
    goal = _ik(robot, checker, "left", _pose(up, (-0.55, 0.65, 1.0)), start)
    return _problem(
        "g_madar_left_arm",
        "MADAR's left arm carries an upright can past a box; the right arm stays folded",
        robot,
        scene,
        constraints,
        start,
        goal,
        "left_arm",
        hands=hands,
    )


def madar_one_arm_holds() -> PlanningProblem:
    """Both arms planned, the left arm's goal is its start: it must hold its pose, not wander."""
    hands = {"right": "power", "left": "power"}
    robot = load_robot("madar", hands)
    scene = Scene(
        obstacles=[
            table(position=(0.0, 0.85), size=(1.0, 0.5, 0.04), top=0.72),
            Obstacle(name="divider", shape=Box(size=(0.04, 0.4, 0.3)), pose=Pose(xyz=(0.25, 0.75, 0.89))),
        ]
    )
    checker = CollisionChecker(robot, scene)
    up = MADAR_UPRIGHT.rotation()
    start = _both_arms(
        robot, checker, _pose(up, (0.45, 0.65, 1.0)), _pose(up, (-0.3, 0.65, 0.95)), robot.configuration({})
    )
    goal = _ik(robot, checker, "right", _pose(up, (0.1, 0.65, 0.95)), start, free=("y",))
    return _problem(
        "i_madar_one_arm_holds",
        "Both arms planned: the right arm moves past a divider, the left arm holds its pose",
        robot,
        scene,
        [],
        start,
        goal,
        "both_arms",
        hands=hands,
    )


# -- band families (d, e, f, h): the tolerance bands and volumes used along the whole path -------
UR5_DOWN = Pose(rpy=(np.pi, 0.0, 0.0))
UR5_HOME = (0.0, -1.2, 1.5, -1.9, -1.57, 0.0)


def _tilted_down(angle: float) -> np.ndarray:
    """The UR5 tool pointing down, tilted by `angle` about world y (its wrist leans to -x)."""
    return pin.utils.rpyToMatrix(0.0, -angle, 0.0) @ UR5_DOWN.rotation()


def _problem(
    name: str,
    description: str,
    robot: Robot,
    scene: Scene,
    constraints: list,
    start: np.ndarray,
    goal: np.ndarray,
    group: str | None = None,
    **extra,
) -> PlanningProblem:
    """A problem from joint-space start and goal; the goal gives the planned group's joints only."""
    return PlanningProblem(
        name=name,
        description=description,
        robot=robot.name,
        scene=scene,
        constraints=spec.ConstraintSet(constraints=constraints),
        start=dict(zip(robot.joint_names, start)),
        goal=JointTarget(values=dict(zip(robot.group_joints(group), robot.group_values(goal, group)))),
        **({"group": group} if group else {}),
        **extra,
    )


def ur5_tilt_past_post(dynamic: bool) -> PlanningProblem:
    """(d) The tool slides along a 1 cm rail past a post standing 4-5 cm from it: upright, the
    wrist hits the post at every point of the rail there; tilted 0.2-0.4 rad away it passes."""
    robot = load_robot("ur5")
    scene = Scene(
        obstacles=[
            table(position=(0.5, 0.0), size=(0.6, 1.2, 0.04), top=-0.05),
            Obstacle(name="post", shape=Box(size=(0.1, 0.3, 0.8)), pose=Pose(xyz=(0.55, 0.0, 0.3))),
        ]
    )
    checker = CollisionChecker(robot, scene)
    joints = robot.group_joints()
    tolerance = {"tolerance": 0.05, "tolerance_gradient": 1.0} if dynamic else {"tolerance": 0.5}
    constraints = [
        _upright(joints, "tool", "z", UR5_DOWN, **tolerance),
        _box("rail", joints, "tool", (0.01, 0.8, 0.3), (0.455, 0.0, 0.2)),
    ]
    home = robot.configuration(UR5_HOME)
    start = _ik(robot, checker, "arm", _pose(UR5_DOWN.rotation(), (0.455, -0.35, 0.15)), home)
    goal = _ik(robot, checker, "arm", _pose(UR5_DOWN.rotation(), (0.455, 0.35, 0.15)), start)
    kind = "dynamic" if dynamic else "static"
    return _problem(
        f"d_ur5_tilt_past_post_{kind}",
        f"UR5 tool on a rail past a post: passes only tilted within its {kind} tolerance",
        robot,
        scene,
        constraints,
        start,
        goal,
    )


def ur5_tilted_start() -> PlanningProblem:
    """(e) Scenario (a) with a dynamic tolerance (0.05 rad + 0.5 rad/m), starting tilted 0.25 rad:
    inside its tolerance 0.6 m from the goal (0.35 rad), far outside the 0.05 rad at the goal."""
    robot = load_robot("ur5")
    scene = _ur5_block_scene()
    checker = CollisionChecker(robot, scene)
    joints = robot.group_joints()
    constraints = [
        _upright(joints, "tool", "z", UR5_DOWN, tolerance=0.05, tolerance_gradient=0.5),
        _box("workspace", joints, "tool", (0.8, 1.2, 0.6), (0.45, 0.0, 0.3)),
    ]
    home = robot.configuration(UR5_HOME)
    start = _ik(robot, checker, "arm", _pose(_tilted_down(0.25), (0.45, -0.3, 0.12)), home)
    goal = _ik(robot, checker, "arm", _pose(UR5_DOWN.rotation(), (0.45, 0.3, 0.12)), start)
    return _problem(
        "e_ur5_tilted_start",
        "UR5 starts tilted inside its dynamic tolerance and ends upright over a block",
        robot,
        scene,
        constraints,
        start,
        goal,
    )


def madar_volumes_only() -> PlanningProblem:
    """(f) The empty-can handover: scenario (b) without the upright constraint (cone + box only)."""
    problem = madar_handover()
    volumes = [c for c in problem.constraints.constraints if c.type != "orientation"]
    return problem.model_copy(
        update={
            "name": "f_madar_volumes_only",
            "description": "MADAR hands an empty can over: approach cone and shared workspace only",
            "constraints": spec.ConstraintSet(constraints=volumes),
        }
    )


def ur5_cluttered_cabinet() -> PlanningProblem:
    """(h) From a cluttered table into a cabinet's middle compartment, the tool upright."""
    robot = load_robot("ur5")
    board = lambda name, size, xyz: Obstacle(name=name, shape=Box(size=size), pose=Pose(xyz=xyz))  # noqa: E731
    scene = Scene(
        obstacles=[
            table(position=(0.55, 0.0), size=(0.7, 1.4, 0.04), top=-0.05),
            board("cabinet_left", (0.4, 0.02, 0.9), (0.7, -0.3, 0.4)),
            board("cabinet_right", (0.4, 0.02, 0.9), (0.7, 0.3, 0.4)),
            board("cabinet_back", (0.02, 0.62, 0.9), (0.91, 0.0, 0.4)),
            board("cabinet_shelf", (0.4, 0.6, 0.02), (0.7, 0.0, 0.25)),
            board("cabinet_top", (0.4, 0.62, 0.02), (0.7, 0.0, 0.86)),
            Obstacle(name="can_1", shape=Cylinder(radius=0.04, height=0.2), pose=Pose(xyz=(0.3, -0.15, 0.05))),
            Obstacle(name="can_2", shape=Cylinder(radius=0.04, height=0.25), pose=Pose(xyz=(0.25, 0.25, 0.075))),
            board("crate", (0.15, 0.2, 0.15), (0.45, -0.55, 0.025)),
        ]
    )
    checker = CollisionChecker(robot, scene)
    joints = robot.group_joints()
    constraints = [_upright(joints, "tool", "z", UR5_DOWN)]
    home = robot.configuration(UR5_HOME)
    start = _ik(robot, checker, "arm", _pose(UR5_DOWN.rotation(), (0.3, -0.35, 0.15)), home)
    goal = _ik(robot, checker, "arm", _pose(UR5_DOWN.rotation(), (0.65, 0.05, 0.33)), start)
    return _problem(
        "h_ur5_cluttered_cabinet",
        "UR5 carries a cup upright from a cluttered table into a cabinet compartment",
        robot,
        scene,
        constraints,
        start,
        goal,
    )


BAND_FAMILIES = (
    lambda: ur5_tilt_past_post(False),
    lambda: ur5_tilt_past_post(True),
    ur5_tilted_start,
    madar_volumes_only,
    ur5_cluttered_cabinet,
)

SCENARIOS = (ur5_upright_box, madar_handover, madar_peg_in_hole, *BAND_FAMILIES, madar_left_arm, madar_one_arm_holds)

if __name__ == "__main__":
    OUT.mkdir(exist_ok=True)
    for make in SCENARIOS:
        problem = make()
        (OUT / f"{problem.name}.json").write_text(problem.model_dump_json(indent=1, exclude_defaults=False))
        print("wrote", problem.name)
