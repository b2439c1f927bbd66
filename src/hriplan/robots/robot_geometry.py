"""Fast collision geometry for a loaded robot: one capsule per arm link and per finger.

Capsules are fitted to the union of a part's collision and visual shapes (meshes and box
corners) so that they contain everything the display shows. A link drawn and collided with
primitives only (MADAR's torso cylinder and boxes, wheels, hand adapters) keeps them as they are:
the URDF says so, not the link's name. The hand's palm is a box.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import coal
import numpy as np
import pinocchio as pin

from hriplan import HriplanError
from hriplan.robots.assets import resolve_package_uri
from hriplan.robots.bounding import fit_box, fit_capsule
from hriplan.robots.fit_cache import cached_fit, se3, se3_data, shape, shape_data
from hriplan.robots.model import Robot, RobotSpec

_FINGER = re.compile(r"^(?P<prefix>\w*?)hand_link_(?P<n>\d+)\.0(_tip)?$")


@dataclass(frozen=True)
class RobotPart:
    name: str
    link: str  # URDF link that carries it (for adjacency)
    joint: int
    geometry: coal.CollisionGeometry
    placement: pin.SE3
    kept: bool = False  # a URDF primitive kept as it is (not fitted): its own collision shape


def _points(geom: pin.GeometryObject) -> np.ndarray:
    shape = geom.geometry
    if isinstance(shape, coal.Box):
        half = shape.halfSide
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
    elif isinstance(shape, coal.Sphere):
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * shape.radius
    elif isinstance(shape, (coal.Cylinder, coal.Capsule)):
        # The rims of a polygon circumscribing the cylinder's circles (a capsule: its cylinder
        # lengthened by the radius at each end), so their hull contains the solid.
        n = 32
        angle = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
        rim = np.column_stack([np.cos(angle), np.sin(angle)]) * shape.radius / np.cos(np.pi / n)
        half = shape.halfLength + (shape.radius if isinstance(shape, coal.Capsule) else 0.0)
        corners = np.vstack([np.column_stack([rim, np.full(n, z)]) for z in (-half, half)])
    elif isinstance(shape, coal.BVHModelBase):
        corners = np.asarray(coal.MeshLoader().load(resolve_package_uri(geom.meshPath), geom.meshScale).vertices())
    else:
        raise HriplanError(f"collision geometry {geom.name!r}: no fit for a {type(shape).__name__}")
    return corners @ geom.placement.rotation.T + geom.placement.translation


def _link(model: pin.Model, geom: pin.GeometryObject) -> str:
    return model.frames[geom.parentFrame].name


def _group(link: str) -> str:
    finger = _FINGER.match(link)
    if finger:
        return f"{finger['prefix']}hand_finger_{int(finger['n']) // 4}"
    return link


_CACHE: dict[tuple[RobotSpec, float], tuple[RobotPart, ...]] = {}


# Change whenever the way parts are fitted changes: it keys the fits kept on disk.
FIT_RULES = "capsules on collision + hand visual meshes per link group; palm box; primitive-only links kept"


def _parts(robot: Robot, padding: float) -> tuple[RobotPart, ...]:
    """The fitted parts, from the disk cache (fit_cache.py) when this robot was fitted before."""
    key = (FIT_RULES, robot.urdf, robot.spec.hand_postures, robot.finger_values, padding, robot.model_key)
    fitted = cached_fit(
        f"parts-{robot.name}", key, lambda: {"parts": [_part_data(p) for p in _fitted_parts(robot, padding)]}
    )
    return tuple(
        RobotPart(p["name"], p["link"], p["joint"], shape(p["shape"]), se3(p["placement"]), p["kept"])
        for p in fitted["parts"]
    )


def _part_data(part: RobotPart) -> dict:
    return {
        "name": part.name,
        "link": part.link,
        "joint": part.joint,
        "shape": shape_data(part.geometry),
        "placement": se3_data(part.placement),
        "kept": part.kept,
    }


def _collision_names(urdf: str) -> dict[str, list[str | None]]:
    """Per link, the names of its URDF <collision> elements, in order (pinocchio's geometry
    objects are `{link}_{index}`)."""
    return {el.get("name"): [c.get("name") for c in el.findall("collision")] for el in ET.fromstring(urdf).iter("link")}


def _primitive_links(robot: Robot) -> set[str]:
    """The links with collision shapes, none of whose collision or visual shapes is a mesh."""
    collision, visual = robot.collision_meshes.geometryObjects, robot.visual.geometryObjects
    meshed = {_link(robot.model, g) for g in [*collision, *visual] if isinstance(g.geometry, coal.BVHModelBase)}
    return {_link(robot.model, g) for g in collision} - meshed


def _fitted_parts(robot: Robot, padding: float) -> tuple[RobotPart, ...]:
    model = robot.model
    clouds: dict[str, list[np.ndarray]] = {}
    owners: dict[str, tuple[str, int]] = {}
    parts: list[RobotPart] = []
    names = _collision_names(robot.urdf)
    kept = _primitive_links(robot)
    for geom in robot.collision_meshes.geometryObjects:
        link = _link(model, geom)
        if link in kept:
            # A primitive is named as the URDF names it (MADAR's torso: madar_base_cylinder, ...).
            name = names[link][int(geom.name.rsplit("_", 1)[1])] or link
            parts.append(RobotPart(name, link, geom.parentJoint, geom.geometry, geom.placement, kept=True))
            continue
        group = _group(link)
        clouds.setdefault(group, []).append(_points(geom))
        owners.setdefault(group, (link, geom.parentJoint))
    for geom in robot.visual.geometryObjects:
        group = _group(_link(model, geom))
        if group in clouds and isinstance(geom.geometry, coal.BVHModelBase) and "hand" in group:
            clouds[group].append(_points(geom))
    for group, cloud in clouds.items():
        points = np.vstack(cloud)
        link, joint = owners[group]
        if group.endswith("palm_link"):
            # The palm is flat: a box in the palm frame is far tighter than a capsule.
            palm = model.frames[model.getFrameId(link)].placement
            size, centre = fit_box(points @ palm.rotation - palm.rotation.T @ palm.translation, padding)
            parts.append(RobotPart(group, link, joint, coal.Box(*size), palm * centre))
        else:
            radius, length, placement = fit_capsule(points, padding)
            parts.append(RobotPart(group, link, joint, coal.Capsule(radius, length), placement))
    return tuple(parts)


# Said where a robot has no collision part (`CollisionChecker`, `robot init`): nothing to check.
NO_COLLISION_SHAPES = (
    "the URDF gives no link a <collision> shape, and hriplan checks every motion against them"
    " (people and the scene included): add them, as MoveIt needs them too"
)


def robot_parts(robot: Robot, padding: float = 0.0) -> tuple[RobotPart, ...]:
    """The robot's collision parts (cached per robot description, hand postures and padding)."""
    key = (robot.spec, padding)
    if key not in _CACHE:
        _CACHE[key] = _parts(robot, padding)
    return _CACHE[key]


def part_collision_shapes(robot: Robot, part: RobotPart) -> list[pin.GeometryObject]:
    """The URDF collision shapes a part stands for (a kept primitive is its own shape):
    for pairs whose fitted parts cannot tell contact apart (acm.MESH)."""
    if part.kept:
        return [pin.GeometryObject(f"{part.name} (mesh)", part.joint, part.placement, part.geometry)]
    shapes = []
    for geom in robot.collision_meshes.geometryObjects:
        if _group(_link(robot.model, geom)) == part.name:
            shapes.append(pin.GeometryObject(f"{part.name} (mesh)", geom.parentJoint, geom.placement, geom.geometry))
    return shapes


def parent_links(robot: Robot) -> dict[str, str]:
    """URDF link -> its parent link, from the full model's frame tree."""
    frames = robot.full_model.frames
    parents = {}
    for frame in frames:
        if frame.type == pin.FrameType.BODY:
            joint_frame = frames[frame.parentFrame]
            parents[frame.name] = frames[joint_frame.parentFrame].name
    return parents


def ask_contacts(data: pin.GeometryData) -> None:
    """Have coal compute the contact of a colliding pair, not only say whether it collides.
    Without (pinocchio's default), coal's GJK misses some penetrations in aligned poses: two of
    Baxter's arm cylinders 4.5 mm into each other were "free" (and 1 in about 1500 random
    penetrating box-capsule poses). Free pairs cost the same; a colliding one adds its contact."""
    for request in data.collisionRequests:
        request.enable_contact = True
