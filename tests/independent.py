"""Checks of written trajectories by geometry written here, apart from the planner's.

The planner accepts a path with its own evaluator (`planner/constraints`) and `replay.py`
re-checks it with the same code; a test that repeats that check cannot catch a bug shared by
both. This module recomputes what a trajectory promises from the URDF alone: forward kinematics
with pinocchio built from the URDF string, link surfaces from the URDF's collision meshes with
coal, and each constraint's membership (upright angle, inside or outside a box, sphere,
cylinder, cone) from the semantics in the constraint specification's docstring. It imports
nothing from `hriplan.planner.constraints` or `hriplan.safety`.
"""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin

from hriplan.robots.descriptions.registry import description_of, hand_model


def nearest(shape_a: coal.ShapeBase, at_a: pin.SE3, shape_b: coal.ShapeBase, at_b: pin.SE3) -> coal.DistanceResult:
    """coal's distance between two placed shapes, with their nearest points."""
    result = coal.DistanceResult()
    coal.distance(
        shape_a,
        coal.Transform3s(at_a.rotation, at_a.translation),
        shape_b,
        coal.Transform3s(at_b.rotation, at_b.translation),
        coal.DistanceRequest(),
        result,
    )
    return result


def outside_distance(spec, local: np.ndarray) -> np.ndarray:
    """Per point (rows of `local`, in the constraint frame): > 0 outside the closed solid, by at
    least that much along some axis (a bound, not the exact distance, except for the sphere)."""
    kind = spec.type
    if kind == "box":
        return np.max(np.abs(local) - np.array(spec.size) / 2.0, axis=1)
    if kind == "sphere":
        return np.linalg.norm(local, axis=1) - spec.radius
    r, z = np.linalg.norm(local[:, :2], axis=1), local[:, 2]
    if kind == "cylinder":
        return np.maximum.reduce([r - spec.radius, -z, z - spec.height])
    if kind == "cone":  # apex at the origin, radius r z / h for 0 <= z <= h, nothing above h
        return np.maximum.reduce([-z, z - spec.height, r - spec.radius * np.clip(z, 0.0, None) / spec.height])
    raise AssertionError(f"no independent geometry for {kind!r}")


def inside(spec, local: np.ndarray) -> np.ndarray:
    """Membership of each point in the closed solid of a volume constraint."""
    return outside_distance(spec, local) <= 0.0


class UrdfRobot:
    """A robot as its URDF says: the full model (fingers at their postures) and its collision meshes."""

    def __init__(self, name: str, hands: dict[str, str]) -> None:
        description = description_of(name)
        urdf = description.urdf()
        self.model = pin.buildModelFromXML(urdf)
        self.data = self.model.createData()
        self.geometry = pin.buildGeomFromUrdfString(self.model, urdf, pin.COLLISION)
        self.geometry_data = pin.GeometryData(self.geometry)
        self.fingers = {}  # each hand's finger joint values at its posture (the hand model's data)
        for side, posture in hands.items():
            arm = description.arms[side]
            hand = hand_model(arm.hand)
            self.fingers |= {hand.joint_name(arm.prefix, j): v for j, v in hand.joint_values(posture).items()}

    def configure(self, values: dict[str, float]) -> None:
        """Forward kinematics (frames and collision geometry) for named joint values."""
        q = pin.neutral(self.model)
        for joint, value in (self.fingers | values).items():
            q[self.model.joints[self.model.getJointId(joint)].idx_q] = value
        pin.framesForwardKinematics(self.model, self.data, q)
        pin.updateGeometryPlacements(self.model, self.data, self.geometry, self.geometry_data)

    def pose(self, frame: str) -> pin.SE3:
        return self.data.oMf[self.model.getFrameId(frame)]

    def surface_distance(self, spec, frame: np.ndarray, prefix: str) -> tuple[float, str]:
        """Smallest distance from the collision meshes of links named `prefix...` to the solid of
        a box, sphere or cylinder constraint placed at `frame` (negative: penetrating)."""
        solid, local = _coal_solid(spec)
        placement = pin.SE3(frame[:3, :3], frame[:3, 3]) * local
        request, best = coal.DistanceRequest(), (np.inf, "")
        for g, placed in zip(self.geometry.geometryObjects, self.geometry_data.oMg):
            if not g.name.startswith(prefix):
                continue
            result = coal.DistanceResult()
            d = coal.distance(g.geometry, coal.Transform3s(placed), solid, coal.Transform3s(placement), request, result)
            best = min(best, (d, g.name))
        return best


def _coal_solid(spec) -> tuple[coal.ShapeBase, pin.SE3]:
    """The constraint's solid as a coal shape and its pose in the constraint frame (coal centres
    its cylinder on the origin; the constraint's stands on z = 0)."""
    if spec.type == "box":
        return coal.Box(*spec.size), pin.SE3.Identity()
    if spec.type == "sphere":
        return coal.Sphere(spec.radius), pin.SE3.Identity()
    if spec.type == "cylinder":
        return coal.Cylinder(spec.radius, spec.height), pin.SE3(np.eye(3), np.array([0.0, 0.0, spec.height / 2.0]))
    raise AssertionError(f"no independent surface check for {spec.type!r}")


def orientation_error(spec, rotation: np.ndarray) -> float:
    """The error angle of a link orientation `rotation` (in the constraint frame) as the
    specification defines it: no free axis, the angle of Rt^T R; one free axis a, the angle
    between R a and Rt a (the upright angle); two, the twist of Rt^T R about the third axis."""
    target = spec.target.rotation()
    error = target.T @ rotation
    if not spec.free_axes:
        return float(np.arccos(np.clip((np.trace(error) - 1.0) / 2.0, -1.0, 1.0)))
    if len(spec.free_axes) == 1:
        a = "xyz".index(spec.free_axes[0])
        return float(np.arccos(np.clip(rotation[:, a] @ target[:, a], -1.0, 1.0)))
    b = ({0, 1, 2} - {"xyz".index(axis) for axis in spec.free_axes}).pop()
    quat = pin.Quaternion(error)
    twist = 2.0 * np.arctan2(abs([quat.x, quat.y, quat.z][b]), abs(quat.w))
    return float(twist)


def constraint_violations(trajectory, slack: float = 1e-3) -> list[str]:
    """Every written point against every constraint of a trajectory file, by the geometry here:
    the target link's position in its volume, its orientation within the tolerance, and for
    keep-out volumes every link surface of the moving arm and its hand outside. Returns the breaches."""
    robot = UrdfRobot(trajectory.robot, dict(trajectory.hands))
    description = description_of(trajectory.robot)
    breaches = []
    for point in trajectory.points:
        robot.configure(dict(trajectory.start) | dict(zip(trajectory.joint_names, point.positions)))
        for c in trajectory.constraints:
            spec, frame = c.spec, c.frame_in_world.matrix()
            tool = robot.pose(spec.target_link)
            where = [spec.id]
            if spec.type == "orientation":
                goal = 0.0 if c.goal_position is None else np.linalg.norm(tool.translation - np.array(c.goal_position))
                allowed = spec.tolerance + spec.tolerance_gradient * goal
                worst = orientation_error(spec, frame[:3, :3].T @ tool.rotation) - allowed
            else:
                local = frame[:3, :3].T @ (tool.translation - frame[:3, 3])
                distance = float(outside_distance(spec, local[None])[0])
                worst = distance if spec.region == "inside" else -distance
                if spec.keep_out_all_links:
                    arm = next(d for d in description.arms.values() if d.tool_frame == spec.target_link)
                    surface, link = robot.surface_distance(spec, frame, arm.prefix)
                    if -surface > worst:
                        worst, where = -surface, [spec.id, link]
            if worst > slack:
                breaches.append(
                    f"{trajectory.step}: {' '.join(where)} broken by {worst:.4f} at t={point.time_from_start:.2f}"
                )
    return breaches
