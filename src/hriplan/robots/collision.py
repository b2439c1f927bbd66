"""Collision checking and clearance for a robot in a scene with people.

One pinocchio GeometryModel holds the robot's parts, the carried objects, the obstacles and the
people's capsules; the pairs to check are fixed when the scene's *contents* change. Moving an
obstacle or re-posing a person only rewrites placements, so the robot is never rebuilt. A scene
is built when it is first asked about (planning sets scenes it never checks in).

A robot part that never moves (the base) against an obstacle gives the same answer in every
state, so that pair is decided once, exactly, on the part's URDF collision shapes: a UR5 base
standing on a table must not collide through its capsule, which reaches 8 cm below the base.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import cached_property
from itertools import count
from typing import TYPE_CHECKING

import coal
import numpy as np
import pinocchio as pin

from hriplan import HriplanError
from hriplan.recent import MadeFor, Recent
from hriplan.robots.acm import MESH, load_acm
from hriplan.robots.human import Human, HumanSpec
from hriplan.robots.kernel_switch import kernels_on
from hriplan.robots.mesh_clearance import ClearanceTable, clearance_tables
from hriplan.robots.model import Robot
from hriplan.robots.part_spheres import PartSpheres, box_sphere
from hriplan.robots.robot_geometry import NO_COLLISION_SHAPES, ask_contacts, part_collision_shapes, robot_parts
from hriplan.robots.scene import Scene
from hriplan.robots.spatial import Pose
from hriplan.robots.still_pairs import Held, Motion, Views

if TYPE_CHECKING:
    from hriplan.robots.free_certifier import FreeCertifier
    from hriplan.robots.mesh_pairs import MeshPair

# How a separation zone is named in contacts and messages: "bob/left_upperleg (minimum separation 0.225 m)".
ZONE_NAMING = "minimum separation"


@dataclass(frozen=True)
class Contact:
    a: str
    b: str


# coal's GJK stops when a step gains less than this (its default 1e-6): robot-person distances
# feed ISO/TS 15066 speeds, and at 1e-6 a cylinder's witness points were up to 0.6 mm off (its
# distance 1.4e-6 m), turning an approach direction by ~1e-4; at 1e-12 the distance agrees with
# the exact segment-to-cylinder one to ~1e-11 m and the points to ~1e-6 m, for ~0.3 us more a
# query (at 1e-13 GJK stalls on some pairs, 7e-7 m short).
PERSON_GJK_TOLERANCE = 1e-12


def person_distance_data(model: pin.GeometryModel) -> pin.GeometryData:
    """The data of a model of robot-person pairs, its distance requests at PERSON_GJK_TOLERANCE."""
    data = model.createData()
    for request in data.distanceRequests:
        request.gjk_tolerance = PERSON_GJK_TOLERANCE
    return data


# (robot model, distance model, joints, states (N, nq), ceiling, posed) -> (distance, state, pair):
# of the model's pairs whose robot part rides on one of the joints, the least distance over the
# states, of equal ones the first state, then the first pair; (inf, -1, -1) if none comes within
# the ceiling. `posed` changes whenever the model's people are placed anew (what it read of them
# at the same `posed` stands).
NearestPairs = Callable[[pin.Model, pin.GeometryModel, frozenset[int], np.ndarray, float, int], tuple[float, int, int]]

# Stamps of placings of the people in a distance model, never the same twice (`_people_placed`).
_PLACINGS = count(1)


@dataclass
class _Route:
    """How `closest_human` splits a distance model's pairs for states along which the same
    entries vary: read once per such split (~0.1 ms a call), with the still pairs' last answer."""

    moving: np.ndarray  # a flag a pair: its robot part rides on a joint a varying entry moves
    joints: frozenset[int]  # the joints carrying the moving pairs' robot parts
    still_entries: np.ndarray  # a flag a configuration entry: does it move a still pair's part?
    # ((when the people were placed, the still entries' values), (distance, pair)) of the last ask
    still_asked: tuple[tuple[int, bytes], tuple[float, int]] | None = None


# A list of colliding pairs in a message is cut to this many characters, so that the message's
# line stays within 300 (a person standing in the robot touches dozens of its parts: the whole
# list made one line of 12,600 characters).
LISTED_WIDTH = 200


def listed_contacts(contacts: Sequence[Contact], width: int = LISTED_WIDTH) -> str:
    """Colliding pairs in one line of at most `width` characters: as many as fit, then how many
    more and how many in all, so that a message stays readable and still says how bad it is."""
    pairs = [f"{c.a} - {c.b}" for c in contacts]
    if len(", ".join(pairs)) <= width:
        return ", ".join(pairs)
    shown: list[str] = []
    for pair in pairs:
        tail = f" and {len(pairs) - len(shown) - 1} more ({len(pairs)} pairs in all)"
        if len(", ".join([*shown, pair]) + tail) > width:
            break
        shown.append(pair)
    if not shown:  # names longer than the line
        return f"{len(pairs)} colliding pairs"
    return f"{', '.join(shown)} and {len(pairs) - len(shown)} more ({len(pairs)} pairs in all)"


@dataclass(frozen=True)
class SeparationZones:
    """Per person, per capsule: how far beyond the bare capsule the moving parts must stay (m).
    Checked only against robot parts and carried objects on `moving_joints`."""

    distances: dict[str, dict[str, float]]
    moving_joints: frozenset[int]


@dataclass(frozen=True)
class PairDistances:
    """Every robot part (and carried object) against every capsule of one person: row k is one pair."""

    parts: list[str]
    joints: np.ndarray  # the robot joint that carries each part
    capsules: list[str]  # the person's body-model segment, e.g. right_hand
    distance: np.ndarray  # between the bare capsule (no safety margin) and the part, m


@dataclass(frozen=True)
class PersonPairs(PairDistances):
    """The same, with each pair's closest points."""

    robot_point: np.ndarray  # (k, 3) world
    person_point: np.ndarray  # (k, 3) world


# What a build of the scene sets, remembered for the last few builds.
_BUILT = (
    "_kind",
    "_pairs_of",
    "_touched_by",
    "_resting",
    "_human_slots",
    "_zone_slots",
    "_geom_model",
    "_geom_data",
    "_tabled_pairs",
    "_fixed_contacts",
    "_index",
    "_names",
    "_joints",
    "_pair_table",
    "_views",
    "_where",
)
_REMEMBERED_BUILDS = 8
_PEOPLE_KEPT = 16  # the people a checker keeps a Human of (a service's session sees many)
# A person's pose (where they stand and reach) moves their capsules; their body (height) and
# margin make them. Builds are remembered by the body, and placed anew for the pose.
_PERSON_POSE = {"posture", "position", "yaw", "reach"}
_PERSON_BODY = {"name", "height", "margin"}
# So are obstacles' poses: a keep-out follows its person, a released object lands elsewhere.
_BUILD_KEY = {"humans": {"__all__": _PERSON_POSE}, "obstacles": {"__all__": {"pose"}}}


@dataclass
class _RobotGeometry:
    """What every checker of one robot (its description and hand postures, at one padding)
    builds alike: its allowed-collision matrix, its geometry objects and its own pairs. A task
    makes several checkers of a robot per step (the retreat after a release makes three), each
    of which built these (~15 ms)."""

    acm: dict[str, str]
    objects: list[tuple[pin.GeometryObject, str]]
    tables: list[tuple[ClearanceTable, list[tuple[int, int]]]]  # and the mesh shape pairs each stands for
    # Per part on the fixed base: its URDF collision shapes where they stand (finding them walks
    # every mesh of the robot, ~0.2 ms for a MADAR arm's base: a re-plan asked ~90 times).
    fixed_shapes: dict[int, list[tuple[coal.CollisionGeometry, coal.Transform3s]]]
    # Per part on the fixed base (in `fixed_shapes`' order): a ball holding its shapes, the
    # centres (P, 3) and radii (P,), so that a moved obstacle asks coal only about parts near it.
    fixed_balls: tuple[np.ndarray, np.ndarray]
    internal_pairs: list[tuple[int, int]] | None = None  # made by the first checker's first build
    # Per tabled shape pair (indices of `objects`): its triangles' trees (None: not two meshes),
    # made when first asked.
    mesh_pairs: dict[tuple[int, int], MeshPair | None] = field(default_factory=dict)


_BY_ROBOT: dict[tuple[object, float], _RobotGeometry] = {}  # by robot spec and padding, as robot_parts

# Balls this far apart or more hold shapes coal finds apart (its contact tolerance is ~1e-6 m).
_BALLS_APART = 1e-3


def _fixed_balls(
    fixed_shapes: dict[int, list[tuple[coal.CollisionGeometry, coal.Transform3s]]],
) -> tuple[np.ndarray, np.ndarray]:
    """Per part on the fixed base: a ball holding every one of its shapes' balls (none: no ball)."""
    centres, radii = [], []
    for shapes in fixed_shapes.values():
        balls = [
            (placement.transform(centre), radius)
            for shape, placement in shapes
            for centre, radius in [box_sphere(shape)]
        ]
        middle = np.mean([centre for centre, _ in balls], axis=0) if balls else np.zeros(3)
        centres.append(middle)
        radii.append(max((np.linalg.norm(centre - middle) + radius for centre, radius in balls), default=-np.inf))
    return np.array(centres).reshape(-1, 3), np.array(radii)


class CollisionChecker:
    """Robot vs scene, robot vs people, robot self-collision and carried objects vs the rest."""

    def __init__(self, robot: Robot, scene: Scene | None = None, padding: float = 0.0) -> None:
        self.robot = robot
        self.parts = robot_parts(robot, padding)
        if not self.parts:
            raise HriplanError(f"robot {robot.name!r}: {NO_COLLISION_SHAPES}")
        key = (robot.spec, padding)
        if key not in _BY_ROBOT:
            self.acm = load_acm(robot, robot_parts(robot))
            objects = self._robot_objects()
            fixed = self._fixed_shapes()
            _BY_ROBOT[key] = _RobotGeometry(self.acm, objects, self._tables(objects), fixed, _fixed_balls(fixed))
        self._robot = _BY_ROBOT[key]
        self.acm, self._robot_geometry = self._robot.acm, self._robot.objects
        self.humans: dict[str, Human] = {}
        self._people: Recent[tuple[str, float | None], Human] = Recent(_PEOPLE_KEPT)  # by name and height
        self.zones: SeparationZones | None = None
        self._builds: Recent[str, dict[str, object]] = Recent(_REMEMBERED_BUILDS)
        # Distance and person models, by what is carried and the people.
        self._people_models: Recent[str, tuple] = Recent(_REMEMBERED_BUILDS)
        # Per distance model: its pairs as geometry indices and the joint of each pair's robot part.
        self._distance_pairs: MadeFor[tuple[np.ndarray, np.ndarray]] = MadeFor(_REMEMBERED_BUILDS)
        # The scenes this checker copied lately, each with its contents as a build's key reads
        # them: given back (a keep-out's block ends with the scene before it), one is the
        # checker's own already and needs no copy (~0.1 ms each), nor its contents read (~35 us).
        self._copies: Recent[int, tuple[Scene, str]] = Recent(_REMEMBERED_BUILDS)
        # Per person: where their capsules are as posed now (made once a posing; every build and
        # every remembered build placed anew asks: ~40 us each, a dozen a re-plan). Forgotten
        # when the person is posed anew or is another Human (`_posed`, `pose_human`).
        self._placements: dict[str, tuple[list[pin.SE3], np.ndarray]] = {}
        self._people_placed = 0  # a new `_PLACINGS` stamp whenever the distance model's people are placed
        # Per distance model and the entries varying along the states: `_Route`.
        self._routes: MadeFor[_Route] = MadeFor(_REMEMBERED_BUILDS)
        self._statics_placed = 0  # counts placings of what is on no joint: a certifier placed before reads them again
        self._motion: Motion | None = None  # the joints that move, and where the rest stay (`moving`)
        self._held: Held | None = None  # while a view holds pairs still
        self.scene: Scene | None = None
        self.set_scene(scene or Scene())

    # -- building ---------------------------------------------------------------------------
    def _robot_objects(self) -> list[tuple[pin.GeometryObject, str]]:
        """The robot's parts, then the URDF shapes of the parts the ACM checks on meshes: the
        same in every scene, so built once (with their kinds)."""
        objects = [
            (pin.GeometryObject(part.name, part.joint, part.placement, part.geometry), "robot") for part in self.parts
        ]
        meshed = {name for pair, reason in self.acm.items() if reason == MESH for name in pair.split("|")}
        for part in self.parts:
            if part.name in meshed:
                objects += [(shape, f"mesh:{part.name}") for shape in part_collision_shapes(self.robot, part)]
        return objects

    def _tables(
        self, objects: list[tuple[pin.GeometryObject, str]]
    ) -> list[tuple[ClearanceTable, list[tuple[int, int]]]]:
        """The mesh pairs' clearance tables, each with the pairs of mesh shapes it certifies."""
        slots: dict[str, list[int]] = {}
        for i, (_, kind) in enumerate(objects):
            if kind.startswith("mesh:"):
                slots.setdefault(kind.split(":", 1)[1], []).append(i)
        return [
            (table, [tuple(sorted((i, j))) for i in slots[table.parts[0]] for j in slots[table.parts[1]]])
            for table in clearance_tables(self.robot, self.parts, self.acm)
        ]

    def _fixed_shapes(self) -> dict[int, list[tuple[coal.CollisionGeometry, coal.Transform3s]]]:
        return {
            p: [
                (shape.geometry, coal.Transform3s(shape.placement.rotation, shape.placement.translation))
                for shape in part_collision_shapes(self.robot, part)
            ]
            for p, part in enumerate(self.parts)
            if part.joint == 0
        }

    def set_scene(self, scene: Scene) -> None:
        """Replace the scene's contents (pairs are recomputed; the robot model is kept). The same
        scene again changes nothing."""
        self.set_world(scene, self.zones)

    def set_world(self, scene: Scene, zones: SeparationZones | None) -> None:
        """The scene and the people's separation zones (None: none) in one build, made when first
        asked: planning sets scenes it never checks in (a session's empty first scene, the scene
        a keep-out is added to and removed from around a call), and one asked only about people
        needs no collision model."""
        if scene == self.scene and zones == self.zones:
            return
        missing = sorted(set(zones.distances) - {h.name for h in scene.humans}) if zones else []
        if missing:
            raise HriplanError(f"the scene has no person {missing[0]!r} to keep a separation from")
        for obj in scene.attached:  # refused here, as when the scene was built at once
            self.robot.tool_frame(obj.arm)
        # The caller may change theirs in place later (not one of the checker's own).
        own = self._copies.get(id(scene))
        copy, contents = own if own is not None and own[0] is scene else (scene.model_copy(deep=True), None)
        try:
            humans = {spec.name: self._posed(spec) for spec in copy.humans}
        except HriplanError:  # a reach out of range: the people stay where the scene has them
            for spec in self.scene.humans if self.scene else []:
                self._posed(spec)
            raise
        self.scene, self.zones, self.humans = copy, zones, humans
        contents = contents or copy.model_dump_json(exclude=_BUILD_KEY)
        self._copies.put(id(copy), (copy, contents))  # held here, so its id is not reused while it is
        self._key = self._build_key(contents)
        self._stale = self._people_stale = True

    def _posed(self, spec: HumanSpec) -> Human:
        """The checker's Human of this person and body, posed as `spec` (made once: ~2 ms). The
        Human in the scene already, posed as `spec`, is left as it is, with its capsules'
        placements (a re-plan sets a dozen scenes on its checkers, most with the same people);
        any other forgets them."""
        human = self._people.get((spec.name, spec.height))
        if human is None:
            human = Human(spec)
            self._people.put((spec.name, spec.height), human)
        elif human.spec != spec:
            human.pose(spec)
        elif self.humans.get(spec.name) is human:
            return human
        self._placements.pop(spec.name, None)
        return human

    def _placed(self, name: str) -> list[pin.SE3]:
        """Where the person's capsules are in the world as the Human is posed now, in `capsules` order."""
        return self._placing(name)[0]

    def _placing(self, name: str) -> tuple[list[pin.SE3], np.ndarray]:
        """`_placed`, and the same as homogeneous matrices (k, 4, 4) for `_where`."""
        if name not in self._placements:
            placements = self.humans[name].capsule_placements()
            self._placements[name] = placements, np.array([p.homogeneous for p in placements]).reshape(-1, 4, 4)
        return self._placements[name]

    def _build_key(self, contents: str) -> str:
        """What makes a build: the scene's `contents` (JSON, not where things stand) and the zones."""
        key = (
            contents,
            None
            if self.zones is None
            else (
                sorted(self.zones.moving_joints),
                sorted((p, sorted(d.items())) for p, d in self.zones.distances.items()),
            ),
        )
        return repr(key)

    def _ready(self) -> None:
        """The build of the current scene and zones, or the remembered one of an earlier build
        (planning adds and removes keep-out and separation zones around every call), placed where
        everything stands now."""
        built = self._builds.get(self._key)
        if built is not None:
            vars(self).update(built)
            if any([self._place_obstacle(self._index[o.name], o.pose) for o in self.scene.obstacles]):
                self._pair_up()
            for name in self.humans:
                self._place_person(name)
        else:
            self._build_new()
        self._hold()
        self._remember()
        self._stale = False
        self._placed_statics()

    @property
    def geom_model(self) -> pin.GeometryModel:
        """The collision model of the current scene and zones (built if it was not)."""
        if self._stale:
            self._ready()
        return self._geom_model

    @property
    def geom_data(self) -> pin.GeometryData:
        if self._stale:
            self._ready()
        return self._geom_data

    @property
    def kind(self) -> list[str]:
        """Per geometry of `geom_model`: robot, mesh:<part>, attached:<arm>, obstacle, human, zone."""
        if self._stale:
            self._ready()
        return self._kind

    def _remember(self) -> None:
        """Keep the current build (the most recent last) under its key."""
        self._builds.put(self._key, {name: getattr(self, name) for name in _BUILT})

    def _build_new(self) -> None:
        scene = self.scene
        gm = pin.GeometryModel()
        self._kind: list[str] = []
        for geometry, kind in self._robot_geometry:
            gm.addGeometryObject(pin.GeometryObject(geometry))
            self._kind.append(kind)
        for obj, geometry in zip(scene.attached, self._attached_objects()):
            gm.addGeometryObject(geometry)
            self._kind.append(f"attached:{obj.arm}")
        self._touched_by = {o.name: o.touched_by for o in scene.obstacles if o.touched_by is not None}
        self._resting = {(a.name, support) for a in scene.attached for support in a.resting_on}
        for obstacle in scene.obstacles:
            gm.addGeometryObject(pin.GeometryObject(obstacle.name, 0, obstacle.pose.se3(), obstacle.shape.geometry()))
            self._kind.append("obstacle")
        self._human_slots: dict[str, list[int]] = {}
        for spec in scene.humans:
            self._human_slots[spec.name] = [gm.addGeometryObject(g) for g in self._capsule_objects(spec)]
            self._kind += ["human"] * len(self._human_slots[spec.name])
        self._zone_slots = self._add_zones(gm)
        self._geom_model = gm
        # Where each geometry is placed in the model, kept as the checker places those on no
        # joint (`_place_obstacle`, `_place_person`): the certifier reads them here.
        self._where = np.array([g.placement.homogeneous for g in gm.geometryObjects])
        self._pair_up()
        self._index = {g.name: i for i, g in enumerate(gm.geometryObjects)}

    def _attached_objects(self) -> list[pin.GeometryObject]:
        """The carried objects of the scene, on their hands' tool frames."""
        objects = []
        for obj in self.scene.attached:
            frame = self.robot.model.frames[self.robot.frame_id(self.robot.tool_frame(obj.arm))]
            placement = frame.placement * obj.grasp.se3()
            objects.append(pin.GeometryObject(obj.name, frame.parentJoint, placement, obj.shape.geometry()))
        return objects

    def _capsule_objects(self, spec: HumanSpec) -> list[pin.GeometryObject]:
        """A person's capsules grown by their margin, where they stand now."""
        human = self.humans[spec.name]
        return [
            pin.GeometryObject(
                f"{spec.name}/{capsule.name}", 0, placement, coal.Capsule(capsule.radius + spec.margin, capsule.length)
            )
            for capsule, placement in zip(human.capsules, self._placed(spec.name))
        ]

    def _add_zones(self, gm: pin.GeometryModel) -> dict[str, list[tuple[int, int]]]:
        """The separation zones' grown capsules; per person: (geometry slot, capsule index)."""
        slots: dict[str, list[tuple[int, int]]] = {}
        for name, distances in (self.zones.distances if self.zones else {}).items():
            human = self.humans[name]
            slots[name] = []
            for k, (capsule, placement) in enumerate(zip(human.capsules, self._placed(name))):
                if capsule.name in distances:
                    grown = coal.Capsule(capsule.radius + distances[capsule.name], capsule.length)
                    label = f"{name}/{capsule.name} ({ZONE_NAMING} {distances[capsule.name]:.3f} m)"
                    slots[name].append((gm.addGeometryObject(pin.GeometryObject(label, 0, placement, grown)), k))
                    self._kind.append("zone")
        return slots

    def _people_ready(self) -> None:
        """The distance model (robot parts and people only, with robot-person pairs: distances in
        one C++ call) and the person models, placed where the people stand now. They depend on
        what is carried and on the people's bodies only, so builds that differ in obstacles and
        zones (planning's keep-outs) share them; they are made apart from the collision model."""
        key = self.scene.model_dump_json(include={"attached": True, "humans": {"__all__": _PERSON_BODY}})
        kept = self._people_models.get(key)
        if kept is None:
            kept = (*self._new_distance_model(), self._new_person_models())
            self._people_models.put(key, kept)
        self._distance_model, self._distance_data, self._distance_slots, self._person_models = kept
        for name in self.humans:  # built where the people stood then
            self._place_person_models(name)
        self._people_stale = False

    def _new_distance_model(self) -> tuple[pin.GeometryModel, pin.GeometryData, dict[str, int]]:
        """The distance model, its data and each person's first capsule in it."""
        dm = pin.GeometryModel()
        for geometry, kind in self._robot_geometry:
            if kind == "robot":
                dm.addGeometryObject(pin.GeometryObject(geometry))
        robot, first = dm.ngeoms, {}
        for spec in self.scene.humans:
            first[spec.name] = dm.ngeoms
            for capsule in self._capsule_objects(spec):
                dm.addGeometryObject(capsule)
        for a in range(robot):
            for b in range(robot, dm.ngeoms):
                dm.addCollisionPair(pin.CollisionPair(a, b))
        return dm, person_distance_data(dm), first

    def _new_person_models(
        self,
    ) -> dict[str, tuple[pin.GeometryModel, pin.GeometryData, list[str], np.ndarray, list[str]]]:
        """Per person: robot parts and carried objects against the person's bare capsules (no
        margin: separation is measured to the body), for speed and separation monitoring."""
        movers = [pin.GeometryObject(g) for g, kind in self._robot_geometry if kind == "robot"]
        movers += self._attached_objects()
        models = {}
        for name, human in self.humans.items():
            pm = pin.GeometryModel()
            for mover in movers:
                pm.addGeometryObject(pin.GeometryObject(mover))
            for capsule, placement in zip(human.capsules, self._placed(name)):
                k = pm.addGeometryObject(
                    pin.GeometryObject(capsule.name, 0, placement, coal.Capsule(capsule.radius, capsule.length))
                )
                for a in range(len(movers)):
                    pm.addCollisionPair(pin.CollisionPair(a, k))
            objects, pairs = pm.geometryObjects, pm.collisionPairs
            models[name] = (
                pm,
                person_distance_data(pm),
                [objects[p.first].name for p in pairs],
                np.array([objects[p.first].parentJoint for p in pairs]),
                [objects[p.second].name for p in pairs],
            )
        return models

    def _checked(self, i: int, j: int) -> bool:
        ki, kj = self._kind[i], self._kind[j]
        names = (self._names[i], self._names[j])
        static = ("obstacle", "human", "zone")
        if ki in static and kj in static:
            return False
        if ki == "robot" and kj == "robot":
            return f"{names[0]}|{names[1]}" not in self.acm and f"{names[1]}|{names[0]}" not in self.acm
        if ki.startswith("mesh:") or kj.startswith("mesh:"):
            # Meshes stand in for their part only against the parts the ACM names for them.
            if not (ki.startswith("mesh:") and kj.startswith("mesh:")):
                return False
            a, b = ki.split(":", 1)[1], kj.split(":", 1)[1]
            return MESH in (self.acm.get(f"{a}|{b}"), self.acm.get(f"{b}|{a}"))
        if (names[0], names[1]) in self._resting or (names[1], names[0]) in self._resting:
            return False  # a held object being lifted off what it stands on
        for (k, a), (other, b) in (((ki, i), (kj, j)), ((kj, j), (ki, i))):
            if k == "robot" and other == "obstacle" and self.parts[a].joint == 0:
                return self._fixed_part_touches(a, b)
        for k, this, other in ((ki, i, j), (kj, j, i)):
            if self._kind[other] != "robot":
                continue
            # A carried object touches its own hand and wrist by design, and so does an object
            # the hand is closing on.
            arm = k.split(":", 1)[1] if k.startswith("attached:") else self._touched_by.get(self._names[this])
            if arm is not None:
                return not self._on_hand(other, arm)
        return True

    def _on_hand(self, part_index: int, arm: str) -> bool:
        """Is the part on `arm`'s hand or wrist: carried by the joint that carries its tool frame
        (the hand's fingers are locked onto it)? By the kinematics, not by names: TALOS's
        `gripper_right_*` links do not start with its arm's name."""
        return self._joints[part_index] == self._tool_joint(arm)

    def _tool_joint(self, arm: str) -> int:
        return self.robot.model.frames[self.robot.frame_id(self.robot.tool_frame(arm))].parentJoint

    def _pair_up(self) -> None:
        gm = self._geom_model
        gm.removeAllCollisionPairs()
        self._fixed_contacts: set[tuple[int, int]] = set()
        # Read once: a pinocchio object's field costs about a microsecond from Python.
        self._names, self._joints = zip(*[(g.name, g.parentJoint) for g in gm.geometryObjects])
        robot = len(self._robot_geometry)
        if self._robot.internal_pairs is None:  # the robot's own pairs are the same in every scene
            self._robot.internal_pairs = [
                (i, j) for i in range(robot) for j in range(i + 1, robot) if self._checked(i, j)
            ]
        # A scene geometry pairs only with robot parts and carried objects (added before the rest).
        movers = [i for i, kind in enumerate(self._kind) if kind == "robot" or kind.startswith("attached:")]
        zoned = {i for i in movers if self._joints[i] in self.zones.moving_joints} if self.zones else set()
        pairs = list(self._robot.internal_pairs)
        for j in range(robot, gm.ngeoms):
            before = [i for i in movers if i < j]
            if self._kind[j] == "human":  # a person against every part and carried object
                pairs += [(i, j) for i in before]
            elif self._kind[j] == "zone":  # a separation zone against the moving ones only
                pairs += [(i, j) for i in before if i in zoned]
            else:
                pairs += [(i, j) for i in before if self._checked(i, j)]
        chosen = np.zeros((gm.ngeoms, gm.ngeoms), dtype=bool)
        chosen[tuple(np.array(pairs, dtype=int).reshape(-1, 2).T)] = True
        gm.setCollisionPairs(chosen, True)  # in one call, in the order of sorted(pairs)
        self._geom_data = gm.createData()
        ask_contacts(self._geom_data)
        self._pairs_of: dict[str, list[int]] = {}  # a geometry's pairs, as `touches` asks them
        # The mesh pairs a clearance table stands for are left out of the broad phase: `in_collision`
        # asks the table first, `contacts` checks them on their own.
        listed = {pair: k for k, pair in enumerate(sorted(pairs))}
        tabled = [(table, [listed[p] for p in shape_pairs]) for table, shape_pairs in self._robot.tables]
        self._tabled_pairs = [k for _, ks in tabled for k in ks]
        for k in self._tabled_pairs:
            self._geom_data.deactivateCollisionPair(k)
        self._pair_table = np.array(sorted(pairs), dtype=int).reshape(-1, 2)
        # A table free in every cell proves the pair never touches (the crossbar and a shoulder).
        asked = [(table, ks) for table, ks in tabled if not table.free.all()]
        self._views = Views.of(self._pair_table, gm.ngeoms, self._tabled_pairs, asked)
        self._hold()  # the view of the motion under way, if one is

    def _fixed_part_touches(self, part: int, obstacle: int) -> bool:
        """Does a part on the robot's fixed base touch an obstacle, on its URDF collision shapes?"""
        other = self._geom_model.geometryObjects[obstacle]
        where = coal.Transform3s(other.placement.rotation, other.placement.translation)
        for shape, placement in self._robot.fixed_shapes[part]:
            if coal.collide(shape, placement, other.geometry, where, coal.CollisionRequest(), coal.CollisionResult()):
                self._fixed_contacts.add((part, obstacle))
                return True
        return False

    # -- a motion of some joints ----------------------------------------------------------------
    @contextmanager
    def moving(self, joints: str | Sequence[int], q_base: np.ndarray) -> Iterator[None]:
        """Within the block, a motion of the group `joints` (or of these configuration entries),
        every other entry at `q_base`: the pairs it cannot move (`still_pairs.py`) are checked
        once, at `q_base`, and left out of the per-state checks; a colliding one makes every state
        collide, and `contacts` still names it. A state whose other entries differ from
        `q_base` has those pairs checked where it has them. Blocks nest; leaving restores the
        checks as they were."""
        entries = self.robot.group_indices(joints) if isinstance(joints, str) else joints
        before = self._motion
        self._motion = Motion.of(self._moves, entries, q_base)
        try:
            if not self._stale:
                self._hold()
            yield
        finally:
            self._motion = before
            if not self._stale:
                self._hold()

    def _hold(self) -> None:
        """Apply the current motion's view (`still_pairs.View`) to the build, made once per build
        and motion's moved joints, with its own broad phase and certifier."""
        views, moved = self._views, None if self._motion is None else self._motion.moved
        view = views.by_moved.get(moved)
        if view is None:
            view = views.by_moved[moved] = views.held(moved, self._pair_table, self._joints)
        views.apply(view, self._geom_model, self._geom_data)
        if view.broadphase is None:  # the naive manager loops over the pairs with an AABB test first: fastest here
            view.broadphase = pin.BroadPhaseManager_NaiveCollisionManager(
                self.robot.model, self._geom_model, self._geom_data
            )
        self._view, self._tabled, self._broadphase = view, view.tabled, view.broadphase
        motion, held = self._motion, self._held
        if motion is None or not view.holds:
            self._held = None
        elif held is None or held.view is not view or held.at_base != motion.at_base:  # else its answer stands
            self._held = Held(view, motion.at_base)

    def _placed_statics(self) -> None:
        """Something on no joint moved (an obstacle, a person): the certifier reads it again, and
        the still pairs are asked again at the base."""
        self._statics_placed += 1
        if self._held is not None:
            self._held.answer = None

    def _held_touch(self, q: np.ndarray) -> bool:
        """Does a pair the motion holds still touch at `q`? Its answer at the base, asked once,
        if `q` is at the base outside the moving joints; else asked at `q`."""
        held, motion = self._held, self._motion
        if motion.fixed is not None and q[motion.fixed].tobytes() != motion.at_base:
            return self._still_touch(q)
        if held.answer is None:
            held.answer = self._still_at_base()
        return held.answer

    def _still_at_base(self) -> bool:
        """Does a still pair touch at the motion's base? Kept on the view with the base and where
        everything on no joint stood (`_where`): a build used again where nothing moved (every
        scene switch places its people anew) answers as before, without coal (~130 us)."""
        motion, view = self._motion, self._view
        stood = self._where.tobytes()
        if view.still_asked is None or view.still_asked[:2] != (motion.at_base, stood):
            view.still_asked = (motion.at_base, stood, self._still_touch(motion.base))
        return view.still_asked[2]

    def _first_held(self, qs: np.ndarray) -> int | None:
        """The first of the states `qs` at which a pair the motion holds still touches, or None."""
        if self._held is None or not len(qs):
            return None
        stays = self._motion.stays_many(qs)
        at_base = np.flatnonzero(stays)
        first = int(at_base[0]) if len(at_base) and self._held_touch(qs[at_base[0]]) else len(qs)
        hit = next((k for k in np.flatnonzero(~stays[:first]).tolist() if self._still_touch(qs[k])), first)
        return hit if hit < len(qs) else None

    def _still_touch(self, q: np.ndarray) -> bool:
        """Does a still pair of the current view touch at `q`, asked of coal as the full check would?"""
        return self._view.still_touch(self.robot.model, self.robot.data, self._geom_model, self._geom_data, q)

    # -- updates (no rebuild of the robot) -------------------------------------------------------------
    def move_obstacle(self, name: str, pose: Pose) -> None:
        if name not in {o.name for o in self.scene.obstacles}:
            raise HriplanError(f"the scene has no obstacle {name!r}")
        self.scene = self.scene.model_copy(
            update={
                "obstacles": [
                    o.model_copy(update={"pose": pose}) if o.name == name else o for o in self.scene.obstacles
                ]
            }
        )
        self._placed_statics()
        if not self._stale and self._place_obstacle(self._index[name], pose):
            self._pair_up()
            self._remember()

    def _place_obstacle(self, i: int, pose: Pose) -> bool:
        """Put obstacle `i` at `pose` in the current build; True if a part on the fixed base
        touches it now and did not before, or the other way round (its pairs must change)."""
        placement = pose.se3()
        matrix = placement.homogeneous
        if np.array_equal(self._where[i], matrix):
            return False
        self._geom_model.geometryObjects[i].placement = placement
        self._where[i] = matrix
        before = {p for p, o in self._fixed_contacts if o == i}
        self._fixed_contacts -= {(p, i) for p in before}
        return {p for p in self._near_base(i) if self._fixed_part_touches(p, i)} != before

    def _near_base(self, obstacle: int) -> list[int]:
        """The parts on the fixed base whose ball comes within `_BALLS_APART` of the obstacle's
        where it stands: no other can touch it (a moved obstacle asked coal about each of
        MADAR's nine, ~10 us each; a keep-out follows its person, away from the base)."""
        other = self._geom_model.geometryObjects[obstacle]
        centre, radius = box_sphere(other.geometry)
        centres, radii = self._robot.fixed_balls
        gaps = np.linalg.norm(centres - other.placement.act(centre), axis=1) - radii - radius
        return [p for p, gap in zip(self._robot.fixed_shapes, gaps.tolist()) if gap < _BALLS_APART]

    def pose_human(self, spec: HumanSpec) -> None:
        """Re-pose a person already in the scene: only capsule placements change (and the scene).
        The checker keeps a copy of `spec`, as of a scene: its caller may change theirs later."""
        if spec.name not in self.humans:
            raise HriplanError(f"the scene has no person {spec.name!r}")
        spec = spec.model_copy(deep=True)
        self._placements.pop(spec.name, None)
        self.humans[spec.name].pose(spec)
        self.scene = self.scene.model_copy(
            update={"humans": [spec if h.name == spec.name else h for h in self.scene.humans]}
        )
        if not self._stale:
            self._place_person(spec.name)
        if not self._people_stale:
            self._place_person_models(spec.name)

    def _place_person(self, name: str) -> None:
        """Set the person's capsules, and the separation zones grown from them, where the Human
        stands now, in the build. Builds are remembered without the people's poses (a person who
        moved changes no pair), so using one places them."""
        placements, where = self._placing(name)
        self._placed_statics()
        objects = self._geom_model.geometryObjects
        slots, zones = self._human_slots[name], self._zone_slots.get(name, [])
        for slot, placement in zip(slots, placements):
            objects[slot].placement = placement
        for slot, k in zones:
            objects[slot].placement = placements[k]
        self._where[slots] = where
        self._where[[slot for slot, _ in zones]] = where[[k for _, k in zones]]

    def _place_person_models(self, name: str) -> None:
        """The same in the distance model and the person's model."""
        placements = self._placed(name)
        self._people_placed = next(_PLACINGS)
        first = self._distance_slots[name]
        for k, placement in enumerate(placements):
            self._distance_model.geometryObjects[first + k].placement = placement
        person_model = self._person_models[name][0]
        first = person_model.ngeoms - len(placements)
        for k, placement in enumerate(placements):
            person_model.geometryObjects[first + k].placement = placement

    # -- queries --------------------------------------------------------------------------
    def in_collision(self, q: np.ndarray) -> bool:
        """True if any checked pair collides at planning configuration `q`. A tabled mesh pair is
        checked on its meshes only where its table cannot certify it (the broad phase placed them).
        With the kernels on, the certifier's verdict first: coal is asked only about what it
        cannot clear (`_free_certifier`)."""
        if self._stale:
            self._ready()
        if self._held is not None and self._held_touch(q):
            return True
        view = self._view
        certifier = view.certifier  # `_free_certifier`'s answer when nothing moved: no call (~0.1 us)
        if not certifier or view.placed != self._statics_placed or not kernels_on():
            certifier = self._free_certifier()
        if certifier is not None and (verdict := certifier.verdict(q)) is not None:
            return bool(verdict[0] or verdict[1]) and self._left_touch(q, *verdict)
        if pin.computeCollisions(self.robot.model, self.robot.data, self._broadphase, q, True):
            return True
        if not self._tabled:
            return False
        values = q.tolist()
        return any(not table.certified(values) and self._meshes_touch(pairs) for table, pairs in self._tabled)

    def compiled_verdict(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """The certifier's packed arrays, for compiled code to ask its verdict
        (`certifier_kernels.verdict_one`) about states that differ from `q` only in joints that
        move in the current motion (`moving`; any, outside one): a state it calls free is free
        for `in_collision`, any other must be asked there.
        None where `in_collision` must be asked about every state: the kernels off, no certifier
        for this robot, or a pair the motion holds still touching at `q`."""
        if self._stale:
            self._ready()
        if self._held is not None and self._held_touch(q):
            return None
        certifier = self._free_certifier()
        return None if certifier is None else certifier.packed

    def first_collision(self, qs: np.ndarray) -> int | None:
        """The index of the first of the states `qs` (N, nq) in collision, None if none: each
        state checked as `in_collision` does, in order, until one collides; the clearance
        tables asked about every state at once (a path's dense validation)."""
        if self._stale:
            self._ready()
        held = self._first_held(qs)  # a still pair touches there: the states after it are not asked
        qs = qs[:held]
        model, data, broadphase = self.robot.model, self.robot.data, self._broadphase
        certifier = self._free_certifier()
        # The states the certifier does not call free, in order (all, with it off).
        if certifier is not None:
            asked, touching, verdicts = certifier.left_over(qs)
        else:
            asked, touching, verdicts = list(range(len(qs))), [False] * len(qs), [None] * len(qs)
        # The tables are asked about the states the certifier left to coal whole.
        undecided = [k for k, proven, verdict in zip(asked, touching, verdicts) if verdict is None and not proven]
        certified = np.ones((len(qs), len(self._tabled)), dtype=bool)
        if undecided and self._tabled:
            states = np.asarray(qs)[undecided]
            answers = np.array([table.certified_many(states) for table, _ in self._tabled], dtype=bool)
            certified[undecided] = answers.reshape(len(self._tabled), len(states)).T
        for k, proven, verdict in zip(asked, touching, verdicts):
            q = qs[k]
            if proven:  # a capsule in a box: coal finds it collide
                return k
            if verdict is not None:  # not free: some pairs or tables left to coal
                if self._left_touch(q, *verdict):
                    return k
                continue
            if pin.computeCollisions(model, data, broadphase, q, True):
                return k
            if any(not free and self._meshes_touch(pairs) for (_, pairs), free in zip(self._tabled, certified[k])):
                return k
        return held

    def _free_certifier(self) -> FreeCertifier | None:
        """The compiled certifier of this build's broad-phase pairs and tables, placed where the
        scene stands now; None with the kernels off (`kernel_switch`) or for a robot it cannot
        walk. It says free only where coal and the tables would, so answers are the same."""
        if not kernels_on():
            return None
        view = self._view
        if view.certifier is None:
            from hriplan.robots.free_certifier import FreeCertifier

            active = np.array(self._geom_data.activeCollisionPairs, dtype=bool)
            pairs = np.array([(p.first, p.second) for p in self._geom_model.collisionPairs], dtype=np.int64)
            tables = [table for table, _ in self._tabled]
            people = [slots + [s for s, _ in self._zone_slots.get(n, [])] for n, slots in self._human_slots.items()]
            ids = np.flatnonzero(active)
            made = FreeCertifier.of(
                self.robot.model,
                self._geom_model,
                pairs.reshape(-1, 2)[ids],
                tables,
                people,
                ids,
                self._tabled_meshes(),
            )
            view.certifier, view.placed = made or False, self._statics_placed  # False: none for this robot
        elif view.certifier and view.placed != self._statics_placed:
            view.certifier.place(self._where)
            view.placed = self._statics_placed
        return view.certifier or None

    def _left_touch(self, q: np.ndarray, uncertified: int, pairs: tuple[int, ...]) -> bool:
        """With every other broad-phase pair clear at `q` (the certifier's word): does one of
        `pairs` (ids in the collision model) or a mesh pair of a table that does not certify `q`
        (bit k: `_tabled[k]`) touch? Each asked of coal as the broad phase would, placed here (a
        table's mesh pairs through `_meshes_touch`: their triangle trees first)."""
        pin.updateGeometryPlacements(self.robot.model, self.robot.data, self._geom_model, self._geom_data, q)
        if any(pin.computeCollision(self._geom_model, self._geom_data, k) for k in pairs):
            return True
        return any(uncertified >> k & 1 and self._meshes_touch(ks) for k, (_, ks) in enumerate(self._tabled))

    def _meshes_touch(self, pairs: list[int]) -> bool:
        """Does any of a table's mesh pairs collide, where the broad phase placed them? With the
        kernels on, each is decided on its triangles first (`mesh_pairs.MeshPair`: a few us
        against coal's ~20-70 near contact), coal asked only where they prove nothing."""
        return any(self._mesh_pair_touches(k) for k in pairs)

    def _mesh_pair_touches(self, k: int) -> bool:
        """Does pair `k` collide where placed: its trees' verdict, else (or with the kernels off)
        coal's."""
        if kernels_on():
            first, second = (int(i) for i in self._pair_table[k])
            meshes = self._mesh_pair(first, second)
            if meshes is not None:
                placed = self._geom_data.oMg
                verdict = meshes.touches(placed[first], placed[second])
                if verdict is not None:
                    return verdict
        return pin.computeCollision(self._geom_model, self._geom_data, k)

    def _mesh_pair(self, first: int, second: int) -> MeshPair | None:
        """The trees of geometries `first` and `second` (collision model indices) if both are
        meshes, made once per robot geometry (8-10 ms a MADAR pair). Kernels on only."""
        if (first, second) not in self._robot.mesh_pairs:
            from hriplan.robots.mesh_pairs import MeshPair  # numba's: with the kernels only

            objects = self._geom_model.geometryObjects
            self._robot.mesh_pairs[first, second] = MeshPair.of(objects[first].geometry, objects[second].geometry)
        return self._robot.mesh_pairs[first, second]

    def _tabled_meshes(self) -> list[list[tuple[MeshPair, int, int]] | None]:
        """Per table, its mesh pairs' trees with their geometries, for the certifier to decide
        them on their triangles (`FreeCertifier`); None for a table with a pair that is not two
        meshes (coal decides it)."""
        out = []
        for _, ks in self._tabled:
            found = [
                (self._mesh_pair(*pair), *pair) for pair in (tuple(int(i) for i in self._pair_table[k]) for k in ks)
            ]
            out.append(None if any(meshes is None for meshes, _, _ in found) else found)
        return out

    def contacts(self, q: np.ndarray) -> list[Contact]:
        """Every colliding pair at `q`, by name (for error messages and reports). A free state
        lists nothing: reading every pair's result back costs more than computing them."""
        if self._stale:
            self._ready()
        with self._views.every_pair(self._geom_model, self._geom_data):  # a motion's still pairs too
            hit = pin.computeCollisions(self.robot.model, self.robot.data, self._geom_model, self._geom_data, q, False)
        tabled = [pin.computeCollision(self._geom_model, self._geom_data, k) for k in self._tabled_pairs]
        if not hit and not any(tabled):
            return []
        names = self._geom_model.geometryObjects
        return [
            Contact(names[p.first].name, names[p.second].name)
            for p, r in zip(self._geom_model.collisionPairs, self._geom_data.collisionResults)
            if r.isCollision()
        ]

    def touches(self, q: np.ndarray, name: str) -> bool:
        """Does the geometry `name` touch anything it is checked against at `q`? Only its own
        pairs are computed (a retreat asks this at every dense state: `contacts` computes all)."""
        if self._stale:
            self._ready()
        pairs = self._pairs_of.get(name)
        if pairs is None:
            i = self._index.get(name)
            listed = self._geom_model.collisionPairs
            pairs = [k for k, p in enumerate(listed) if i in (p.first, p.second)] if i is not None else []
            self._pairs_of[name] = pairs
        if not pairs:
            return False
        pin.updateGeometryPlacements(self.robot.model, self.robot.data, self._geom_model, self._geom_data, q)
        return any(pin.computeCollision(self._geom_model, self._geom_data, k) for k in pairs)

    def human_distances(self, qs: np.ndarray) -> list[tuple[float, str, str]]:
        """Per planning configuration of a path `qs` (N, nq): (distance, robot part, human part) of
        the closest robot-human pair; inf without people. A part no joint moves along the path is
        as far from everyone at every state, so its pairs are measured once (a path moves one
        group: most of MADAR stands still), the others at every state, in one C++ call each."""
        if self._people_stale:
            self._people_ready()
        dm = self._distance_model
        if not dm.collisionPairs or not len(qs):
            return [(float("inf"), "", "")] * len(qs)
        qs = np.asarray(qs, dtype=float)
        pairs, _ = self._distance_pair_table()
        route = self._route(qs)
        moving = route.moving
        # Per state (distance, pair): the least, and of equal ones the first pair, as one call over all.
        ranked: list[tuple[float, int]] = [(float("inf"), -1)] * len(qs)
        if not moving.all():  # the still parts: the same at every state
            ranked = [self._still_closest(route, qs[0])] * len(qs)
        if moving.any():
            with self._only_pairs(moving):
                ranked = [min(r, self._closest_at(q)) for r, q in zip(ranked, qs)]
        names = [g.name for g in dm.geometryObjects]
        return [(d, names[pairs[k, 0]], names[pairs[k, 1]]) for d, k in ranked]

    def closest_human(self, qs: np.ndarray, nearest: NearestPairs | None = None) -> tuple[float, str, str]:
        """The closest robot-person pair over the states `qs` (N, nq): the least of
        `human_distances(qs)` and its pair (of equal ones, the first state's); (inf, "", "")
        without people or states. A path report keeps only this one number, so not every pair
        is measured at every state. The still parts are measured once (as there). Every moving
        pair gets a lower bound per state (`PartSpheres`: its part's bounding sphere against the
        grown capsule's axis); the state of the least bound is measured on every moving pair,
        then only the pairs whose bound comes within the closest found at some state, at the
        states in the order of their bound until it passes the closest found, each state through
        coal as there. A pair or state whose bound is above the closest found cannot hold a
        closer distance, nor an equal one (the bound is 1e-4 m below coal's), so the least, its
        first state and that state's first pair of the least are those of `human_distances`.
        `nearest` finds the moving pairs' least instead (`NearestPairs`: the compiled route)."""
        if not len(qs):
            return (float("inf"), "", "")
        if self._people_stale:
            self._people_ready()
        dm = self._distance_model
        if not dm.collisionPairs:
            return (float("inf"), "", "")
        qs = np.asarray(qs, dtype=float)
        pairs, _ = self._distance_pair_table()
        route = self._route(qs)
        moving = route.moving
        best = (float("inf"), 0, -1)  # (distance, state, pair): the least, then the first state, then pair
        if not moving.all():
            distance, pair = self._still_closest(route, qs[0])
            best = (distance, 0, pair)
        if moving.any() and nearest is not None:
            best = min(best, nearest(self.robot.model, dm, route.joints, qs, best[0], self._people_placed))
        elif moving.any():
            floor, rows = self._moving_floors(qs, moving)
            first = int(np.argmin(floor.min(axis=1)))
            if floor[first].min() <= best[0]:
                with self._only_pairs(moving):
                    distance, pair = self._closest_at(qs[first])
                best = min(best, (distance, first, pair))
            near = floor.min(axis=0) <= best[0]
            active = np.zeros(len(pairs), dtype=bool)
            active[rows[near]] = True
            bound = floor[:, near].min(axis=1, initial=np.inf)
            with self._only_pairs(active):
                for state in np.argsort(bound, kind="stable").tolist():
                    if bound[state] > best[0]:
                        break
                    if state != first:
                        distance, pair = self._closest_at(qs[state])
                        best = min(best, (distance, state, pair))
        objects = dm.geometryObjects
        return best[0], objects[int(pairs[best[2], 0])].name, objects[int(pairs[best[2], 1])].name

    def _moving_floors(self, qs: np.ndarray, moving: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A lower bound on the distance of each of the distance model's `moving` pairs at each
        state (N, R), and those pairs' indices (R,)."""
        pairs, _ = self._distance_pair_table()
        objects = self._distance_model.geometryObjects
        parts, capsules = sorted(set(pairs[moving, 0].tolist())), sorted(set(pairs[moving, 1].tolist()))
        placements = [objects[b].placement for b in capsules]
        floors = PartSpheres.of(self.robot.model, self._distance_model, parts).floors(
            qs,
            np.array([m.translation for m in placements]),
            np.array([m.rotation[:, 2] for m in placements]),
            np.array([objects[b].geometry.halfLength for b in capsules]),
            np.array([objects[b].geometry.radius for b in capsules]),
        )
        index = np.full((self._distance_model.ngeoms,) * 2, -1, dtype=int)
        index[pairs[:, 0], pairs[:, 1]] = np.arange(len(pairs))
        return floors.reshape(len(qs), -1), index[np.ix_(parts, capsules)].reshape(-1)

    def _route(self, qs: np.ndarray) -> _Route:
        """The distance model's `_Route` for the entries varying along `qs` (N, nq): its moving
        pairs those whose robot part rides on a joint that a varying entry moves."""
        varying = np.ptp(qs, axis=0) > 0.0

        def route() -> _Route:
            _, joints = self._distance_pair_table()
            moving = self._moves[varying].any(axis=0)[joints]
            still = self._moves[:, joints[~moving]].any(axis=1)
            return _Route(moving, frozenset(joints[moving].tolist()), still)

        return self._routes.made((self._distance_model,), route, varying.tobytes())

    def _still_closest(self, route: _Route, q: np.ndarray) -> tuple[float, int]:
        """(distance, pair) of the closest still pair of `route` at `q`: asked of coal again only
        when the people were placed anew or a still pair's part stands elsewhere (its entries in
        `q` differ), else the last answer, the same numbers (~50 us a path report)."""
        key = (self._people_placed, q[route.still_entries].tobytes())
        if route.still_asked is None or route.still_asked[0] != key:
            with self._only_pairs(~route.moving):
                route.still_asked = (key, self._closest_at(q))
        return route.still_asked[1]

    @cached_property
    def _moves(self) -> np.ndarray:
        """(nq, njoints): does configuration entry i move joint j (a joint on j's chain, the
        universe aside, holds i)? Read once: walking the chains in Python at every call cost
        ~0.4 ms, a tenth of the closest approach's."""
        model = self.robot.model
        moves = np.zeros((model.nq, model.njoints), dtype=bool)
        for j in range(model.njoints):
            for c in model.supports[j]:
                if c > 0:
                    moves[model.idx_qs[c] : model.idx_qs[c] + model.nqs[c], j] = True
        return moves

    @contextmanager
    def _only_pairs(self, active: np.ndarray) -> Iterator[None]:
        """The distance model's pairs `active` (a flag a pair) alone active, within the block."""
        dm, data = self._distance_model, self._distance_data
        data.setActiveCollisionPairs(dm, self._pair_map(active), False)
        try:
            yield
        finally:
            data.setActiveCollisionPairs(dm, self._pair_map(np.ones(len(active), dtype=bool)), False)

    def _closest_at(self, q: np.ndarray) -> tuple[float, int]:
        """(distance, pair) of the distance model's closest active pair at `q`, in one C++ call."""
        k = pin.computeDistances(self.robot.model, self.robot.data, self._distance_model, self._distance_data, q)
        return float(self._distance_data.distanceResults[k].min_distance), k

    def _distance_pair_table(self) -> tuple[np.ndarray, np.ndarray]:
        """The distance model's pairs as geometry indices (k, 2) and the joint carrying each
        pair's robot part (k): read from pinocchio once per distance model, not at every call."""
        dm = self._distance_model

        def table() -> tuple[np.ndarray, np.ndarray]:
            pairs = np.array([(p.first, p.second) for p in dm.collisionPairs], dtype=int).reshape(-1, 2)
            return pairs, np.array([dm.geometryObjects[int(a)].parentJoint for a in pairs[:, 0]], dtype=int)

        return self._distance_pairs.made((dm,), table)

    def _pair_map(self, active: np.ndarray) -> np.ndarray:
        """The distance model's pairs `active` (a flag a pair) as the map of geometries pinocchio takes."""
        pairs, _ = self._distance_pair_table()
        chosen = np.zeros((self._distance_model.ngeoms,) * 2, dtype=bool)
        chosen[pairs[active, 0], pairs[active, 1]] = chosen[pairs[active, 1], pairs[active, 0]] = True
        return chosen

    def person_pairs(self, q: np.ndarray, person: str) -> PersonPairs:
        """Every robot part and carried object against every capsule of `person`, at `q`."""
        measured = self.person_distances(q, person)
        results = self._person_models[person][1].distanceResults
        return PersonPairs(
            **vars(measured),
            robot_point=np.array([r.getNearestPoint1() for r in results]).reshape(-1, 3),
            person_point=np.array([r.getNearestPoint2() for r in results]).reshape(-1, 3),
        )

    def person_distances(self, q: np.ndarray, person: str) -> PairDistances:
        """`person_pairs` without the closest points, which cost ten times coal's distances to
        read back (~0.65 ms for MADAR's ~500 pairs): what a start check and the separation zones
        ask. The same one coal query, so the distances are the same."""
        if self._people_stale:
            self._people_ready()
        if person not in self._person_models:
            raise HriplanError(f"the scene has no person {person!r}")
        model, data, parts, joints, capsules = self._person_models[person]
        pin.computeDistances(self.robot.model, self.robot.data, model, data, q)
        distance = np.array([r.min_distance for r in data.distanceResults])
        return PairDistances(parts=parts, joints=joints, capsules=capsules, distance=distance)

    def person_model(self, person: str) -> pin.GeometryModel:
        """The model `person_pairs` measures: robot parts and carried objects against `person`'s
        bare capsules, one pair per part and capsule (for callers that batch many states)."""
        if self._people_stale:
            self._people_ready()
        if person not in self._person_models:
            raise HriplanError(f"the scene has no person {person!r}")
        return self._person_models[person][0]
