"""Import a Kautham problem file: its robot's `<Constraint>` elements and its query.

Kautham (the seed framework) describes constraints inside `<Robot>`; see
shared/reference/kautham-constraints.md. Differences handled here:
- `<Joint name=...>` names the joint's CHILD LINK; hriplan names joints.
- `<Origin rpy=...>` was built by Kautham as Rx(r) Ry(p) Rz(y), not the URDF convention; the
  import keeps the geometry Kautham used by converting to a quaternion (`rpy="urdf"` reads it
  the URDF way instead, for files written with that convention in mind).
- Orientation targets are relative to the robot base link; dynamic tolerance is
  `<Tolerance value variable="true" gradient>`.
- Query values are normalised controls c in [0, 1] over Kautham's +-2 pi joint ranges:
  q = 4 pi c - 2 pi, each mapped by name (joint or child link).
- Obstacles are read from `<Obstacle name=...>` with Kautham's `<Home X Y Z WX WY WZ TH/>`
  (position, rotation axis and angle in radians), so a constraint can refer to their frames.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Literal

import numpy as np
import pinocchio as pin

from hriplan import HriplanError
from hriplan.files import read_text
from hriplan.planner.motion import JointGoal
from hriplan.planner.options import PlanOptions
from hriplan.planner.problem import PlanningProblem
from hriplan.planner.spec import (BoxConstraint, ConeConstraint, ConstraintSet, CylinderConstraint, FrameRef,
                                  OrientationConstraint, SphereConstraint)  # fmt: skip
from hriplan.robots.model import Robot, load_robot
from hriplan.robots.scene import Obstacle, Scene, Sphere
from hriplan.robots.spatial import Pose

VOLUMES = {"box": BoxConstraint, "sphere": SphereConstraint, "cylinder": CylinderConstraint, "cone": ConeConstraint}
TYPES = ("arm_orientation", *VOLUMES)
# Kautham's UR5 joints span +-2 pi: a normalised control c is the angle 4 pi c - 2 pi.
KAUTHAM_LOWER, KAUTHAM_UPPER = -2.0 * math.pi, 2.0 * math.pi


class _Reader:
    """Attribute access that names the element and the file when something is missing."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def fail(self, message: str) -> HriplanError:
        return HriplanError(f"{self.path}: {message}")

    def child(self, el: ET.Element, tag: str, where: str) -> ET.Element:
        found = el.find(tag)
        if found is None:
            raise self.fail(f"{where}: missing <{tag}>")
        return found

    def attr(self, el: ET.Element, name: str, where: str) -> str:
        value = el.get(name)
        if value is None:
            raise self.fail(f"{where}: <{el.tag}> has no attribute {name!r}")
        return value

    def floats(self, text: str, count: int, where: str) -> list[float]:
        try:
            values = [float(v) for v in text.split()]
        except ValueError:
            raise self.fail(f"{where}: {text!r} is not {count} numbers") from None
        if len(values) != count or not all(math.isfinite(v) for v in values):
            raise self.fail(f"{where}: {text!r} is not {count} finite numbers")
        return values

    def number(self, el: ET.Element, name: str, where: str, default: float | None = None) -> float:
        text = el.get(name)
        if text is None:
            if default is None:
                raise self.fail(f"{where}: <{el.tag}> has no attribute {name!r}")
            return default
        return self.floats(text, 1, where)[0]


def _kautham_rpy(r: float, p: float, y: float) -> np.ndarray:
    return pin.rpy.rpyToMatrix(r, 0, 0) @ pin.rpy.rpyToMatrix(0, p, 0) @ pin.rpy.rpyToMatrix(0, 0, y)


def _origin(reader: _Reader, el: ET.Element | None, where: str, rpy: str) -> Pose:
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
    return Pose.from_matrix(np.block([[_kautham_rpy(*angles), np.array(xyz)[:, None]], [np.zeros((1, 3)), np.ones((1, 1))]]))


def _joint_by_name(robot: Robot) -> dict[str, str]:
    """Joint names and Kautham's names for joints (each joint's child link) -> joint name."""
    names = {joint: joint for joint in robot.joint_names}
    for frame in robot.model.frames:
        if frame.type == pin.FrameType.BODY and robot.model.names[frame.parentJoint] in names:
            parent_joint_frame = robot.model.frames[frame.parentFrame]
            if parent_joint_frame.type == pin.FrameType.JOINT:
                names[frame.name] = robot.model.names[frame.parentJoint]
    return names


def _joints(reader: _Reader, robot: Robot, constraint: ET.Element, where: str) -> list[str]:
    by_name = _joint_by_name(robot)
    joints = []
    for el in constraint.findall("Joint"):
        name = reader.attr(el, "name", where)
        if name not in by_name:
            raise reader.fail(f"{where}: robot {robot.name!r} has no link or joint {name!r}")
        joints.append(by_name[name])
    if not joints:
        raise reader.fail(f"{where}: no <Joint> elements")
    return joints


def _constraint(reader: _Reader, robot: Robot, el: ET.Element, obstacles: set[str], rpy: str):  # noqa: ANN202
    cid = reader.attr(el, "id", "<Constraint>")
    kind = reader.attr(el, "type", f"constraint {cid!r}")
    where = f"constraint {cid!r}"
    if kind not in TYPES:
        raise reader.fail(f"{where}: unknown type {kind!r}; Kautham types: {', '.join(TYPES)}")
    target_link = reader.attr(reader.child(el, "TargetLink", where), "name", where)
    if not robot.model.existFrame(target_link):
        raise reader.fail(f"{where}: robot {robot.name!r} has no link {target_link!r}")
    enabled = el.find("Enabled") is None or el.find("Enabled").get("status", "true").lower() == "true"
    common = {"id": cid, "joints": _joints(reader, robot, el, where), "target_link": target_link, "enabled": enabled}
    if kind == "arm_orientation":
        q = reader.child(el, "TargetOrientation", where)
        quat = [reader.number(q, k, where) for k in ("qx", "qy", "qz", "qw")]
        axes = el.find("FreeMovementAxes")
        free = [a for a in "xyz" if axes is not None and axes.get(a, "false").lower() == "true"]
        tol = el.find("Tolerance")
        variable = tol is not None and tol.get("variable", "false").lower() == "true"
        try:
            return OrientationConstraint(
                **common, target=Pose(quat_xyzw=tuple(quat)), free_axes=free, frame=FrameRef(entity="robot_base"),
                tolerance=reader.number(tol, "value", where, 0.1) if tol is not None else 0.1,
                tolerance_gradient=reader.number(tol, "gradient", where, 0.0) if variable else 0.0,
            )  # fmt: skip
        except ValueError as exc:
            raise reader.fail(f"{where}: {exc.errors()[0]['msg']}") from None
    params = reader.child(el, "GeometricParams", where)
    region_el = el.find("AllowedVolumeRegion")
    region_name = region_el.get("name", "Inner") if region_el is not None else "Inner"
    if region_name not in ("Inner", "Outer"):
        raise reader.fail(f"{where}: AllowedVolumeRegion must be Inner or Outer, got {region_name!r}")
    ref = el.find("ReferenceFrame")
    entity = "world"
    if ref is not None and ref.get("entity"):
        entity = ref.get("entity")
        if entity not in obstacles:
            raise reader.fail(f"{where}: reference entity {entity!r} is not an obstacle of the problem")
    frame = FrameRef(entity=entity, offset=_origin(reader, el.find("Origin"), where, rpy))
    names = {"box": ("length", "width", "height"), "sphere": ("radius",)}.get(kind, ("radius", "height"))
    values = [reader.number(params, n, where) for n in names]
    dims = {"size": tuple(values)} if kind == "box" else dict(zip(names, values))
    try:
        return VOLUMES[kind](**common, **dims, frame=frame, region="inside" if region_name == "Inner" else "outside")
    except ValueError as exc:
        raise reader.fail(f"{where}: {exc.errors()[0]['msg']}") from None


def _obstacles(reader: _Reader, root: ET.Element) -> list[Obstacle]:
    obstacles = []
    for el in root.iter("Obstacle"):
        name = el.get("name") or Path(reader.attr(el, "obstacle", "<Obstacle>")).stem
        home = el.find("Home")
        pose = Pose()
        if home is not None:
            where = f"obstacle {name!r}"
            xyz = tuple(reader.number(home, k, where, 0.0) for k in ("X", "Y", "Z"))
            axis = np.array([reader.number(home, k, where, 0.0) for k in ("WX", "WY", "WZ")])
            angle = reader.number(home, "TH", where, 0.0)
            rotation = pin.exp3(axis / np.linalg.norm(axis) * angle) if np.linalg.norm(axis) > 0 else np.eye(3)
            pose = Pose.from_matrix(np.block([[rotation, np.array(xyz)[:, None]], [np.zeros((1, 3)), np.ones((1, 1))]]))
        # Kautham obstacles are meshes we do not have: a small marker keeps their frames usable.
        obstacles.append(Obstacle(name=name, shape=Sphere(radius=0.01), pose=pose))
    return obstacles


def _query(reader: _Reader, robot: Robot, root: ET.Element) -> tuple[dict[str, float], dict[str, float]]:
    controls = list(root.iter("RobotControl"))
    if not controls:
        raise reader.fail("no <RobotControl> elements in the query")
    lower, upper = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    init, goal = {}, {}
    by_name = _joint_by_name(robot)
    for el in controls:
        name = reader.attr(el, "name", "<RobotControl>")
        if name not in by_name:
            raise reader.fail(f"query: robot {robot.name!r} has no joint {name!r}")
        joint = by_name[name]
        i = robot.model.joints[robot.model.getJointId(joint)].idx_q
        for values, key in ((init, "init"), (goal, "goal")):
            c = reader.number(el, key, f"query control {name!r}")
            if not 0.0 <= c <= 1.0:
                raise reader.fail(f"query control {name!r}: {key} {c} is not a normalised value in [0, 1]")
            q = KAUTHAM_LOWER + c * (KAUTHAM_UPPER - KAUTHAM_LOWER)
            if not lower[i] <= q <= upper[i]:
                raise reader.fail(f"query control {name!r}: {key} {c} is {q:.3f} rad, outside {joint}'s limits")
            values[joint] = q
    return init, goal


def import_kautham(path: str | Path, rpy: Literal["kautham", "urdf"] = "kautham") -> PlanningProblem:
    """A hriplan planning problem from a Kautham problem file (robot madar or ur5)."""
    path = Path(path)
    reader = _Reader(path)
    text = read_text(path, "Kautham problem file (XML)")
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise reader.fail(f"not valid XML ({exc})") from None
    robot_el = root if root.tag == "Robot" else root.find(".//Robot")
    if robot_el is None:
        raise reader.fail("no <Robot> element")
    name = (robot_el.get("name") or Path(robot_el.get("robot", "")).stem or "").lower()
    robot_name = "madar" if "madar" in name else "ur5" if "ur5" in name else None
    if robot_name is None:
        raise reader.fail(f"robot {name!r} is not supported (madar or ur5)")
    robot = load_robot(robot_name)
    obstacles = _obstacles(reader, root)
    names = {o.name for o in obstacles}
    constraints = [_constraint(reader, robot, el, names, rpy) for el in robot_el.findall("Constraint")]
    init, goal = _query(reader, robot, root)
    group = _group(robot, [*init, *[j for c in constraints for j in c.joints]])
    options = PlanOptions(time_limit=_parameter(reader, root, "_Max Planning Time", 10.0), range=_parameter(reader, root, "_Range", 0.1))
    return PlanningProblem(
        name=path.stem, description=f"imported from the Kautham problem {path.name}", robot=robot_name,
        scene=Scene(obstacles=obstacles), constraints=ConstraintSet(constraints=constraints), group=group,
        start=init, goal=JointGoal(values={j: v for j, v in goal.items() if j in robot.group_joints(group)}), options=options,
    )  # fmt: skip


def _group(robot: Robot, joints: list[str]) -> str:
    """The smallest joint group that contains every joint the problem moves or constrains."""
    for group in sorted(robot.groups, key=lambda g: len(robot.groups[g])):
        if set(joints) <= set(robot.groups[group]):
            return group
    return robot.default_group


def _parameter(reader: _Reader, root: ET.Element, name: str, default: float) -> float:
    for el in root.iter("Parameter"):
        if el.get("name") == name and el.text:
            return reader.floats(el.text, 1, f"planner parameter {name!r}")[0]
    return default
