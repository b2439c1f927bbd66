"""Write the glass benchmark's problems (benchmarks/glass/*.json): carry a glass upright, free to
spin about vertical, on three robots in four kinds of scene.

Run: PYTHONPATH=src .venv/bin/python benchmarks/glass/make_glass.py [--out DIR]

The files are the data, this script is how they were made. Each problem holds a glass (a
cylinder, radius 3.5 cm, height 10 cm) in its tool, keeps the glass's axis within a small
tolerance of vertical (0.05 rad; 0.01 rad for the `_tight` ones) and leaves the spin about that
axis free: start and goal differ in it. Start and goal are joint configurations found by
hriplan's IK; the script refuses to write a problem whose start or goal is not valid by the
tests' own geometry (tests/independent.py: pinocchio on the URDF, coal on its meshes): the
glass's tilt within the tolerance, no link or the glass touching an obstacle, no link inside a
person's keep-out volume.

World frames (metres, z up): the UR5 stands at the origin and reaches along +x at
shoulder_pan 0; the Panda (examples/robots/panda.yaml) stands on a 0.5 m pedestal at the origin
and faces +x; MADAR stands at the origin and faces +y (its right arm towards +x), so its tables,
shelves and people are at +y.
"""

from __future__ import annotations

import argparse
import functools
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from hriplan.planner.constraints import spec
from hriplan.planner.motion import JointTarget
from hriplan.planner.problem import PlanningProblem
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.descriptions.registry import load_robot_file
from hriplan.robots.human import HumanSpec
from hriplan.robots.ik import solve_ik
from hriplan.robots.model import Robot, load_robot
from hriplan.robots.scene import AttachedObject, Box, Cylinder, Obstacle, Scene
from hriplan.robots.spatial import Pose

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from independent import UrdfRobot, check_path  # noqa: E402  (the tests' geometry, apart from hriplan's)

PANDA_FILE = "../../examples/robots/panda.yaml"  # relative to this folder, as the files name it
GLASS = Cylinder(radius=0.035, height=0.10)
TIGHT, LOOSE = 0.01, 0.05


@dataclass(frozen=True)
class Arm:
    """How a robot holds the glass: the robot, its arm and tool frame, the tool's orientation
    that holds the glass upright (at spin 0), the tool axis along the glass, and the grasp."""

    robot: str
    arm: str
    tool: str
    upright: np.ndarray
    axis: str
    grasp: Pose
    posture: dict[str, float]
    hands: dict[str, str] = field(default_factory=dict)
    group: str | None = None


DOWN = pin.utils.rpyToMatrix(math.pi, 0.0, 0.0)  # tool z pointing down
# MADAR's tool: y along a held cylinder, z the approach; upright = y up, approach +y (forward).
MADAR_UP = np.column_stack([(-1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, 1.0, 0.0)])
UR5 = Arm(
    "ur5",
    "arm",
    "tool",
    DOWN,
    "z",
    Pose(xyz=(0.0, 0.0, 0.06)),  # hanging below the tool, its axis along the tool's z
    {"shoulder_lift_joint": -1.2, "elbow_joint": 1.5, "wrist_1_joint": -1.9, "wrist_2_joint": -1.57},
)
PANDA = Arm(
    "franka_panda",
    "arm",
    "panda_hand_tcp",
    DOWN,
    "z",
    Pose(xyz=(0.0, 0.0, 0.02)),  # between the fingertips, held from above
    {"panda_joint2": -0.3, "panda_joint4": -2.2, "panda_joint6": 1.9, "panda_joint7": 0.785398},
    {"arm": "closed"},
)
MADAR_RIGHT = Arm(
    "madar",
    "right",
    "right_tool",
    MADAR_UP,
    "y",
    Pose(rpy=(-math.pi / 2, 0.0, 0.0)),  # the glass's axis (z) along the tool's y
    {"left_shoulder_lift_joint": -2.2, "left_elbow_joint": 1.2},
    {"right": "power"},
    "right_arm",
)
MADAR_LEFT = Arm(
    "madar",
    "left",
    "left_tool",
    MADAR_UP,
    "y",
    Pose(rpy=(-math.pi / 2, 0.0, 0.0)),
    {"right_shoulder_lift_joint": -2.2, "right_elbow_joint": 1.2},
    {"left": "power"},
    "left_arm",
)


def box(name: str, size, xyz) -> Obstacle:
    return Obstacle(name=name, shape=Box(size=size), pose=Pose(xyz=xyz))


def can(name: str, radius: float, height: float, x: float, y: float, floor: float) -> Obstacle:
    """A cylinder standing on the surface at height `floor`."""
    return Obstacle(name=name, shape=Cylinder(radius=radius, height=height), pose=Pose(xyz=(x, y, floor + height / 2)))


def shelf(x: float, y: float, levels: list[float], width: float, depth: float, along_x: bool) -> list[Obstacle]:
    """Boards at the given heights (their top faces) and two side walls; the open side faces the
    robot (along x: the boards span y and their open side faces -x; else they span x, open to -y)."""
    size = (depth, width, 0.02) if along_x else (width, depth, 0.02)
    boards = [box(f"board_{i}", size, (x, y, z - 0.01)) for i, z in enumerate(levels)]
    height = levels[-1] - levels[0]
    middle = (levels[0] + levels[-1]) / 2
    wall = (depth, 0.02, height) if along_x else (0.02, depth, height)
    sides = (
        [(x, y - width / 2 - 0.01), (x, y + width / 2 + 0.01)]
        if along_x
        else [(x - width / 2 - 0.01, y), (x + width / 2 + 0.01, y)]
    )
    return boards + [box(f"side_{i}", wall, (sx, sy, middle)) for i, (sx, sy) in enumerate(sides)]


@dataclass(frozen=True)
class Glass:
    """One problem: where the glass starts and ends (tool position, spin about vertical)."""

    name: str
    description: str
    arm: Arm
    obstacles: list[Obstacle]
    start: tuple[float, float, float]
    start_spin: float
    goal: tuple[float, float, float]
    goal_spin: float
    tolerance: float = LOOSE
    people: list[tuple[HumanSpec, str]] = field(default_factory=list)
    keep_out: float = 0.45  # radius of the keep-out cylinder around each person


def tool_pose(arm: Arm, xyz, spin: float) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, :3] = pin.utils.rpyToMatrix(0.0, 0.0, spin) @ arm.upright
    pose[:3, 3] = xyz
    return pose


def ik(robot: Robot, checker: CollisionChecker, arm: Arm, target: np.ndarray, base: np.ndarray) -> np.ndarray:
    group = robot.arm_group(arm.arm)
    result = solve_ik(
        robot,
        arm.arm,
        target,
        base_q=base,
        reference=robot.group_values(base, group),
        is_valid=lambda q: not checker.in_collision(q),
        why_invalid=lambda q: [f"collides: {c.a} - {c.b}" for c in checker.contacts(q)],
    )
    if not result.success:
        raise SystemExit(f"IK failed at {np.round(target[:3, 3], 3).tolist()}: {result.message}")
    return robot.configuration(result.q, group, base=base)


def problem(g: Glass) -> PlanningProblem:
    """The planning problem, its start and goal found by IK (the goal nearest the start)."""
    arm = g.arm
    robot = load_robot(arm.robot, arm.hands or None)
    joints = robot.group_joints(robot.arm_group(arm.arm))
    glass = AttachedObject(name="glass", shape=GLASS, arm=arm.arm, grasp=arm.grasp)
    humans = [person for person, _ in g.people]
    scene = Scene(obstacles=g.obstacles, attached=[glass], humans=humans)
    checker = CollisionChecker(robot, scene)
    constraints = [
        spec.OrientationConstraint(
            id="glass_upright",
            joints=joints,
            target_link=arm.tool,
            target=Pose.from_matrix(tool_pose(arm, (0.0, 0.0, 0.0), 0.0)),
            free_axes=[arm.axis],
            tolerance=g.tolerance,
        )
    ]
    constraints += [
        spec.CylinderConstraint(
            id=f"keep_out_{person.name}",
            joints=joints,
            target_link=arm.tool,
            region="outside",
            radius=g.keep_out,
            height=2.0,
            keep_out_all_links=True,
            frame=spec.FrameRef(entity=f"{person.name}/base"),
        )
        for person in humans
    ]
    base = robot.configuration(arm.posture)
    start = ik(robot, checker, arm, tool_pose(arm, g.start, g.start_spin), base)
    goal = ik(robot, checker, arm, tool_pose(arm, g.goal, g.goal_spin), start)
    return PlanningProblem(
        name=g.name,
        description=g.description,
        robot=robot.name,
        hands=arm.hands,
        scene=scene,
        constraints=spec.ConstraintSet(constraints=constraints),
        group=arm.group,
        start=dict(zip(robot.joint_names, start)),
        goal=JointTarget(values=dict(zip(joints, robot.group_values(goal, robot.arm_group(arm.arm))))),
        options={"time_limit": 10.0},
        roles={person.name: role for person, role in g.people},
    )


@functools.cache
def urdf_robot(name: str, hands: tuple[tuple[str, str], ...]) -> UrdfRobot:
    return UrdfRobot(name, dict(hands))


def refuse_invalid(p: PlanningProblem) -> None:
    """Stop unless the start and the goal are valid by the tests' own geometry."""
    joints = list(p.goal.values)
    robot = urdf_robot(p.robot, tuple(p.hands.items()))
    for what, values in (("start", [p.start[j] for j in joints]), ("goal", list(p.goal.values.values()))):
        check = check_path(p, joints, np.array([values]), robot=robot)
        tolerances = {c.id: c.tolerance for c in p.constraints.constraints if c.type == "orientation"}
        breaches = check.breaches(tolerances)
        if breaches:
            raise SystemExit(f"{p.name}: the {what} is not valid: {'; '.join(breaches)}")


def file_text(p: PlanningProblem) -> str:
    """The problem as a file: a robot from a robot file named by its path relative to this folder."""
    text = p.model_dump_json(indent=1, exclude={"robot_file"})
    return text.replace(f'"robot": "{PANDA.robot}"', f'"robot": "{PANDA_FILE}"') + "\n"


def ur5_problems() -> list[Glass]:
    table = box("table", (1.2, 1.6, 0.04), (0.3, 0.0, -0.07))
    clutter = [
        table,
        can("bottle_1", 0.04, 0.20, 0.45, 0.0, -0.05),
        can("bottle_2", 0.035, 0.25, 0.30, 0.25, -0.05),
        box("crate", (0.2, 0.15, 0.2), (0.55, -0.25, 0.05)),
        box("books", (0.12, 0.25, 0.3), (0.2, -0.45, 0.10)),
        can("jug", 0.06, 0.22, 0.6, 0.3, -0.05),
    ]
    shelves = [table, *shelf(0.62, 0.0, [-0.05, 0.30, 0.65], 0.9, 0.3, along_x=True)]
    person = HumanSpec(name="pat", position=(0.75, 0.95), yaw=-math.pi / 2)
    behind = HumanSpec(name="sam", position=(-0.9, -0.4), yaw=0.0)
    return [
        Glass(
            "ur5_open",
            "UR5 carries a glass across open space",
            UR5,
            [table],
            (0.45, -0.3, 0.3),
            0.0,
            (0.2, 0.45, 0.45),
            1.2,
        ),
        Glass(
            "ur5_open_tight",
            "UR5 carries a glass round its base, 0.01 rad tolerance",
            UR5,
            [table],
            (0.5, 0.2, 0.2),
            0.5,
            (-0.15, 0.5, 0.35),
            -1.0,
            TIGHT,
        ),
        Glass(
            "ur5_shelf_up",
            "UR5 moves a glass from a shelf's lower level to its middle level",
            UR5,
            shelves,
            (0.52, -0.2, 0.07),
            0.0,
            (0.52, 0.2, 0.42),
            0.8,
        ),
        Glass(
            "ur5_shelf_down_tight",
            "UR5 moves a glass from the shelf's middle level down to the lower level, 0.01 rad",
            UR5,
            shelves,
            (0.52, 0.25, 0.42),
            -0.4,
            (0.52, -0.15, 0.07),
            0.6,
            TIGHT,
        ),
        Glass(
            "ur5_clutter",
            "UR5 carries a glass between bottles, a crate and a jug on a table",
            UR5,
            clutter,
            (0.35, -0.15, 0.12),
            0.0,
            (0.45, 0.2, 0.15),
            1.5,
        ),
        Glass(
            "ur5_clutter_far",
            "UR5 carries a glass from beside the books to behind the jug",
            UR5,
            clutter,
            (0.25, -0.25, 0.15),
            0.3,
            (0.45, 0.45, 0.12),
            -0.9,
        ),
        Glass(
            "ur5_person",
            "UR5 carries a glass past a person standing at the table's side (keep-out, speed limits)",
            UR5,
            [table],
            (0.5, -0.3, 0.25),
            0.0,
            (0.35, 0.45, 0.3),
            1.0,
            people=[(person, "Collaborator")],
        ),
        Glass(
            "ur5_person_behind",
            "UR5 carries a glass across its front while a bystander stands behind it",
            UR5,
            [table],
            (0.45, 0.35, 0.2),
            0.0,
            (0.45, -0.35, 0.2),
            -1.2,
            people=[(behind, "Bystander")],
        ),
    ]


def panda_problems() -> list[Glass]:
    top = 0.45
    table = box("table", (0.8, 1.4, 0.04), (0.65, 0.0, top - 0.02))
    clutter = [
        table,
        can("bottle_1", 0.04, 0.30, 0.5, 0.0, top),
        can("bottle_2", 0.035, 0.25, 0.35, 0.3, top),
        box("crate", (0.18, 0.15, 0.2), (0.6, -0.25, top + 0.1)),
        can("jug", 0.06, 0.22, 0.65, 0.25, top),
    ]
    shelves = [table, *shelf(0.7, 0.0, [top, 0.92, 1.5], 0.9, 0.3, along_x=True)]
    person = HumanSpec(name="pat", position=(0.9, 0.95), yaw=-math.pi / 2)
    return [
        Glass(
            "panda_open",
            "Panda carries a glass across open space",
            PANDA,
            [table],
            (0.45, -0.3, 0.75),
            0.0,
            (0.35, 0.4, 0.9),
            1.2,
        ),
        Glass(
            "panda_open_tight",
            "Panda carries a glass across open space, 0.01 rad tolerance",
            PANDA,
            [table],
            (0.5, 0.3, 0.7),
            0.3,
            (0.4, -0.35, 0.85),
            -0.9,
            TIGHT,
        ),
        Glass(
            "panda_shelf_up",
            "Panda moves a glass from a shelf's lower level to its middle level",
            PANDA,
            shelves,
            (0.6, -0.2, top + 0.12),
            0.0,
            (0.6, 0.2, 1.04),
            0.7,
        ),
        Glass(
            "panda_clutter",
            "Panda carries a glass between bottles, a crate and a jug on a table",
            PANDA,
            clutter,
            (0.4, -0.15, top + 0.14),
            0.0,
            (0.5, 0.18, top + 0.16),
            1.3,
        ),
        Glass(
            "panda_clutter_tight",
            "Panda carries a glass past the bottles, 0.01 rad tolerance",
            PANDA,
            clutter,
            (0.35, 0.15, top + 0.15),
            0.5,
            (0.35, -0.4, top + 0.15),
            -0.5,
            TIGHT,
        ),
        Glass(
            "panda_person",
            "Panda carries a glass past a person standing at the table's side (keep-out, speed limits)",
            PANDA,
            [table],
            (0.5, -0.3, 0.7),
            0.0,
            (0.4, 0.4, 0.75),
            1.0,
            people=[(person, "Collaborator")],
        ),
    ]


def madar_problems() -> list[Glass]:
    top = 0.72
    table = box("table", (1.2, 0.45, 0.04), (0.0, 0.675, top - 0.02))  # clear of the base (y < 0.4)
    clutter = [
        table,
        can("bottle_1", 0.04, 0.25, 0.3, 0.5, top),
        can("bottle_2", 0.035, 0.25, -0.15, 0.78, top),
        box("crate", (0.18, 0.12, 0.2), (-0.3, 0.75, top + 0.1)),
        can("jug", 0.06, 0.22, 0.0, 0.8, top),
    ]
    shelves = [table, *shelf(0.1, 0.75, [top, 1.05, 1.4], 1.2, 0.25, along_x=False)]
    person = HumanSpec(name="pat", position=(0.1, 1.6), yaw=-math.pi / 2)
    side = HumanSpec(name="sam", position=(1.3, 0.6), yaw=math.pi)
    return [
        Glass(
            "madar_open",
            "MADAR's right arm carries a glass across open space in front of it",
            MADAR_RIGHT,
            [table],
            (0.35, 0.55, 1.0),
            0.0,
            (0.05, 0.65, 1.1),
            0.8,
        ),
        Glass(
            "madar_left_open_tight",
            "MADAR's left arm carries a glass in front of it, 0.01 rad tolerance",
            MADAR_LEFT,
            [table],
            (-0.35, 0.55, 1.0),
            0.0,
            (-0.1, 0.7, 0.95),
            -0.8,
            TIGHT,
        ),
        Glass(
            "madar_shelf_up",
            "MADAR's right arm moves a glass from a shelf's lower level to its middle level",
            MADAR_RIGHT,
            shelves,
            (0.35, 0.68, top + 0.12),
            0.0,
            (0.1, 0.68, 1.17),
            0.6,
        ),
        Glass(
            "madar_clutter",
            "MADAR's right arm carries a glass between bottles, a crate and a jug",
            MADAR_RIGHT,
            clutter,
            (0.38, 0.6, top + 0.12),
            0.0,
            (0.15, 0.5, top + 0.2),
            1.0,
        ),
        Glass(
            "madar_person",
            "MADAR's right arm carries a glass while a person stands across the table (keep-out, speed limits)",
            MADAR_RIGHT,
            [table],
            (0.4, 0.6, 0.95),
            0.0,
            (0.12, 0.58, 1.0),
            1.0,
            people=[(person, "Collaborator")],
        ),
        Glass(
            "madar_person_side",
            "MADAR's right arm carries a glass towards a person standing at its right, 0.01 rad",
            MADAR_RIGHT,
            [table],
            (0.05, 0.6, 1.0),
            0.0,
            (0.5, 0.55, 1.0),
            -0.6,
            TIGHT,
            people=[(side, "Supervisor")],
        ),
    ]


def glass_problems() -> list[PlanningProblem]:
    """Every problem of the family, each checked valid at its start and goal."""
    load_robot_file(HERE / PANDA_FILE)
    problems = [problem(g) for g in ur5_problems() + panda_problems() + madar_problems()]
    for p in problems:
        refuse_invalid(p)
    return problems


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=HERE, help="folder to write to (default: this one)")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for p in glass_problems():
        (args.out / f"{p.name}.json").write_text(file_text(p))
        print("wrote", args.out / f"{p.name}.json")


if __name__ == "__main__":
    main()
