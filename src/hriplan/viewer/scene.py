"""The plan as one meshcat drawing: robot, people, scene, constraints, tool paths and camera.

The robot is drawn from its full display model (meshes and primitives, fingers at their
postures) and animated by the placement of every part that moves, sampled uniformly in time at
no more than `MAX_FPS` (and `MAX_FRAMES` in all, so that long motions stay small). People are
their display meshes, with the capsules the planner checks as a hidden layer to switch on.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence

import coal
import numpy as np
import pinocchio as pin

from hriplan.planner.constraints.spec import OrientationConstraint
from hriplan.planner.replay import PlannedWorld
from hriplan.planner.trajectory import ResolvedConstraint
from hriplan.robots.human import display_meshes
from hriplan.robots.scene import Mesh
from hriplan.viewer.drawing import Drawing, material, rgba_color
from hriplan.viewer.shapes import Part, beads, parts, tube
from hriplan.viewer.volumes import colors, draw_orientation, draw_volume, link_axes

MAX_FPS = 25.0
MAX_FRAMES = 600
CAMERA_FOV = 45.0  # deg, vertical
PERSON, PERSON_CAPSULES, OBSTACLE, CARRIED, TOOL_PATH = 0xE0B48F, 0x9467BD, 0xB5916B, 0x1F77B4, 0x7B2CBF
SLOWED = 0xFF7F0E  # tool path where the speed limit near a person held the robot (ISO/TS 15066)
# A point whose speed towards a person is this close to the allowed one was held by the limit.
HELD = 0.98


def frame_times(duration: float) -> np.ndarray:
    """Uniform animation times over [0, duration]: one frame for a motionless trajectory."""
    if duration <= 0.0:
        return np.zeros(1)
    frames = max(1, math.ceil(duration * min(MAX_FPS, MAX_FRAMES / duration)))
    return np.linspace(0.0, duration, frames + 1)


def build_drawing(world: PlannedWorld) -> Drawing:
    times = frame_times(world.duration)
    full_qs = [world.full_q(row) for row in world.positions_at(times)]
    traced = _traced_links(world)
    carriers = [world.robot.tool_frame(obj.arm) for obj in world.trajectory.scene.attached]
    link_poses = _link_poses(world, full_qs, [*traced, *carriers])
    drawing = Drawing()
    robot_points = _robot(drawing, world, full_qs)
    _carried(drawing, world, link_poses)
    _obstacles(drawing, world)
    _people(drawing, world)
    _constraints(drawing, world, link_poses)
    _tool_paths(drawing, world, traced, link_poses)
    work = [p.translation for link in traced for p in link_poses[link]]
    _camera(
        drawing, world, robot_points, np.array(work + [np.array(o.pose.xyz) for o in world.trajectory.scene.obstacles])
    )
    if len(times) > 1:
        drawing.finish_animation(fps=(len(times) - 1) / world.duration)
    return drawing


def _traced_links(world: PlannedWorld) -> list[str]:
    """Tools of the arms that move, and every constrained link."""
    moving = set(world.trajectory.joint_names)
    robot = world.robot
    tools = [
        robot.tool_frame(arm) for arm in robot.arms if moving.intersection(robot.group_joints(robot.arm_group(arm)))
    ]
    targets = [c.spec.target_link for c in world.trajectory.constraints]
    return list(dict.fromkeys(tools + targets))


def _link_poses(world: PlannedWorld, full_qs: Sequence[np.ndarray], links: Sequence[str]) -> dict[str, list[pin.SE3]]:
    """World pose of each named link at each configuration."""
    model = world.robot.full_model
    data = model.createData()
    poses: dict[str, list[pin.SE3]] = {link: [] for link in links}
    for q in full_qs:
        pin.forwardKinematics(model, data, q)
        for link in poses:
            poses[link].append(pin.SE3(pin.updateFramePlacement(model, data, model.getFrameId(link))))
    return poses


def _robot(drawing: Drawing, world: PlannedWorld, full_qs: Sequence[np.ndarray]) -> np.ndarray:
    """Every display geometry, animated where it moves; returns where the parts are (for the camera)."""
    model, visual = world.robot.full_model, world.robot.full_visual
    data, visual_data = model.createData(), visual.createData()
    frames = []
    for q in full_qs:
        pin.updateGeometryPlacements(model, data, visual, visual_data, q)
        frames.append([pin.SE3(m) for m in visual_data.oMg])
    for i, geometry in enumerate(visual.geometryObjects):
        path = f"robot/{geometry.name}"
        color, opacity = rgba_color(geometry.meshColor)
        drawing.draw(path, parts(geometry.geometry), material(color, opacity))
        track = [frame[i] for frame in frames]
        drawing.place(path, track[0])
        if any(not p.isApprox(track[0], 1e-9) for p in track[1:]):
            drawing.animate_poses(path, track)
    return np.array([p.translation for frame in frames for p in frame])


def _carried(drawing: Drawing, world: PlannedWorld, link_poses: dict[str, list[pin.SE3]]) -> None:
    for obj in world.trajectory.scene.attached:
        poses = [tool * obj.grasp.se3() for tool in link_poses[world.robot.tool_frame(obj.arm)]]
        path = f"carried/{obj.name}"
        drawing.draw(path, parts(obj.shape.geometry()), material(CARRIED))
        drawing.place(path, poses[0])
        if len(poses) > 1:
            drawing.animate_poses(path, poses)


def _obstacles(drawing: Drawing, world: PlannedWorld) -> None:
    for obstacle in world.trajectory.scene.obstacles:
        shape = obstacle.shape
        # Collision sees a mesh's convex hull; the viewer shows the mesh itself.
        geometry = (
            coal.MeshLoader().load(shape.path, np.asarray(shape.scale)) if isinstance(shape, Mesh) else shape.geometry()
        )
        path = f"scene/{obstacle.name}"
        drawing.draw(path, parts(geometry), material(OBSTACLE))
        drawing.place(path, obstacle.pose.se3())


def _people(drawing: Drawing, world: PlannedWorld) -> None:
    for name, human in world.checker.humans.items():
        for geometry, placement in display_meshes(human):
            path = f"people/{name}/body/{geometry.name}"
            drawing.draw(path, parts(geometry.geometry), material(PERSON))
            drawing.place(path, placement)
        margin = human.spec.margin
        for capsule, placement in zip(human.capsules, human.capsule_placements()):
            path = f"people/{name}/checked_capsules/{capsule.name}"
            drawing.draw(
                path, parts(coal.Capsule(capsule.radius + margin, capsule.length)), material(PERSON_CAPSULES, 0.3)
            )
            drawing.place(path, placement)
        drawing.set(f"people/{name}/checked_capsules", "visible", False)


def _constraints(drawing: Drawing, world: PlannedWorld, link_poses: dict[str, list[pin.SE3]]) -> None:
    bound = {c.id: c for c in world.constraints}
    shades = colors(world.trajectory.constraints)
    drawn: set[str] = set()
    for constraint in world.trajectory.constraints:
        spec = constraint.spec
        path = f"constraints/{spec.id}"
        if not isinstance(spec, OrientationConstraint):
            volume = _same_volume(constraint)
            if volume not in drawn:  # one arm's keep-out is the other's: one volume in the picture
                draw_volume(drawing, path, constraint, shades[spec.id])
                drawn.add(volume)
            continue
        poses = link_poses[spec.target_link]
        goal = bound[spec.id].p_goal
        distances = [0.0 if goal is None else float(np.linalg.norm(p.translation - goal)) for p in poses]
        tolerances = [spec.tolerance + spec.tolerance_gradient * d for d in distances]
        draw_orientation(drawing, f"{path}/target", constraint, poses, tolerances)
        link_axes(drawing, f"{path}/link_axes", spec, poses)


def _same_volume(constraint: ResolvedConstraint) -> str:
    """What a volume looks like: its shape, size, side and place (not which link or arm it binds)."""
    shape = constraint.spec.model_dump(mode="json", exclude={"id", "joints", "target_link", "enabled"})
    return json.dumps([shape, constraint.frame_in_world.model_dump(mode="json")], sort_keys=True)


def _tool_paths(
    drawing: Drawing, world: PlannedWorld, links: Sequence[str], link_poses: dict[str, list[pin.SE3]]
) -> None:
    """A tube through the link's position at every timed point, beads at the animation frames
    (their spacing shows the speed)."""
    at_points = _link_poses(world, [world.full_q(row) for row in world.positions], links)
    held = _held(world)
    for link in links:
        points = np.array([p.translation for p in at_points[link]])
        line = tube(points, 0.003)
        if line is not None:
            drawing.draw(f"tool_paths/{link}/path", [Part(line, np.eye(4))], material(TOOL_PATH))
        for k, (first, last) in enumerate(_runs(held)):
            slowed = tube(points[first : last + 1], 0.0045)
            if slowed is not None:
                drawing.draw(f"tool_paths/{link}/slowed_near_people/{k}", [Part(slowed, np.eye(4))], material(SLOWED))
        steps = beads(np.array([p.translation for p in link_poses[link]]), 0.007)
        drawing.draw(f"tool_paths/{link}/time_steps", [Part(steps, np.eye(4))], material(TOOL_PATH))


def _held(world: PlannedWorld) -> np.ndarray:
    """Per timed point: was the robot held to a person's speed limit there (trajectory report)?"""
    held = np.zeros(len(world.trajectory.points), dtype=bool)
    for trace in world.trajectory.report.separation:
        for i, (allowed, actual) in enumerate(zip(trace.allowed_speed, trace.approach_speed)):
            held[i] |= allowed is not None and actual is not None and actual > 0.0 and actual >= HELD * allowed
    return held


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) index of every run of True in `mask`."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(int), [0]])))
    return [(int(a), int(b) - 1) for a, b in zip(edges[::2], edges[1::2])]


def _view_azimuth(work: np.ndarray, people: np.ndarray) -> np.ndarray:
    """The horizontal direction from the scene to the eye: on the side where the work happens (the
    tools' paths, the objects), turned away from the people so that nobody stands between the
    camera and the arms, and a little to one side so that depth shows."""
    angles = np.linspace(0.0, 2.0 * math.pi, 72, endpoint=False)
    candidates = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    score = candidates @ work + 0.3 * np.abs(candidates @ np.array([-work[1], work[0]]))
    if np.linalg.norm(people) > 0.0:
        score -= 1.2 * np.maximum(candidates @ people, 0.0) ** 2
    return candidates[int(np.argmax(score))]


def _unit(v: np.ndarray) -> np.ndarray:
    norm = float(np.linalg.norm(v))
    return v / norm if norm > 1e-9 else np.zeros_like(v)


def _camera(drawing: Drawing, world: PlannedWorld, robot_points: np.ndarray, work_points: np.ndarray) -> None:
    """Frame the robot (at every frame), the people, the objects and the tools' paths, seen from
    the side where the work happens, and leave the lower left to the legend."""
    people = [np.array(h.spec.position) for h in world.checker.humans.values()]
    interest = [*robot_points, *work_points]
    interest += [np.array([*xy, z]) for xy in people for z in (0.0, 1.8)]
    low, high = np.min(interest, axis=0), np.max(interest, axis=0)
    radius = float(np.linalg.norm(high - low)) / 2
    base = np.mean(robot_points[:, :2], axis=0)
    work = _unit(np.mean(work_points[:, :2], axis=0) - base) if len(work_points) else np.array([0.0, 1.0])
    towards_people = _unit(np.mean(people, axis=0) - base) if people else np.zeros(2)
    direction = np.array([*_view_azimuth(work, towards_people), 0.55])
    direction /= np.linalg.norm(direction)
    right = np.cross(-direction, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, -direction)
    target = (low + high) / 2 - radius * (0.2 * right + 0.33 * up)  # the scene sits up, clear of the legend
    eye = target + max(2.0, 1.25 * radius / math.sin(math.radians(CAMERA_FOV / 2))) * direction
    drawing.look(eye, target, CAMERA_FOV)
