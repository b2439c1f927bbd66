"""Allowed-collision matrix: robot part pairs that need no self-collision check.

As MoveIt's setup assistant does: parts on the same rigid body or on adjacent links are not
checked, nor pairs that were in collision in none of many random samples of the collision model
the planner checks (the fitted parts, which contain the meshes, so the meshes never touch
either). A pair whose fitted parts touch in every sample, or two links with one link between
them, is checked on its URDF collision meshes ("mesh"): their capsules overlap around the link
between (UR5 base and upper arm: 43 % of the samples against 3.5 % for the meshes; forearm and
wrist 2: 37 % against 4 %), which would forbid motions, and starts, the robot can make. Nothing is taken from a published SRDF: its pairs were judged on other models, and
the UR5's forearm and wrists, or its base and upper arm, do touch in some configurations
(tests/robots/test_acm.py checks every disabled pair at mesh level).
Sampling costs about a second, so the result is cached on disk per robot description and
per RULES (change it whenever the rules that decide a pair change).
"""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pinocchio as pin

from hriplan.files import write_atomically
from hriplan.robots.fit_cache import cache_dir
from hriplan.robots.model import Robot
from hriplan.robots.robot_geometry import RobotPart, parent_links

DEFAULT_SAMPLES = 10000
RULES = "adjacent; never (sampled); always or two apart -> mesh; no SRDF pairs"
MESH = "mesh"  # the reason of pairs checked on their meshes rather than their fitted parts


def _key(robot: Robot, parts: tuple[RobotPart, ...], samples: int) -> str:
    shapes = [(p.name, p.joint, p.placement.homogeneous.round(6).tolist(), _shape_key(p.geometry)) for p in parts]
    text = repr((RULES, robot.urdf, robot.spec.hand_postures, robot.finger_values, shapes, samples))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _shape_key(geometry: object) -> tuple:
    attrs = ("radius", "halfLength", "halfSide")
    return (
        type(geometry).__name__,
        *(np.round(np.atleast_1d(getattr(geometry, a)), 6).tolist() for a in attrs if hasattr(geometry, a)),
    )


def adjacent(robot: Robot, a: RobotPart, b: RobotPart) -> bool:
    """Same rigid body, or links directly connected in the URDF tree."""
    if a.joint == b.joint:
        return True
    parents = parent_links(robot)
    return parents.get(a.link) == b.link or parents.get(b.link) == a.link


def two_apart(robot: Robot, a: RobotPart, b: RobotPart) -> bool:
    """Links with one link between them (forearm and wrist 2): their fitted parts overlap around
    the link between far more often than their meshes touch."""
    parents = parent_links(robot)
    return parents.get(parents.get(a.link, "")) == b.link or parents.get(parents.get(b.link, "")) == a.link


def compute_acm(
    robot: Robot, parts: tuple[RobotPart, ...], samples: int = DEFAULT_SAMPLES, seed: int = 0
) -> dict[str, str]:
    """Pairs not checked on their fitted parts, as {"a|b": reason}: adjacent, never or mesh."""
    disabled: dict[str, str] = {}
    geom_model = pin.GeometryModel()
    for part in parts:
        geom_model.addGeometryObject(pin.GeometryObject(part.name, part.joint, part.placement, part.geometry))
    candidates, candidate_parts = [], []
    for i, a in enumerate(parts):
        for j in range(i + 1, len(parts)):
            b = parts[j]
            if adjacent(robot, a, b):
                disabled[f"{a.name}|{b.name}"] = "adjacent"
            else:
                geom_model.addCollisionPair(pin.CollisionPair(i, j))
                candidates.append(f"{a.name}|{b.name}")
                candidate_parts.append((a, b))
    geom_data = geom_model.createData()
    rng = np.random.default_rng(seed)
    lower, upper = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    hits = np.zeros(len(candidates), dtype=int)
    for _ in range(samples):
        q = rng.uniform(lower, upper)
        pin.computeCollisions(robot.model, robot.data, geom_model, geom_data, q, False)
        hits += [r.isCollision() for r in geom_data.collisionResults]
    for (a, b), pair, count in zip(candidate_parts, candidates, hits):
        if count == 0:
            disabled[pair] = "never"
        elif count == samples or two_apart(robot, a, b):
            disabled[pair] = MESH
    return disabled


def load_acm(robot: Robot, parts: tuple[RobotPart, ...], samples: int = DEFAULT_SAMPLES) -> dict[str, str]:
    """The ACM for this robot, from the cache or computed (and cached)."""
    path = cache_dir() / f"acm-{robot.name}-{_key(robot, parts, samples)}.json"
    if path.exists():
        return json.loads(path.read_text())
    acm = compute_acm(robot, parts, samples)
    write_atomically(path, json.dumps(acm, indent=0, sort_keys=True))
    return acm
