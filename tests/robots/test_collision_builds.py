"""When a checker builds its collision and people models, and that building them later or
reusing them changes no pair and no answer (checked on coal directly)."""

import coal
import numpy as np
import pinocchio as pin
import pytest
from pydantic import ValidationError

from hriplan import HriplanError
from hriplan.robots.collision import CollisionChecker, SeparationZones
from hriplan.robots.human import HumanSpec
from hriplan.robots.robot_geometry import robot_parts
from hriplan.robots.scene import AttachedObject, Cylinder, Obstacle, Scene, Sphere, table
from hriplan.robots.spatial import Pose
from independent import closest_robot_person
from madar_states import CLEAR

BOB = HumanSpec(name="bob", position=(0.0, 1.45), yaw=-np.pi / 2, margin=0.05)
TABLE = table(size=(0.5, 0.5, 0.04), position=(0.45, 0.85), top=0.72)
KEEP_OUT = Obstacle(name="keep-out:bob", shape=Cylinder(radius=0.45, height=2.0), pose=Pose(xyz=(0.0, 1.45, 1.0)))
CAN = AttachedObject(name="can", shape=Cylinder(radius=0.033, height=0.12), arm="right", grasp=Pose(xyz=(0, 0, 0.06)))


@pytest.fixture
def counted(monkeypatch):
    """How many collision models and people models checkers make from here on."""
    made = {"collision": 0, "people": 0}
    build, people = CollisionChecker._build_new, CollisionChecker._new_distance_model

    def counted_build(self):
        made["collision"] += 1
        build(self)

    def counted_people(self):
        made["people"] += 1
        return people(self)

    monkeypatch.setattr(CollisionChecker, "_build_new", counted_build)
    monkeypatch.setattr(CollisionChecker, "_new_distance_model", counted_people)
    return made


def test_a_scene_is_built_when_first_asked_and_a_question_about_people_builds_no_collision_model(madar, counted):
    """A session's empty first scene and a scene replaced before any question build nothing;
    the people's pairs need no collision model; the first collision question builds the scene
    the checker has then (a checker that built the first scene it was given answers for it)."""
    q = madar.configuration(CLEAR)
    checker = CollisionChecker(madar)
    checker.set_scene(Scene(obstacles=[TABLE], humans=[BOB]))
    inside = TABLE.model_copy(
        update={"name": "slab", "pose": Pose(xyz=tuple(madar.frame_pose("right_tool", q)[:3, 3]))}
    )
    scene = Scene(obstacles=[inside], humans=[BOB])
    checker.set_scene(scene)
    assert counted == {"collision": 0, "people": 0}
    assert checker.person_pairs(q, "bob").distance.size == len(robot_parts(madar)) * 16
    assert counted == {"collision": 0, "people": 1}
    assert checker.in_collision(q) and ("slab" in {c.b for c in checker.contacts(q)})
    assert counted == {"collision": 1, "people": 1}
    checker.set_scene(Scene(obstacles=[TABLE], humans=[BOB]))  # the same people: their models kept
    assert not checker.in_collision(q) and counted == {"collision": 2, "people": 1}


def _pairs(checker: CollisionChecker) -> set[tuple[str, str]]:
    objects = checker.geom_model.geometryObjects
    return {(objects[p.first].name, objects[p.second].name) for p in checker.geom_model.collisionPairs}


def _coal_contacts(checker: CollisionChecker, q: np.ndarray) -> set[tuple[str, str]]:
    """Every pair of the checker's model that coal finds in contact at `q`, on fresh data."""
    model, geometry = checker.robot.model, checker.geom_model
    data, placed = model.createData(), geometry.createData()
    pin.updateGeometryPlacements(model, data, geometry, placed, q)
    objects, found = geometry.geometryObjects, set()
    for p in geometry.collisionPairs:
        a, b = objects[p.first], objects[p.second]
        request = coal.CollisionRequest()
        request.enable_contact = True
        ta, tb = placed.oMg[p.first], placed.oMg[p.second]
        if coal.collide(
            a.geometry,
            coal.Transform3s(ta.rotation, ta.translation),
            b.geometry,
            coal.Transform3s(tb.rotation, tb.translation),
            request,
            coal.CollisionResult(),
        ):
            found.add((a.name, b.name))
    return found


def test_pairs_and_answers_do_not_depend_on_when_or_how_often_a_build_is_made(madar, rng):
    """The same changes (zones and a keep-out added and removed, the person moving, an obstacle
    moved into the fixed base, a can taken) asked after each change, or only after the last, or
    by a checker given the last scene at once: the same pairs, every pair a rule asks for (each
    capsule against every part and carried object; a separation zone against the moving arm's
    parts), and the same contacts, closest person and person pairs as coal computes them."""
    moving = madar.moved_joints("right_arm")
    zones = SeparationZones(distances={"bob": {"middle_thorax": 0.2, "right_hand": 0.1}}, moving_joints=moving)
    near = BOB.model_copy(update={"position": (0.2, 1.1)})
    ball = Obstacle(name="ball", shape=Sphere(radius=0.1), pose=Pose(xyz=(3.0, 3.0, 3.0)))
    base = Scene(obstacles=[TABLE, ball], humans=[BOB])
    q0 = madar.configuration(CLEAR)
    states = [q0, *(q0 + rng.normal(0.0, 0.4, q0.size) for _ in range(12))]

    def changes(checker: CollisionChecker, ask) -> None:
        for scene, zoned in ((base, None), (base.model_copy(update={"obstacles": [*base.obstacles, KEEP_OUT]}), zones)):
            checker.set_world(scene, zoned)
            ask(checker)
        checker.pose_human(near)
        ask(checker)
        checker.move_obstacle(
            "ball", Pose(xyz=(0.0, 0.0, 0.4))
        )  # into the base cylinder: the fixed base's pairs change
        ask(checker)
        checker.set_world(
            Scene(obstacles=checker.scene.obstacles, attached=[CAN], humans=[near]),
            SeparationZones(distances={"bob": {"right_hand": 0.3}}, moving_joints=moving),
        )
        ask(checker)

    eager, late = CollisionChecker(madar), CollisionChecker(madar)
    changes(eager, lambda c: c.in_collision(q0) and c.person_pairs(q0, "bob"))
    changes(late, lambda c: None)
    fresh = CollisionChecker(madar)
    fresh.set_world(late.scene, late.zones)
    pairs = _pairs(fresh)
    assert _pairs(eager) == _pairs(late) == pairs
    movers = {p.name for p in robot_parts(madar)} | {"can"}
    arm = {p.name for p in robot_parts(madar) if p.joint in moving} | {"can"}
    capsules = {name for a, b in pairs for name in (a, b) if name.startswith("bob/") and "(" not in name}
    assert len(capsules) == 16
    for capsule in capsules:
        assert {a for a, b in pairs if b == capsule} == movers
    assert {a for a, b in pairs if b.startswith("bob/right_hand (")} == arm
    assert ("madar_base_cylinder", "ball") in pairs and ("can", "ball") in pairs
    for q in states:
        expected = _coal_contacts(fresh, q)
        for checker in (eager, late):
            assert {(c.a, c.b) for c in checker.contacts(q)} == expected
            assert checker.in_collision(q) == bool(expected)
            distance, part, capsule = checker.human_distances([q])[0]
            coals = closest_robot_person(madar.model, fresh.geom_model, fresh.kind, q)
            # coal's GJK converges to 1e-6 from a guess that depends on the model's history
            assert distance == pytest.approx(coals[0], abs=1e-5) and (part, capsule) == coals[1:]
            mine = checker.person_pairs(q, "bob")
            assert set(mine.parts) == movers and set(mine.capsules) == {c.split("/")[1] for c in capsules}
            assert np.allclose(mine.distance, fresh.person_pairs(q, "bob").distance, atol=1e-5)
    assert any(_coal_contacts(fresh, q) for q in states[1:])


def test_a_scene_the_checker_cannot_build_is_refused_when_set(madar):
    """Building later does not move the errors: a separation zone around a person not in the
    scene, an object carried by an arm the robot lacks and a reach out of range are refused by
    set_world, and the checker keeps the scene it had, its people where that scene has them
    (one person moved before another's reach failed included)."""
    checker = CollisionChecker(madar, Scene(humans=[BOB]))
    zones = SeparationZones(distances={"eve": {"right_hand": 0.2}}, moving_joints=madar.moved_joints("right_arm"))
    with pytest.raises(HriplanError, match="no person 'eve'"):
        checker.set_world(Scene(humans=[BOB]), zones)
    with pytest.raises(HriplanError, match="has no arm 'middle'"):
        checker.set_scene(Scene(attached=[CAN.model_copy(update={"arm": "middle"})]))
    q = madar.configuration(CLEAR)
    assert checker.person_pairs(q, "bob").distance.min() > 0.1  # built with bob where he stands
    with pytest.raises(HriplanError, match="cannot reach"):
        checker.set_scene(Scene(humans=[BOB.model_copy(update={"reach": {"right": (5.0, 5.0, 1.0)}})]))
    moved = BOB.model_copy(update={"position": (0.0, 0.9)})  # posed before al's reach fails
    al = BOB.model_copy(update={"name": "al", "reach": {"left": (5.0, 5.0, 1.0)}})
    with pytest.raises(HriplanError, match="cannot reach"):
        checker.set_scene(Scene(humans=[moved, al], obstacles=[TABLE]))
    assert checker.scene == Scene(humans=[BOB]) and checker.zones is None
    fresh = CollisionChecker(madar, Scene(humans=[BOB]))
    assert not checker.in_collision(q) and list(checker.humans) == ["bob"]
    assert np.allclose(checker.person_pairs(q, "bob").distance, fresh.person_pairs(q, "bob").distance, atol=1e-5)
    assert checker.humans["bob"].frame("right_hand") == fresh.humans["bob"].frame("right_hand")


def _capsules_where(checker: CollisionChecker) -> dict[str, np.ndarray]:
    """Where bob's capsules (and zones) stand in the checker's collision, distance and person models, by name."""
    q = np.zeros(checker.robot.model.nq)
    checker.in_collision(q)
    checker.person_pairs(q, "bob")
    placed = {
        f"{model} {g.name}": g.placement.homogeneous
        for model, objects in (
            ("collision", checker.geom_model.geometryObjects),
            ("distance", checker._distance_model.geometryObjects),
        )
        for g in objects
        if g.name.startswith("bob/")
    }
    person = list(checker.person_model("bob").geometryObjects)[-16:]
    return placed | {f"person {g.name}": g.placement.homogeneous for g in person}


def _placed_alike(checker: CollisionChecker, other: CollisionChecker) -> bool:
    """Do the two checkers place bob's capsules and zones the same, to the bit, in every model?"""
    mine, theirs = _capsules_where(checker), _capsules_where(other)
    return mine.keys() == theirs.keys() and all(np.array_equal(mine[k], theirs[k]) for k in mine)


@pytest.mark.parametrize(
    "change",
    [
        {"position": (0.3, 1.2)},
        {"yaw": -np.pi / 2 + 0.4},
        {"reach": {"right": (0.1, 1.0, 1.1)}},
        {"reach": {"right": (0.1, 1.0, 1.1)}, "position": (0.05, 1.45)},
        {"posture": "seated"},
    ],
)
def test_a_person_posed_anew_is_placed_anew_and_one_posed_as_before_keeps_their_placements(madar, change):
    """A person who moved, turned or reaches elsewhere has every capsule and zone where a checker
    made for that scene puts them, in every model; the same person again is not posed again and
    keeps the placements made for them."""
    zones = SeparationZones(distances={"bob": {"middle_thorax": 0.2}}, moving_joints=madar.moved_joints("right_arm"))
    checker = CollisionChecker(madar)
    checker.set_world(Scene(obstacles=[TABLE], humans=[BOB]), zones)
    before = _capsules_where(checker)
    kept = checker._placed("bob")
    checker.set_world(Scene(obstacles=[TABLE, KEEP_OUT], humans=[BOB]), zones)  # a new build, the same person
    assert checker._placed("bob") is kept
    assert all(np.array_equal(placement, before[name]) for name, placement in _capsules_where(checker).items())
    moved = Scene(obstacles=[TABLE], humans=[BOB.model_copy(update=change)])
    checker.set_world(moved, zones)
    fresh = CollisionChecker(madar)
    fresh.set_world(moved, zones)
    expected = _capsules_where(fresh)
    assert _placed_alike(checker, fresh) and len(expected) == 3 * 16 + 1  # and the thorax's zone
    assert any(not np.array_equal(before[name], expected[name]) for name in expected)


def test_what_a_caller_changes_in_place_after_giving_it_reaches_no_checker(madar):
    """A checker holds its own scene and people: a scene or a person's spec changed in place by
    whoever gave it (a person moved, their reach changed, an obstacle added) changes nothing it
    answers, until given again: then it answers as a checker given that scene at once."""
    q = madar.configuration(CLEAR)
    scene = Scene(obstacles=[TABLE], humans=[BOB.model_copy(deep=True)])
    checker = CollisionChecker(madar, scene)
    spec = BOB.model_copy(update={"position": (0.1, 1.4)}, deep=True)
    checker.pose_human(spec)
    answers = _capsules_where(checker)
    assert _placed_alike(checker, CollisionChecker(madar, checker.scene.model_copy(deep=True)))
    spec.position = (0.9, 0.3)  # in place, after it was given
    spec.reach["right"] = (0.6, 0.4, 1.0)
    scene.humans[0].position = (0.9, 0.3)
    scene.obstacles.append(Obstacle(name="slab", shape=Sphere(radius=0.2), pose=Pose(xyz=(0.5, -0.4, 0.9))))
    for name, placement in _capsules_where(checker).items():
        assert np.array_equal(placement, answers[name]), name
    assert [o.name for o in checker.scene.obstacles] == ["table"] and checker.scene.humans[0].position == (0.1, 1.4)
    for given in (Scene(obstacles=scene.obstacles, humans=[spec]), scene):
        checker.set_scene(given)
        fresh = CollisionChecker(madar, given.model_copy(deep=True))
        assert _placed_alike(checker, fresh)
        assert checker.in_collision(q) == fresh.in_collision(q)
        assert {(c.a, c.b) for c in checker.contacts(q)} == {(c.a, c.b) for c in fresh.contacts(q)}


def test_a_scene_copied_for_a_checker_shares_only_what_no_one_can_change(madar):
    """A checker's copy of a scene shares its poses and shapes (frozen, of numbers and tuples:
    assigning to one is refused) and nothing else: lists, obstacles and people are its own."""
    scene = Scene(obstacles=[TABLE], attached=[CAN], humans=[BOB])
    checker = CollisionChecker(madar, scene)
    mine = checker.scene
    assert mine == scene and mine is not scene
    assert mine.obstacles[0].pose is TABLE.pose and mine.obstacles[0].shape is TABLE.shape
    assert mine.attached[0].grasp is CAN.grasp
    assert mine.obstacles is not scene.obstacles and mine.obstacles[0] is not TABLE
    assert mine.humans[0] is not BOB and mine.attached[0] is not CAN
    with pytest.raises(ValidationError, match="frozen"):
        mine.obstacles[0].pose.xyz = (0.0, 0.0, 0.0)
    with pytest.raises(ValidationError, match="frozen"):
        mine.obstacles[0].shape.size = (1.0, 1.0, 1.0)
    moved = mine.obstacles[0].pose.model_copy(update={"xyz": (9.0, 9.0, 9.0)}, deep=True)  # a copy, not the shared
    assert moved.xyz == (9.0, 9.0, 9.0) and TABLE.pose.xyz != moved.xyz and checker.scene == scene


def test_person_distances_are_person_pairs_without_their_points(madar, rng):
    """Two checkers of one scene asked about the same states in the same order (coal's distances
    depend on the queries before): `person_distances` gives `person_pairs`'s parts, joints,
    capsules and distances, to the bit, at every state; only the latter reads the points."""
    scene = Scene(obstacles=[TABLE], attached=[CAN], humans=[BOB])
    lean, full = CollisionChecker(madar, scene), CollisionChecker(madar, scene)
    q0 = madar.configuration(CLEAR)
    for q in [q0, *(q0 + rng.normal(0.0, 0.5, q0.size) for _ in range(8))]:
        mine, theirs = lean.person_distances(q, "bob"), full.person_pairs(q, "bob")
        assert mine.parts == theirs.parts and mine.capsules == theirs.capsules
        assert np.array_equal(mine.joints, theirs.joints) and np.array_equal(mine.distance, theirs.distance)
        assert len(mine.distance) == len(theirs.robot_point) == (len(robot_parts(madar)) + 1) * 16
        assert not hasattr(mine, "robot_point")
    assert np.ptp(mine.distance) > 0.1
    with pytest.raises(HriplanError, match="no person 'eve'"):
        lean.person_distances(q0, "eve")
