"""Allowed-collision matrix: robot part pairs that need no self-collision check.

As MoveIt's setup assistant does: parts on the same rigid body or on adjacent links, and pairs
that were in collision in every sampled configuration, or in none, of many random samples.
Sampling costs about a second, so the result is cached on disk per robot description.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin

from .assets import asset
from .model import Robot
from .robot_geometry import RobotPart, parent_links

DEFAULT_SAMPLES = 10000


def _cache_dir() -> Path:
    return Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "hriplan"


def _key(robot: Robot, parts: tuple[RobotPart, ...], samples: int) -> str:
    shapes = [(p.name, p.joint, p.placement.homogeneous.round(6).tolist(), _shape_key(p.geometry)) for p in parts]
    text = repr((robot.urdf, robot.spec.hand_postures, shapes, samples))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _shape_key(geometry: object) -> tuple:
    attrs = ("radius", "halfLength", "halfSide")
    return (type(geometry).__name__, *(np.round(np.atleast_1d(getattr(geometry, a)), 6).tolist() for a in attrs if hasattr(geometry, a)))


def adjacent(robot: Robot, a: RobotPart, b: RobotPart) -> bool:
    """Same rigid body, or links directly connected in the URDF tree."""
    if a.joint == b.joint:
        return True
    parents = parent_links(robot)
    return parents.get(a.link) == b.link or parents.get(b.link) == a.link


def ur5_srdf_pairs(robot: Robot) -> set[frozenset[str]]:
    """Pairs the UR5's own SRDF (example-robot-data) disables, renamed to each arm's links."""
    root = ET.parse(asset("ur_description/srdf/ur5.srdf")).getroot()
    rename = {"forearm_link": "fore_arm_link"}
    pairs = set()
    for prefix, _ in robot.arms.values():
        for el in root.iter("disable_collisions"):
            a, b = (prefix + rename.get(el.get(k), el.get(k)) for k in ("link1", "link2"))
            pairs.add(frozenset((a, b)))
    return pairs


def compute_acm(robot: Robot, parts: tuple[RobotPart, ...], samples: int = DEFAULT_SAMPLES, seed: int = 0) -> dict[str, str]:
    """Disabled pairs as {"a|b": reason}, reason one of adjacent, ur5-srdf, always, never."""
    disabled: dict[str, str] = {}
    srdf = ur5_srdf_pairs(robot)
    geom_model = pin.GeometryModel()
    for part in parts:
        geom_model.addGeometryObject(pin.GeometryObject(part.name, part.joint, part.placement, part.geometry))
    candidates = []
    for i, a in enumerate(parts):
        for j in range(i + 1, len(parts)):
            b = parts[j]
            if adjacent(robot, a, b):
                disabled[f"{a.name}|{b.name}"] = "adjacent"
            elif frozenset((a.link, b.link)) in srdf:
                disabled[f"{a.name}|{b.name}"] = "ur5-srdf"
            else:
                geom_model.addCollisionPair(pin.CollisionPair(i, j))
                candidates.append(f"{a.name}|{b.name}")
    geom_data = geom_model.createData()
    rng = np.random.default_rng(seed)
    lower, upper = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    hits = np.zeros(len(candidates), dtype=int)
    for _ in range(samples):
        q = rng.uniform(lower, upper)
        pin.computeCollisions(robot.model, robot.data, geom_model, geom_data, q, False)
        hits += [r.isCollision() for r in geom_data.collisionResults]
    for pair, count in zip(candidates, hits):
        if count == samples:
            disabled[pair] = "always"
        elif count == 0:
            disabled[pair] = "never"
    return disabled


def load_acm(robot: Robot, parts: tuple[RobotPart, ...], samples: int = DEFAULT_SAMPLES) -> dict[str, str]:
    """The ACM for this robot, from the cache or computed (and cached)."""
    path = _cache_dir() / f"acm-{robot.name}-{_key(robot, parts, samples)}.json"
    if path.exists():
        return json.loads(path.read_text())
    acm = compute_acm(robot, parts, samples)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(acm, indent=0, sort_keys=True))
    tmp.replace(path)
    return acm
