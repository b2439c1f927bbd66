"""Pairs a part can never reach are left out of the collision check (robots/reach.py). Checked
with code that does not share it: pinocchio's placements of each part at random states, and
coal's distance between the parts and the scene's shapes themselves."""

from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
import pytest

from hriplan.robots.collision import CollisionChecker
from hriplan.robots.descriptions.registry import load_robot_file
from hriplan.robots.human import HumanSpec
from hriplan.robots.model import load_robot
from hriplan.robots.reach import reach_sphere
from hriplan.robots.scene import Box, Cylinder, Obstacle, Scene, Sphere, table
from hriplan.robots.spatial import Pose
from madar_states import CLEAR

PANDA = Path(__file__).resolve().parents[2] / "examples" / "robots" / "panda.yaml"


def _random_states(robot, rng, count: int) -> np.ndarray:
    """States drawn uniformly within the joint limits."""
    low, high = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    assert np.isfinite(low).all() and np.isfinite(high).all()
    return rng.uniform(low, high, (count, robot.model.nq))


def _extreme_points(shape: pin.GeometryObject, rng) -> np.ndarray:
    """Points of a shape's surface where its far side lies (ends and rims, many directions), in
    its joint's frame: what a sphere around it must hold."""
    geometry, directions = shape.geometry, rng.normal(size=(200, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    if isinstance(geometry, coal.Box):
        half = np.asarray(geometry.halfSide)
        points = np.array([[(-h, h)[b >> k & 1] for k, h in enumerate(half)] for b in range(8)])
    elif isinstance(geometry, coal.Cylinder):
        angle = np.linspace(0.0, 2 * np.pi, 64)
        rim = np.column_stack([geometry.radius * np.cos(angle), geometry.radius * np.sin(angle), np.zeros(64)])
        points = np.concatenate([rim + (0, 0, geometry.halfLength), rim - (0, 0, geometry.halfLength)])
    elif isinstance(geometry, (coal.Capsule, coal.Sphere)):
        half = geometry.halfLength if isinstance(geometry, coal.Capsule) else 0.0
        points = np.concatenate([directions * geometry.radius + (0, 0, end) for end in (-half, half)])
    else:
        points = np.asarray(geometry.vertices())
    return points @ shape.placement.rotation.T + shape.placement.translation


@pytest.mark.parametrize("name", ["madar", "ur5", "panda"])
def test_every_part_stays_inside_its_reach_sphere(name, rng):
    robot = load_robot(load_robot_file(PANDA).name if name == "panda" else name)
    checker = CollisionChecker(robot)
    movers = [i for i, kind in enumerate(checker.kind) if kind == "robot"]
    objects = [checker.geom_model.geometryObjects[i] for i in movers]
    spheres = [reach_sphere(robot.model, shape) for shape in objects]
    assert all(np.isfinite(r) for _, r in spheres)  # revolute chains: every part is bounded
    corners = [_extreme_points(shape, rng) for shape in objects]
    reached = np.zeros(len(objects))  # per part: the farthest corner, in sphere radii
    for q in _random_states(robot, rng, 400):
        pin.forwardKinematics(robot.model, robot.data, q)
        for k, (shape, local, (centre, radius)) in enumerate(zip(objects, corners, spheres)):
            at = robot.data.oMi[shape.parentJoint]
            world = local @ at.rotation.T + at.translation
            reached[k] = max(reached[k], float(np.max(np.linalg.norm(world - centre, axis=1)) / radius))
    assert reached.max() <= 1.0 + 1e-12  # never left
    moving = [k for k, shape in enumerate(objects) if shape.parentJoint != 0]
    assert np.median(reached[moving]) > 0.6  # and not so loose that it leaves little out


def _near_and_far_scene(tool: np.ndarray) -> Scene:
    """A table, a box, a cylinder and a ball within the arm's reach or beyond it, a person in
    front of the tool and one far behind."""
    return Scene(
        obstacles=[
            table(position=(0.6, 0.9), size=(0.5, 0.6, 0.04), top=0.72),
            Obstacle(name="crate", shape=Box(size=(0.3, 0.2, 0.4)), pose=Pose(xyz=(-1.2, 1.0, 0.9))),
            Obstacle(name="pillar", shape=Cylinder(radius=0.1, height=1.0), pose=Pose(xyz=(2.5, 0.0, 0.5))),
            Obstacle(name="ball", shape=Sphere(radius=0.05), pose=Pose(xyz=tuple(tool + (0.0, 0.2, 0.0)))),
        ],
        humans=[
            HumanSpec(name="ann", position=(tool[0], tool[1] + 0.55), yaw=-np.pi / 2),
            HumanSpec(name="bob", position=(0.0, -2.5), yaw=np.pi / 2),
        ],
    )


def _left_out(checker: CollisionChecker) -> list[tuple[int, int]]:
    """The robot-scene pairs the checker has switched off (pinocchio's own flags)."""
    active = list(checker.geom_data.activeCollisionPairs)
    scene = {j for j, kind in enumerate(checker.kind) if kind in ("human", "obstacle")}
    pairs = checker.geom_model.collisionPairs
    return [(p.first, p.second) for p, on in zip(pairs, active) if not on and p.second in scene]


def test_the_pairs_left_out_never_come_closer_than_touching(madar, rng):
    q0 = madar.configuration({})
    checker = CollisionChecker(madar, _near_and_far_scene(madar.frame_pose("right_tool", q0)[:3, 3]))
    left_out = _left_out(checker)
    kinds = {checker.kind[j] for _, j in left_out}
    assert len(left_out) > 200 and kinds == {"human", "obstacle"}  # bob and far obstacles, at least
    on = [
        (p.first, p.second)
        for p, a in zip(checker.geom_model.collisionPairs, checker.geom_data.activeCollisionPairs)
        if a
    ]
    assert any(checker.kind[j] == "human" for _, j in on)  # ann stands within reach
    objects, closest = checker.geom_model.geometryObjects, np.inf
    for q in _random_states(madar, rng, 300):
        pin.forwardKinematics(madar.model, madar.data, q)
        for i, j in left_out:
            part, other = objects[i], objects[j]
            at = madar.data.oMi[part.parentJoint] * part.placement
            gap = coal.distance(
                part.geometry,
                coal.Transform3s(at.rotation, at.translation),
                other.geometry,
                coal.Transform3s(other.placement.rotation, other.placement.translation),
                coal.DistanceRequest(),
                coal.DistanceResult(),
            )
            closest = min(closest, gap)
    assert closest > 0.0


def test_a_person_who_steps_into_reach_is_checked_on_every_route_that_moves_her(madar, rng):
    """Re-posing a person (pose_human), reusing a build remembered where she stood (set_scene)
    and moving an obstacle (move_obstacle) each put back the pairs that came within reach: the
    answers equal a fresh checker's at states where the arm meets her."""
    q0 = madar.configuration({})
    tool = madar.frame_pose("right_tool", q0)[:3, 3]
    away = HumanSpec(name="ann", position=(0.0, -3.0), yaw=np.pi / 2)
    close = HumanSpec(name="ann", position=(tool[0], tool[1] + 0.3), yaw=-np.pi / 2)
    far_box = Obstacle(name="crate", shape=Box(size=(0.3, 0.3, 0.3)), pose=Pose(xyz=(0.0, -3.0, 1.0)))
    states = [q0 + rng.normal(0.0, 0.6, q0.size) for _ in range(150)]

    def agrees(checker: CollisionChecker, scene: Scene) -> int:
        fresh = CollisionChecker(madar, scene)
        hits = [fresh.in_collision(q) for q in states]
        assert [checker.in_collision(q) for q in states] == hits
        return sum(hits)

    checker = CollisionChecker(madar, Scene(humans=[away], obstacles=[far_box]))
    checker.pose_human(close)
    assert agrees(checker, Scene(humans=[close], obstacles=[far_box])) > 10
    checker.set_scene(Scene(humans=[away], obstacles=[far_box]))
    checker.set_scene(Scene(humans=[close], obstacles=[far_box]))  # the remembered build, where she stood
    agrees(checker, Scene(humans=[close], obstacles=[far_box]))
    checker.set_scene(Scene(humans=[away], obstacles=[far_box]))
    near_box = far_box.model_copy(update={"pose": Pose(xyz=tuple(tool))})
    checker.move_obstacle("crate", near_box.pose)
    assert agrees(checker, Scene(humans=[away], obstacles=[near_box])) > 10


def test_a_person_who_steps_out_of_reach_is_not_listed_in_contacts(madar):
    """A pair switched off keeps its last result in pinocchio: contacts must not report it."""
    q0 = madar.configuration(CLEAR)
    tool = tuple(madar.frame_pose("right_tool", q0)[:3, 3])
    crate = Obstacle(name="crate", shape=Box(size=(0.1, 0.1, 0.1)), pose=Pose(xyz=tool))  # the hand in it
    near = HumanSpec(name="ann", position=(tool[0], tool[1] + 0.45), yaw=-np.pi / 2, reach={"right": tool})
    away = HumanSpec(name="ann", position=(0.0, -3.0), yaw=np.pi / 2)
    checker = CollisionChecker(madar, Scene(obstacles=[crate], humans=[near]))
    touched = {c.b for c in checker.contacts(q0)} | {c.a for c in checker.contacts(q0)}
    assert "crate" in touched and any(name.startswith("ann/") for name in touched)
    checker.pose_human(away)
    listed = checker.contacts(q0)
    assert listed == CollisionChecker(madar, Scene(obstacles=[crate], humans=[away])).contacts(q0)
    assert listed and not any(c.a.startswith("ann/") or c.b.startswith("ann/") for c in listed)
