"""Import a Kautham problem file: robot, obstacles, constraints, controls and query.

Kautham (the seed framework, iocroblab/kautham) describes constraints inside `<Robot>`.
Differences handled here:
- `<Joint name=...>` names the joint's CHILD LINK; hriplan names joints. Link names of other
  descriptions of the robot (Kautham's `right_hand_base_link`) are the robot's link aliases.
- `<Origin rpy=...>` was built by Kautham as Rx(r) Ry(p) Rz(y), not the URDF convention; the
  import keeps the geometry Kautham used by converting to a quaternion (`rpy="urdf"` reads it
  the URDF way instead, for files written with that convention in mind).
- Orientation targets are relative to the robot base link; dynamic tolerance is
  `<Tolerance value variable="true" gradient>`.
- The query's normalised controls become joint angles through the `<Controls>` file
  (controls.py), found like Kautham finds files: next to the problem, then in the models
  folders. Without one, each control names a joint (or its link) directly.
- The robot's `<Home>` places it in Kautham's world; the imported problem keeps the robot at
  the origin and expresses the world in that Home frame (obstacles and world-frame volumes
  move by the inverse of Home), so every relative pose is Kautham's.
- Obstacles are URDF files from the models folders (obstacles.py); one whose file is not found
  is skipped with a warning, and constraints referring to it keep its `<Home>` frame; a
  malformed one is an error.
"""

from __future__ import annotations

import math
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Literal

import numpy as np
import pinocchio as pin

from hriplan import HriplanError
from hriplan.formats.kautham.controls import ControlSet, implicit_controls, read_controls
from hriplan.formats.kautham.obstacles import load_obstacle_model
from hriplan.formats.kautham.reader import Reader, find_file
from hriplan.planner.constraints.binding import check_groups
from hriplan.planner.constraints.spec import VOLUME_TYPES, ConstraintSet, FrameRef, OrientationConstraint
from hriplan.planner.motion import JointTarget
from hriplan.planner.options import PlanOptions
from hriplan.planner.problem import PlanningProblem
from hriplan.robots.descriptions.registry import description_of, robot_name
from hriplan.robots.model import ROBOT_NAMES, Robot, load_robot
from hriplan.robots.scene import Obstacle, Scene
from hriplan.robots.spatial import Pose

TYPES = ("arm_orientation", *VOLUME_TYPES)
# Kautham's UR5 and MADAR joints span +-2 pi (used when Kautham's robot URDF is not at hand).
KAUTHAM_RANGE = (-2.0 * math.pi, 2.0 * math.pi)
Warn = Callable[[str], None]


def _kautham_rpy(r: float, p: float, y: float) -> np.ndarray:
    return pin.rpy.rpyToMatrix(r, 0, 0) @ pin.rpy.rpyToMatrix(0, p, 0) @ pin.rpy.rpyToMatrix(0, 0, y)


def _origin(reader: Reader, el: ET.Element | None, where: str, rpy: str) -> Pose:
    if el is None:
        return Pose()
    xyz = tuple(reader.floats(el.get("xyz", "0 0 0"), 3, where))
    if el.get("quat_xyzw") is not None:
        quat = reader.floats(el.get("quat_xyzw"), 4, where)
        try:
            return Pose(xyz=xyz, quat_xyzw=tuple(quat))
        except ValueError as exc:
            raise reader.fail(f"{where}: {exc.errors()[0]['msg']}") from None
    angles = reader.floats(el.get("rpy", "0 0 0"), 3, where)
    if rpy == "urdf":
        return Pose(xyz=xyz, rpy=tuple(angles))
    return Pose.from_matrix(
        np.block([[_kautham_rpy(*angles), np.array(xyz)[:, None]], [np.zeros((1, 3)), np.ones((1, 1))]])
    )


def _pose(se3: pin.SE3) -> Pose:
    return Pose.from_matrix(se3.homogeneous)


def _joint_by_name(robot: Robot) -> dict[str, str]:
    """Joint names and Kautham's names for joints (each joint's child link) -> joint name."""
    names = {joint: joint for joint in robot.joint_names}
    for frame in robot.model.frames:
        if frame.type == pin.FrameType.BODY and robot.model.names[frame.parentJoint] in names:
            parent_joint_frame = robot.model.frames[frame.parentFrame]
            if parent_joint_frame.type == pin.FrameType.JOINT:
                names[frame.name] = robot.model.names[frame.parentJoint]
    return names


def _joints(reader: Reader, robot: Robot, constraint: ET.Element, where: str) -> list[str]:
    by_name = _joint_by_name(robot)
    joints = []
    for el in constraint.findall("Joint"):
        name = reader.attr(el, "name", where)
        if robot.link_name(name) not in by_name:
            raise reader.fail(f"{where}: robot {robot.name!r} has no link or joint {name!r}")
        joints.append(by_name[robot.link_name(name)])
    if not joints:
        raise reader.fail(f"{where}: no <Joint> elements")
    return joints


# Constraint frames: Kautham's obstacle name -> (hriplan entity, pose that re-bases an offset).
Frames = dict[str, tuple[str, pin.SE3]]


def _constraint(reader: Reader, robot: Robot, el: ET.Element, frames: Frames, world: pin.SE3, rpy: str):
    cid = reader.attr(el, "id", "<Constraint>")
    kind = reader.attr(el, "type", f"constraint {cid!r}")
    where = f"constraint {cid!r}"
    if kind not in TYPES:
        raise reader.fail(f"{where}: unknown type {kind!r}; Kautham types: {', '.join(TYPES)}")
    target_link = robot.link_name(reader.attr(reader.child(el, "TargetLink", where), "name", where))
    if not robot.model.existFrame(target_link):
        raise reader.fail(f"{where}: robot {robot.name!r} has no link {target_link!r}")
    enabled_el = el.find("Enabled")
    status = "true" if enabled_el is None else enabled_el.get("status", "true").lower()
    if status not in ("true", "false"):
        raise reader.fail(f"{where}: <Enabled status> must be true or false, got {status!r}")
    common = {
        "id": cid,
        "joints": _joints(reader, robot, el, where),
        "target_link": target_link,
        "enabled": status == "true",
    }
    if kind == "arm_orientation":
        q = reader.child(el, "TargetOrientation", where)
        quat = [reader.number(q, k, where) for k in ("qx", "qy", "qz", "qw")]
        axes = el.find("FreeMovementAxes")
        free = [a for a in "xyz" if axes is not None and axes.get(a, "false").lower() == "true"]
        tol = el.find("Tolerance")
        variable = tol is not None and tol.get("variable", "false").lower() == "true"
        try:
            return OrientationConstraint(
                **common,
                target=Pose(quat_xyzw=tuple(quat)),
                free_axes=free,
                frame=FrameRef(entity="robot_base"),
                tolerance=reader.number(tol, "value", where, 0.1) if tol is not None else 0.1,
                tolerance_gradient=reader.number(tol, "gradient", where, 0.0) if variable else 0.0,
            )
        except ValueError as exc:
            raise reader.fail(f"{where}: {exc.errors()[0]['msg']}") from None
    params = reader.child(el, "GeometricParams", where)
    region_el = el.find("AllowedVolumeRegion")
    region_name = region_el.get("name", "Inner") if region_el is not None else "Inner"
    if region_name not in ("Inner", "Outer"):
        raise reader.fail(f"{where}: AllowedVolumeRegion must be Inner or Outer, got {region_name!r}")
    ref = el.find("ReferenceFrame")
    entity, rebase = "world", world
    if ref is not None and ref.get("entity"):
        if ref.get("entity") not in frames:
            raise reader.fail(f"{where}: reference entity {ref.get('entity')!r} is not an obstacle of the problem")
        entity, rebase = frames[ref.get("entity")]
    offset = _origin(reader, el.find("Origin"), where, rpy)
    frame = FrameRef(entity=entity, offset=_pose(rebase * offset.se3()))
    names = {"box": ("length", "width", "height"), "sphere": ("radius",)}.get(kind, ("radius", "height"))
    values = [reader.number(params, n, where) for n in names]
    dims = {"size": tuple(values)} if kind == "box" else dict(zip(names, values))
    try:
        return VOLUME_TYPES[kind](
            **common, **dims, frame=frame, region="inside" if region_name == "Inner" else "outside"
        )
    except ValueError as exc:
        raise reader.fail(f"{where}: {exc.errors()[0]['msg']}") from None


def _obstacles(
    reader: Reader, root: ET.Element, folders: list[Path], world: pin.SE3, warn: Warn
) -> tuple[list[Obstacle], Frames]:
    """Scene obstacles in the robot's Home frame, and the frame each Kautham obstacle name stands for."""
    obstacles: list[Obstacle] = []
    frames: Frames = {}
    for el in root.iter("Obstacle"):
        urdf = reader.attr(el, "obstacle", "<Obstacle>")
        kautham_name = el.find("KauthamName")
        name = el.get("name") or (kautham_name.get("name") if kautham_name is not None else None)
        where = f"obstacle {name or urdf!r}"
        home = world * reader.home(el.find("Home"), where).se3()
        scale = reader.number(el, "scale", where, 1.0)
        found = find_file(urdf, folders)
        model = load_obstacle_model(found, scale) if found is not None else None
        name = name or (model.name if model else Path(urdf).stem)
        taken = {o.name for o in obstacles} | set(frames)
        base, k = name, 1
        while name in taken:
            k += 1
            name = f"{base}_{k}"
        if model is None:
            warn(
                f"{reader.path}: skipped obstacle {name!r}: {urdf} is not in {', '.join(map(str, folders))} (give its models folder with --models)"
            )
            frames[name] = ("world", home)
            continue
        for i, (shape, placement) in enumerate(model.pieces):
            obstacles.append(
                Obstacle(name=name if i == 0 else f"{name}_part{i + 1}", shape=shape, pose=_pose(home * placement))
            )
        frames[name] = (name, model.pieces[0][1].inverse())
    return obstacles, frames


def _kautham_ranges(
    reader: Reader, robot: Robot, robot_el: ET.Element, folders: list[Path], warn: Warn
) -> tuple[dict[str, tuple[float, float]], set[str]]:
    """Joint ranges of Kautham's robot model (normalised controls span them) and its names."""
    by_name = _joint_by_name(robot)
    ranges = {joint: KAUTHAM_RANGE for joint in robot.joint_names}
    names = {robot.name}
    kautham_name = robot_el.find("KauthamName")
    if kautham_name is not None and kautham_name.get("name"):
        names.add(kautham_name.get("name"))
    found = find_file(robot_el.get("robot", ""), folders) if robot_el.get("robot") else None
    if found is None:
        warn(
            f"{reader.path}: Kautham's robot file {robot_el.get('robot')!r} is not in {', '.join(map(str, folders))}: "
            "controls are normalised over +-2 pi, the range of Kautham's UR5 and MADAR joints"
        )
    else:
        robot_file = Reader(found)
        urdf = robot_file.parse()
        names.add(urdf.get("name", robot.name))
        for joint in urdf.iter("joint"):
            child, limit = joint.find("child"), joint.find("limit")
            link = robot.link_name(child.get("link", "")) if child is not None else ""
            if limit is not None and link in by_name:
                where = f"joint {joint.get('name')!r}"
                ranges[by_name[link]] = (
                    robot_file.number(limit, "lower", where),
                    robot_file.number(limit, "upper", where),
                )
    return ranges, names


def _controls(reader: Reader, root: ET.Element, folders: list[Path], robot: Robot, robot_names: set[str]) -> ControlSet:
    by_name = _joint_by_name(robot)
    el = root.find("Controls")
    if el is None or not el.get("robot"):
        return implicit_controls(by_name)
    found = find_file(el.get("robot"), folders)
    if found is None:
        raise reader.fail(f"controls file {el.get('robot')!r} not found (looked in {', '.join(map(str, folders))})")
    return read_controls(found, robot_names, lambda link: by_name.get(robot.link_name(link)))


def _query_controls(
    reader: Reader, root: ET.Element, controls: ControlSet
) -> tuple[dict[str, float], dict[str, float]]:
    """Control values (init, goal) by control name: `<RobotControl>` elements or `<Init>`/`<Goal>` lists."""
    query = root.find(".//Queries/Query")
    if query is None:
        raise reader.fail("no <Query> in <Planner><Queries>")
    init: dict[str, float] = {}
    goal: dict[str, float] = {}
    elements = query.findall("RobotControl")
    if elements:
        for el in elements:
            name = reader.attr(el, "name", "<RobotControl>")
            if name not in controls.controls:
                raise reader.fail(f"query: control {name!r} is not in {controls.source}")
            if name in init:
                raise reader.fail(f"query: control {name!r} is set twice")
            init[name] = reader.number(el, "init", f"query control {name!r}")
            goal[name] = reader.number(el, "goal", f"query control {name!r}")
    elif query.find("Init") is not None and query.find("Goal") is not None:
        if not controls.complete:
            raise reader.fail("query: <Init>/<Goal> lists need a <Controls> file to name their values")
        names = list(controls.controls)
        for values, tag in ((init, "Init"), (goal, "Goal")):
            values.update(
                zip(
                    names,
                    reader.floats(query.find(tag).text or "", len(names), f"query <{tag}> ({len(names)} controls)"),
                )
            )
    else:
        raise reader.fail("query: no <RobotControl> elements and no <Init>/<Goal>")
    missing = [name for name in controls.controls if name not in init]
    if controls.complete and missing:
        raise reader.fail(f"query sets {len(init)} of {len(controls.controls)} controls; missing: {', '.join(missing)}")
    for values, key in ((init, "init"), (goal, "goal")):
        for name, c in values.items():
            if not 0.0 <= c <= 1.0:
                raise reader.fail(f"query control {name!r}: {key} {c} is not a normalised value in [0, 1]")
    return init, goal


def _configuration(
    reader: Reader,
    robot: Robot,
    controls: ControlSet,
    values: dict[str, float],
    key: str,
    ranges: dict[str, tuple[float, float]],
) -> dict[str, float]:
    """Every joint's angle for the query's control values (joints no control moves keep their offset)."""
    result = {}
    for joint, p in controls.normalised(values, robot.joint_names).items():
        if not -1e-9 <= p <= 1.0 + 1e-9:
            raise reader.fail(f"query {key}: {joint} gets the normalised value {p:.4f}, outside [0, 1]")
        low, high = ranges[joint]
        q = low + p * (high - low)
        i = robot.model.joints[robot.model.getJointId(joint)].idx_q
        lower, upper = robot.model.lowerPositionLimit[i], robot.model.upperPositionLimit[i]
        if not lower - 1e-9 <= q <= upper + 1e-9:
            raise reader.fail(
                f"query {key}: {joint} = {q:.3f} rad is outside hriplan's limits [{lower:.3f}, {upper:.3f}]"
            )
        result[joint] = float(np.clip(q, lower, upper))
    return result


def _robot_name(reader: Reader, robot_el: ET.Element) -> str:
    kautham_name = robot_el.find("KauthamName")
    names = [
        robot_el.get("name"),
        kautham_name.get("name") if kautham_name is not None else None,
        Path(robot_el.get("robot", "")).stem,
    ]
    for text in filter(None, names):
        for known in ROBOT_NAMES:
            if known in text.lower():
                return known
    raise reader.fail(f"robot {next(filter(None, names), '')!r} is not supported ({', '.join(ROBOT_NAMES)})")


def import_kautham(
    path: str | Path,
    rpy: Literal["kautham", "urdf"] = "kautham",
    models: Sequence[str | Path] = (),
    warn: Warn | None = None,
    robot: str | None = None,
) -> PlanningProblem:
    """A hriplan planning problem from a Kautham problem file (robot madar or ur5, or `robot`:
    a robot name or a robot file, for a Kautham robot hriplan has no description of, such as
    the hand-less MADAR of Kautham's madar_dual_arm demo).

    `models`: folders with Kautham's robot, obstacle and controls files (Kautham's
    demos/models), searched after the problem's own folder. `warn` receives one line per thing
    left out (default: Python warnings)."""
    path = Path(path)
    warn = warn or (lambda message: warnings.warn(message, stacklevel=3))
    reader = Reader(path)
    root = reader.parse()
    robot_el = root if root.tag == "Robot" else root.find(".//Robot")
    if robot_el is None:
        raise reader.fail("no <Robot> element")
    folders = [path.parent, *(Path(m) for m in models)]
    description = description_of(robot_name(robot) if robot else _robot_name(reader, robot_el))
    robot = load_robot(description.name)
    world = reader.home(robot_el.find("Home"), "robot <Home>").se3().inverse()
    obstacles, frames = _obstacles(reader, root, folders, world, warn)
    constraints = [_constraint(reader, robot, el, frames, world, rpy) for el in robot_el.findall("Constraint")]
    try:
        check_groups([c for c in constraints if c.enabled])
    except HriplanError as exc:
        raise reader.fail(str(exc)) from None
    ranges, robot_names = _kautham_ranges(reader, robot, robot_el, folders, warn)
    controls = _controls(reader, root, folders, robot, robot_names)
    init_controls, goal_controls = _query_controls(reader, root, controls)
    start = _configuration(reader, robot, controls, init_controls, "init", ranges)
    goal = _configuration(reader, robot, controls, goal_controls, "goal", ranges)
    moving = [j for j in robot.joint_names if abs(start[j] - goal[j]) > 1e-12]
    group = _group(robot, [*moving, *[j for c in constraints if c.enabled for j in c.joints]])
    # Kautham's `_Range` is its RRTConnect's step; hriplan's default CBiRRT, which plans inside
    # the tolerance bands these problems are about, extends by `delta` and takes no range.
    options = PlanOptions(time_limit=_parameter(reader, root, "_Max Planning Time", 10.0))
    return PlanningProblem(
        name=path.stem,
        description=f"imported from the Kautham problem {path.name} (world = the robot's <Home> frame)",
        robot=robot.name,
        robot_file=description.source,
        scene=Scene(obstacles=obstacles),
        constraints=ConstraintSet(constraints=constraints),
        group=group,
        start=start,
        goal=JointTarget(values={j: goal[j] for j in robot.group_joints(group)}),
        options=options,
    )


def _group(robot: Robot, joints: list[str]) -> str:
    """The smallest joint group that contains every joint the problem moves or constrains."""
    for group in sorted(robot.groups, key=lambda g: len(robot.groups[g])):
        if set(joints) <= set(robot.groups[group]):
            return group
    return robot.default_group


def _parameter(reader: Reader, root: ET.Element, name: str, default: float) -> float:
    for el in root.iter("Parameter"):
        if el.get("name") == name and el.text:
            return reader.floats(el.text, 1, f"planner parameter {name!r}")[0]
    return default
