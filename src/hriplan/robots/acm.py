"""Allowed-collision matrix: robot part pairs that need no self-collision check.

As MoveIt's setup assistant does: parts on the same rigid body or on adjacent links are not
checked, nor pairs that were in collision in none of many random samples of the collision model
the planner checks (the fitted parts, which contain the meshes, so the meshes never touch
either). Some pairs are checked on their URDF collision meshes ("mesh") instead of their fitted
parts, which are bigger than the meshes and would forbid motions, and starts or goals, the
robot can make:
- a pair whose fitted parts touch in every sample;
- two links with one link between them: their capsules overlap around the link between (UR5
  base and upper arm: 43 % of the samples against 3.5 % for the meshes; forearm and wrist 2:
  37 % against 4 %);
- a pair whose fitted parts collide while its meshes do not in one of the robot's named postures
  (its starts: xArm7's base links against its wrist at home);
- a pair whose fitted parts collide while its meshes do not in FALSE_SHARE (5 %) of the samples
  or more, measured on the same samples (the meshes are checked where the fitted parts touch).
  On a UR arm that is the forearm and wrist 3, three links apart (fitted 29 %, meshes 7.6 %:
  21 % false; Kautham's madar_dual_arm demo ends with them 2.4 cm apart), and the base and the
  forearm (6.5 % false); on MADAR's hands also the forearm against the hand adapter, palm and
  the thumb (10 to 16 %). The next pairs make 4 % or less (upper arm and wrist 3, 4.1 %).
Nothing is taken from a published SRDF: its pairs were judged on other models, and
the UR5's forearm and wrists, or its base and upper arm, do touch in some configurations
(tests/robots/test_acm.py checks every disabled pair at mesh level, and that no state is free
where the meshes touch).
Sampling costs a few seconds, so the result is cached on disk per robot description and
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
from hriplan.robots.robot_geometry import RobotPart, ask_contacts, parent_links, part_collision_shapes

DEFAULT_SAMPLES = 10000
# A pair whose fitted parts collide while its meshes do not in this share of the samples or more
# is checked on its meshes: its fitted parts alone would forbid that much of the joint space.
FALSE_SHARE = 0.05
RULES = f"adjacent past links without parts; never (sampled, contacts asked); always on meshes too; always, two apart, false in a posture or in >= {FALSE_SHARE} -> mesh; no SRDF pairs"
USER = "user"  # the reason of pairs the robot file allows (allowed_collisions)
ALWAYS = "always"  # the reason of pairs whose meshes touch in every sample
MESH = "mesh"  # the reason of pairs checked on their meshes rather than their fitted parts


def _key(robot: Robot, parts: tuple[RobotPart, ...], samples: int) -> str:
    shapes = [(p.name, p.joint, p.placement.homogeneous.round(6).tolist(), _shape_key(p.geometry)) for p in parts]
    text = repr(
        (
            RULES,
            FALSE_SHARE,
            robot.description.allowed_collisions,
            robot.urdf,
            robot.spec.hand_postures,
            robot.finger_values,
            robot.model_key,
            robot.description.postures,  # pairs false only in a posture are checked on meshes
            shapes,
            samples,
        )
    )
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _shape_key(geometry: object) -> tuple:
    attrs = ("radius", "halfLength", "halfSide")
    return (
        type(geometry).__name__,
        *(np.round(np.atleast_1d(getattr(geometry, a)), 6).tolist() for a in attrs if hasattr(geometry, a)),
    )


def adjacent(robot: Robot, a: RobotPart, b: RobotPart, parts: tuple[RobotPart, ...] = ()) -> bool:
    """Same rigid body, or links directly connected in the URDF tree, as MoveIt's setup
    assistant sees them: through links that carry none of `parts` (no geometry; Baxter's
    `right_arm_mount` between its torso and shoulder)."""
    if a.joint == b.joint:
        return True
    parents = parent_links(robot)
    carried = {p.link for p in parts}

    def above(link: str) -> str | None:
        up = parents.get(link)
        while up is not None and carried and up not in carried:
            up = parents.get(up)
        return up

    return above(a.link) == b.link or above(b.link) == a.link


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
    allowed = {frozenset(pair) for pair in robot.description.allowed_collisions}
    for i, a in enumerate(parts):
        for j in range(i + 1, len(parts)):
            b = parts[j]
            if frozenset((a.link, b.link)) in allowed:
                disabled[f"{a.name}|{b.name}"] = USER
            elif adjacent(robot, a, b, parts):
                disabled[f"{a.name}|{b.name}"] = "adjacent"
            else:
                geom_model.addCollisionPair(pin.CollisionPair(i, j))
                candidates.append(f"{a.name}|{b.name}")
                candidate_parts.append((a, b))
    geom_data = geom_model.createData()
    ask_contacts(geom_data)
    rng = np.random.default_rng(seed)
    lower, upper = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    states = rng.uniform(lower, upper, size=(samples, robot.model.nq))
    hits = np.zeros((samples, len(candidates)), dtype=bool)
    for k, q in enumerate(states):
        pin.computeCollisions(robot.model, robot.data, geom_model, geom_data, q, False)
        hits[k] = [r.isCollision() for r in geom_data.collisionResults]
    counts = hits.sum(axis=0)
    loose = [
        c
        for c, ((a, b), count) in enumerate(zip(candidate_parts, counts))
        if count == samples or (count >= FALSE_SHARE * samples and not two_apart(robot, a, b))
    ]
    false_hits = _false_collisions(robot, [candidate_parts[c] for c in loose], states, hits[:, loose])
    false_share = dict(zip(loose, false_hits / samples))
    # The robot's named postures are states it must be able to start from: a pair whose fitted
    # parts touch in one while its meshes do not is checked on its meshes (xArm7's base links and
    # wrist, 4 cm apart in its home posture, 2 % false over the random samples).
    postures = np.array([robot.configuration(values) for values in robot.description.postures.values()])
    posture_hits = np.zeros((len(postures), len(candidates)), dtype=bool)
    for k, q in enumerate(postures):
        pin.computeCollisions(robot.model, robot.data, geom_model, geom_data, q, False)
        posture_hits[k] = [r.isCollision() for r in geom_data.collisionResults]
    touched = np.flatnonzero(posture_hits.any(axis=0))
    in_posture = _false_collisions(robot, [candidate_parts[c] for c in touched], postures, posture_hits[:, touched])
    posture_false = {int(c) for c, false in zip(touched, in_posture) if false > 0}
    for c, ((a, b), pair, count) in enumerate(zip(candidate_parts, candidates, counts)):
        if c in posture_false:
            disabled[pair] = MESH
        elif count == 0:
            disabled[pair] = "never"
        elif count == samples and false_share[c] == 0.0 and all(part_collision_shapes(robot, p) for p in (a, b)):
            # Their meshes touch in every sample too (MoveIt's "Always": Baxter's arm cylinders
            # overlap at their joints): no state of the robot is free of the pair, so it says nothing.
            disabled[pair] = ALWAYS
        elif count == samples or two_apart(robot, a, b) or false_share.get(c, 0.0) >= FALSE_SHARE:
            disabled[pair] = MESH
    return disabled


def _false_collisions(
    robot: Robot, pairs: list[tuple[RobotPart, RobotPart]], states: np.ndarray, hits: np.ndarray
) -> np.ndarray:
    """Per pair: in how many of `states` its fitted parts collide (`hits`) and its URDF collision
    meshes do not (none for a part without collision shapes: it stays checked on its fitted part)."""
    meshes = pin.GeometryModel()
    slots: dict[str, list[int]] = {}
    for part in {part.name: part for pair in pairs for part in pair}.values():
        slots[part.name] = [meshes.addGeometryObject(s) for s in part_collision_shapes(robot, part)]
    shape_pairs: list[list[int]] = []
    for a, b in pairs:
        shape_pairs.append([])
        for i in slots[a.name]:
            for j in slots[b.name]:
                shape_pairs[-1].append(len(meshes.collisionPairs))
                meshes.addCollisionPair(pin.CollisionPair(i, j))
    mesh_data = meshes.createData()
    ask_contacts(mesh_data)
    false = np.zeros(len(pairs), dtype=int)
    for q, row in zip(states, hits):
        if not row.any():
            continue
        pin.updateGeometryPlacements(robot.model, robot.data, meshes, mesh_data, q)
        for c in np.flatnonzero(row):
            if shape_pairs[c] and not any(pin.computeCollision(meshes, mesh_data, k) for k in shape_pairs[c]):
                false[c] += 1
    return false


def load_acm(robot: Robot, parts: tuple[RobotPart, ...], samples: int = DEFAULT_SAMPLES) -> dict[str, str]:
    """The ACM for this robot, from the cache or computed (and cached)."""
    path = cache_dir() / f"acm-{robot.name}-{_key(robot, parts, samples)}.json"
    if path.exists():
        return json.loads(path.read_text())
    acm = compute_acm(robot, parts, samples)
    write_atomically(path, json.dumps(acm, indent=0, sort_keys=True))
    return acm
