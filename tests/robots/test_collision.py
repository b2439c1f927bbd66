"""Capsule geometry, allowed-collision matrix, scene and human checks, clearance."""

import coal
import numpy as np
import pytest

from hriplan import HriplanError
from hriplan.robots.acm import load_acm
from hriplan.robots.bounding import capsule_contains, fit_capsule
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.descriptions.registry import posture
from hriplan.robots.human import Human, HumanSpec
from hriplan.robots.model import load_robot
from hriplan.robots.robot_geometry import robot_parts
from hriplan.robots.scene import AttachedObject, Box, Capsule, Cone, Cylinder, Obstacle, Scene, Sphere, table
from hriplan.robots.spatial import Pose
from independent import closest_robot_person
from madar_states import CLEAR


def test_fitted_capsule_contains_every_point(rng):
    points = rng.normal(size=(400, 3)) * (0.03, 0.01, 0.2) + (0.5, -1.0, 2.0)
    radius, length, placement = fit_capsule(points)
    assert capsule_contains(radius, length, placement, points).all()
    assert radius < 0.1  # it follows the long axis rather than a bounding sphere


def test_arm_capsules_contain_the_ur5_meshes(madar):
    parts = {p.name: p for p in robot_parts(madar)}
    for geom in madar.collision_meshes.geometryObjects:
        link = madar.model.frames[geom.parentFrame].name
        if link in parts and isinstance(geom.geometry, coal.BVHModelBase):
            vertices = np.asarray(coal.MeshLoader().load(geom.meshPath, geom.meshScale).vertices())
            points = vertices @ geom.placement.rotation.T + geom.placement.translation
            part = parts[link]
            assert capsule_contains(part.geometry.radius, 2 * part.geometry.halfLength, part.placement, points).all(), (
                link
            )


def test_acm_disables_adjacent_and_keeps_arm_against_arm(madar):
    acm = load_acm(madar, robot_parts(madar))
    assert acm.get("right_shoulder_link|right_upper_arm_link") == "adjacent"
    assert "left_hand_palm_link|right_hand_palm_link" not in acm  # the hands can meet
    assert "right_fore_arm_link|left_fore_arm_link" not in acm and "left_fore_arm_link|right_fore_arm_link" not in acm
    assert set(acm.values()) <= {"adjacent", "never", "mesh"}


@pytest.fixture(scope="module")
def checker(madar):
    scene = Scene(
        obstacles=[
            table(position=(0.6, 0.9), size=(0.5, 0.6, 0.04), top=0.72),
            Obstacle(name="ball", shape=Sphere(radius=0.05), pose=Pose(xyz=(3, 3, 3))),
        ],
        humans=[HumanSpec(name="bob", position=(0.0, 2.2), yaw=-np.pi / 2)],
    )
    return CollisionChecker(madar, scene)


def test_clear_configuration_is_free_and_a_folded_arm_hits_the_torso(madar, checker):
    assert not checker.in_collision(madar.configuration(CLEAR))
    assert checker.contacts(madar.configuration(CLEAR)) == []
    assert checker.in_collision(np.zeros(12))  # the right hand hangs into the base cylinder
    names = {c.a for c in checker.contacts(np.zeros(12))} | {c.b for c in checker.contacts(np.zeros(12))}
    assert "madar_base_cylinder" in names


def test_obstacle_moved_onto_the_hand_collides_without_rebuilding(madar, checker):
    q = madar.configuration(CLEAR)
    model_before = checker.geom_model
    tool = madar.frame_pose("right_tool", q)[:3, 3]
    checker.move_obstacle("ball", Pose(xyz=tuple(tool)))
    try:
        assert [("ball" in (c.a, c.b)) for c in checker.contacts(q)] == [True] * len(checker.contacts(q))
        assert checker.in_collision(q)
    finally:
        checker.move_obstacle("ball", Pose(xyz=(3, 3, 3)))
    assert checker.geom_model is model_before and not checker.in_collision(q)
    with pytest.raises(HriplanError, match="no obstacle 'shelf'"):
        checker.move_obstacle("shelf", Pose())


def test_human_distance_follows_the_person(madar, checker):
    q = madar.configuration(CLEAR)
    far, _, _ = checker.human_distances([q])[0]
    robot_model = madar.model
    tool = madar.frame_pose("right_tool", q)[:3, 3]
    checker.pose_human(HumanSpec(name="bob", position=(tool[0], tool[1] + 0.45), yaw=-np.pi / 2))
    near, part, body = checker.human_distances([q])[0]
    assert near < far - 0.5 and part and body.startswith("bob/")
    checker.pose_human(
        HumanSpec(name="bob", position=(tool[0], tool[1] + 0.45), yaw=-np.pi / 2, reach={"right": tuple(tool)})
    )
    assert checker.in_collision(q)  # the person's hand now touches the robot's hand
    assert madar.model is robot_model
    checker.pose_human(HumanSpec(name="bob", position=(0.0, 2.2), yaw=-np.pi / 2))
    assert checker.human_distances([q])[0][0] == pytest.approx(far)


def test_human_distances_along_a_path_are_coals_closest_pair(madar, rng):
    """The parts the path does not move are measured once: the closest pair is still coal's over
    every pair at every state, whether a moving part (the right arm) or a still one (MADAR's column,
    the left arm) is the closest. A person close in front, with a margin, and a second one."""
    people = [
        HumanSpec(name="kim", position=(0.0, 0.45), yaw=-np.pi / 2, margin=0.05),
        HumanSpec(name="lou", position=(1.3, 0.2), yaw=np.pi),
    ]
    checker = CollisionChecker(madar, Scene(humans=people))
    q0 = madar.configuration(CLEAR)
    arm = madar.group_indices("right_arm")
    qs = np.array([q0] * 40)
    qs[:, arm] += rng.normal(0.0, 0.8, (40, arm.size))
    # Only the shoulder turns, carrying the rest of the arm past kim: every part it carries moves.
    swing = np.array([qs[0]] * 12)
    swing[:, arm[0]] += np.linspace(-0.8, 0.8, 12)
    for path in (qs, swing):
        found = checker.human_distances(path)
        references = [closest_robot_person(madar.model, checker.geom_model, checker.kind, q) for q in path]
        np.testing.assert_allclose([f[0] for f in found], [r[0] for r in references], atol=1e-5)
        assert [f[1:] for f in found] == [r[1:] for r in references]
    found = checker.human_distances(qs)
    moving = {madar.model.frames[madar.frame_id(madar.tool_frame("right"))].parentJoint}
    moving |= {j for j in range(madar.model.njoints) if madar.model.idx_qs[j] in arm}
    part_joint = {g.name: g.parentJoint for g in checker.geom_model.geometryObjects}
    closest_moves = [bool(moving.intersection(madar.model.supports[part_joint[f[1]]])) for f in found]
    assert any(closest_moves) and not all(closest_moves)
    assert checker.human_distances(qs[:0]) == []
    assert CollisionChecker(madar).human_distances(qs[:2]) == [(np.inf, "", "")] * 2


def test_carried_object_is_checked_against_the_scene_but_not_its_hand(madar):
    q = madar.configuration(CLEAR)
    tool = madar.frame_pose("right_tool", q)
    can = AttachedObject(name="can", shape=Cylinder(radius=0.033, height=0.12), arm="right")
    under = Obstacle(name="plate", shape=Box(size=(0.2, 0.2, 0.02)), pose=Pose(xyz=tuple(tool[:3, 3] + (0, 0, -0.035))))
    holding = CollisionChecker(madar, Scene(attached=[can]))
    assert not holding.in_collision(q)  # fingers around the can are allowed
    hits = CollisionChecker(madar, Scene(attached=[can], obstacles=[under])).contacts(q)
    assert any({c.a, c.b} == {"can", "plate"} for c in hits)


def test_a_held_object_may_touch_its_own_wrist_whatever_the_arms_and_links_are_named(arms_named_apart):
    """A carried object touches its hand and wrist by design, the other arm's never. Which parts
    are its arm's is read from the kinematics: TALOS's and TIAGo Pro's arms are `right` and
    `left` while their links are `arm_right_7_link`, `gripper_right_*` (their names do not start
    with the arm's), and a check by name made their hands collide with what they held."""
    robot = arms_named_apart
    q = robot.configuration(posture(robot.name, "home"))
    # A ball 2 cm out of arm a's flange: it overlaps a's wrist_3 link (on a's tool joint) alone.
    ball = Sphere(radius=0.035)
    held = CollisionChecker(robot, Scene(attached=[AttachedObject(name="ball", shape=ball, arm="a", grasp=CLOSE)]))
    assert held.contacts(q) == []
    # The same ball in the same place, held by arm b (a long reach): a's wrist collides with it.
    at_a = robot.frame_pose(robot.tool_frame("a"), q) @ CLOSE.matrix()
    in_b = np.linalg.inv(robot.frame_pose(robot.tool_frame("b"), q)) @ at_a
    reach = Pose(xyz=tuple(in_b[:3, 3]))
    by_b = CollisionChecker(robot, Scene(attached=[AttachedObject(name="ball", shape=ball, arm="b", grasp=reach)]))
    assert [(c.a, c.b) for c in by_b.contacts(q)] == [("right_wrist_3_link", "ball")]


CLOSE = Pose(xyz=(0.0, 0.0, 0.02))


def test_scene_rejects_duplicate_names():
    with pytest.raises(ValueError, match="repeated: a"):
        Scene(obstacles=[Obstacle(name="a", shape=Sphere(radius=0.1)), Obstacle(name="a", shape=Sphere(radius=0.2))])
    with pytest.raises(ValueError, match=r"size\.1\n  Input should be greater than 0"):
        Box(size=(0.1, -1.0, 0.1))


def test_the_fixed_base_is_checked_on_its_meshes_against_obstacles():
    """A UR5 standing 1 cm above a table (as Kautham's UR5 demos place it): the base mesh is
    clear, though the base capsule reaches 8 cm below the base. Moving the table up into the
    base makes every state collide, and back again clears it."""

    ur5 = load_robot("ur5")
    under = Pose(xyz=(0.0, 0.0, -0.39))  # top face at z = -0.01
    checker = CollisionChecker(
        ur5, Scene(obstacles=[Obstacle(name="table", shape=Box(size=(0.5, 0.7, 0.76)), pose=under)])
    )
    q = np.array([0.0, -1.57, 0.0, -1.57, 0.0, 0.0])  # arm straight up
    assert not checker.in_collision(q)
    checker.move_obstacle("table", Pose(xyz=(0.0, 0.0, -0.37)))  # top face at z = +0.01: into the base
    assert ("base_link", "table") in [(c.a, c.b) for c in checker.contacts(q)]
    checker.move_obstacle("table", under)
    assert not checker.in_collision(q) and checker.contacts(q) == []


def pair_names(checker) -> set[tuple[str, str]]:
    objects = checker.geom_model.geometryObjects
    return {(objects[p.first].name, objects[p.second].name) for p in checker.geom_model.collisionPairs}


def test_a_remembered_build_is_the_build_and_in_place_updates_survive_a_rebuild(madar):
    q = madar.configuration(CLEAR)
    tool = madar.frame_pose("right_tool", q)[:3, 3]
    scene = Scene(
        obstacles=[Obstacle(name="ball", shape=Sphere(radius=0.05), pose=Pose(xyz=(3, 3, 3)))],
        humans=[HumanSpec(name="bob", position=(0.0, 2.2), yaw=-np.pi / 2)],
    )
    checker = CollisionChecker(madar, scene)
    plain = pair_names(checker)
    boxed = scene.model_copy(
        update={
            "obstacles": [
                *scene.obstacles,
                Obstacle(name="zone", shape=Box(size=(0.2, 0.2, 0.2)), pose=Pose(xyz=tuple(tool))),
            ]
        }
    )
    checker.set_scene(boxed)
    assert checker.in_collision(q) and pair_names(checker) == pair_names(CollisionChecker(madar, boxed))
    checker.set_scene(scene)  # back: remembered, the same pairs as built fresh
    assert not checker.in_collision(q) and pair_names(checker) == plain
    # Before: a person re-posed in place went back to where the scene had her at the next rebuild.
    near = HumanSpec(name="bob", position=(tool[0], tool[1] + 0.45), yaw=-np.pi / 2, reach={"right": tuple(tool)})
    checker.pose_human(near)
    assert checker.scene.humans == [near] and checker.in_collision(q)
    checker.set_scene(boxed.model_copy(update={"humans": [near]}))
    checker.set_scene(checker.scene.model_copy(update={"obstacles": scene.obstacles}))
    assert checker.in_collision(q) and {c.b for c in checker.contacts(q)} >= {"bob/right_hand"}
    # A scene changed in place by its owner after set_scene is not mistaken for the one built.
    mine = Scene()
    checker.set_scene(mine)
    mine.obstacles.append(Obstacle(name="ball", shape=Sphere(radius=0.05), pose=Pose(xyz=tuple(tool))))
    checker.set_scene(mine)
    assert checker.in_collision(q)


def test_a_scene_given_back_is_the_checkers_own_and_a_callers_copy_is_still_copied(madar):
    """`with_keep_out` ends by giving the checker the scene it had: that one is not copied again,
    and checks exactly as built from a copy; a scene of the caller's still is, so changing it
    afterwards changes nothing here."""
    q = madar.configuration(CLEAR)
    tool = madar.frame_pose("right_tool", q)[:3, 3]
    ball = Obstacle(name="ball", shape=Sphere(radius=0.05), pose=Pose(xyz=tuple(tool)))
    mine = Scene(obstacles=[ball], humans=[HumanSpec(name="bob", position=(0.0, 2.2), yaw=-np.pi / 2)])
    checker = CollisionChecker(madar, mine)
    own = checker.scene
    assert own is not mine and own == mine
    mine.obstacles.clear()  # the caller's: not the checker's
    assert checker.in_collision(q) and checker.scene.obstacles == [ball]
    checker.set_scene(Scene())
    checker.set_scene(own)  # given back: kept as it is
    assert checker.scene is own and checker.in_collision(q)
    assert pair_names(checker) == pair_names(CollisionChecker(madar, own))
    checker.set_scene(mine)  # the caller's again (emptied): copied
    assert checker.scene is not mine and not checker.in_collision(q)


def test_a_scene_given_back_is_built_as_its_own_contents_not_the_last_scenes(madar):
    """Around a keep-out (`with_keep_out`), both builds made: the checker's own scene given back
    (its contents kept with it, not read again) uses its own build, not the keep-out's."""
    q = madar.configuration(CLEAR)
    keep_out = Obstacle(
        name="keep-out:hand", shape=Sphere(radius=0.1), pose=Pose(xyz=tuple(madar.frame_pose("right_tool", q)[:3, 3]))
    )
    checker = CollisionChecker(madar, Scene(humans=[HumanSpec(name="bob", position=(0.0, 2.2), yaw=-np.pi / 2)]))
    own = checker.scene
    assert not checker.in_collision(q)
    for _ in range(2):
        checker.set_scene(own.model_copy(update={"obstacles": [keep_out]}))
        assert checker.in_collision(q)
        checker.set_scene(own)
        assert checker.scene is own and not checker.in_collision(q)
        assert pair_names(checker) == pair_names(CollisionChecker(madar, own))


def test_a_person_moved_by_a_scene_or_re_posed_is_placed_where_they_stand_in_every_model(madar):
    """The checker keeps each person's capsule placements per posing: after every move (a new
    scene, `pose_human`, back to a remembered build) its collision model holds a fresh Human's
    placements and its distance and person models measure as a checker built there."""
    q = madar.configuration(CLEAR)
    tool = madar.frame_pose("right_tool", q)[:3, 3]
    table_scene = Scene(obstacles=[table()])
    moves = [
        HumanSpec(name="bob", position=(0.0, 2.2), yaw=-np.pi / 2),
        HumanSpec(name="bob", position=(tool[0], tool[1] + 0.45), yaw=-np.pi / 2, reach={"right": tuple(tool)}),
        HumanSpec(name="bob", position=(0.4, 1.9), yaw=-np.pi / 2),
        HumanSpec(name="bob", position=(0.0, 2.2), yaw=-np.pi / 2),
    ]
    checker = CollisionChecker(madar, table_scene.model_copy(update={"humans": [moves[0]]}))
    checker.in_collision(q)
    for k, spec in enumerate(moves[1:]):
        if k % 2:
            checker.pose_human(spec)
        else:
            checker.set_scene(table_scene.model_copy(update={"humans": [spec]}))
        fresh = CollisionChecker(madar, checker.scene)
        placed = {
            g.name: g.placement.homogeneous for g in checker.geom_model.geometryObjects if g.name.startswith("bob/")
        }
        expected = {
            f"bob/{c.name}": p.homogeneous
            for c, p in zip(fresh.humans["bob"].capsules, Human(spec).capsule_placements())
        }
        assert placed.keys() == expected.keys()
        for name, placement in placed.items():
            np.testing.assert_array_equal(placement, expected[name])
        # coal's GJK on the non-capsule pairs starts from the model's last answer: 1e-6 apart (so on d3c16e0 too).
        measured, built = checker.person_pairs(q, "bob").distance, fresh.person_pairs(q, "bob").distance
        np.testing.assert_allclose(measured, built, rtol=0, atol=1e-5)
        assert checker.in_collision(q) == fresh.in_collision(q)


def test_a_long_list_of_colliding_pairs_is_cut_to_one_line_with_its_count():
    """A person inside the robot touches dozens of parts: the message lists what fits in the
    width and says how many more there are; a short list is left whole."""
    from hriplan.robots.collision import Contact, listed_contacts

    many = [Contact(f"link_{k}", f"alice/segment_{k}") for k in range(60)]
    line = listed_contacts(many, 200)
    shown = line.split(" and ")[0].split(", ")
    assert len(line) <= 200 and line.endswith(f"and {60 - len(shown)} more (60 pairs in all)")
    assert shown == [f"link_{k} - alice/segment_{k}" for k in range(len(shown))] and len(shown) >= 4
    assert listed_contacts(many[:2], 200) == "link_0 - alice/segment_0, link_1 - alice/segment_1"
    assert listed_contacts([Contact("a" * 300, "b")] * 3, 200) == "3 colliding pairs"


def test_touches_is_any_contact_of_that_geometry_on_random_states(madar, rng):
    """`touches(q, name)` computes only the pairs of `name` (a retreat asks it at every state):
    the same answer as looking for `name` in all of `contacts`, on states that touch and not."""
    clear = madar.configuration(CLEAR)
    ahead = madar.frame_pose("right_tool", clear)[:3, 3] + (0.0, 0.15, 0.0)  # MADAR faces +y
    ball = Obstacle(name="ball", shape=Sphere(radius=0.15), pose=Pose(xyz=tuple(ahead)))
    checker = CollisionChecker(madar, Scene(obstacles=[ball, table("table", (0.5, 0.5, 0.04), 0.72, (0.45, 0.85))]))
    states = [clear + rng.normal(0.0, 0.4, clear.size) for _ in range(300)]
    told = [checker.touches(q, "ball") for q in states]
    assert told == [any("ball" in (c.a, c.b) for c in checker.contacts(q)) for q in states]
    assert 5 < sum(told) < len(states) - 5  # both answers were asked
    assert [checker.touches(q, "table") for q in states[:40]] == [
        any("table" in (c.a, c.b) for c in checker.contacts(q)) for q in states[:40]
    ]
    assert checker.touches(states[0], "no such thing") is False


def test_a_build_remembered_where_a_person_stood_measures_where_she_stands_now(madar, rng):
    """Builds are remembered without the people's poses (a re-plan after a person moved reuses
    them): each use places the person's capsules, zones and distance models anew. Contacts,
    the closest distance and the person's pairs equal a fresh checker's at each pose."""
    from hriplan.robots.collision import SeparationZones

    q0 = madar.configuration(CLEAR)
    tool = madar.frame_pose("right_tool", q0)[:3, 3]
    far = HumanSpec(name="bob", position=(0.0, 2.2), yaw=-np.pi / 2)
    near = HumanSpec(name="bob", position=(tool[0], tool[1] + 0.45), yaw=-np.pi / 2, reach={"right": tuple(tool)})
    ball = Obstacle(name="ball", shape=Sphere(radius=0.05), pose=Pose(xyz=(3, 3, 3)))
    joints = {madar.model.getJointId(j) for j in madar.group_joints("right_arm")}
    zones = SeparationZones(
        moving_joints=frozenset(joints), distances={"bob": {"middle_thorax": 0.2, "right_hand": 0.1}}
    )
    checker = CollisionChecker(madar)
    states = [q0 + rng.normal(0.0, 0.3, q0.size) for _ in range(20)]
    for k, person in enumerate((far, near, far, near)):  # each pose after the first is a remembered build
        elsewhere = ball.model_copy(update={"pose": Pose(xyz=(3, 3, 3 + k))})  # a new build, its people models not
        for extra in ([elsewhere], [], [ball]):
            scene = Scene(obstacles=extra, humans=[person])
            checker.set_world(scene, zones)
            fresh = CollisionChecker(madar)
            fresh.set_world(scene, zones)
            for q in states:
                assert checker.contacts(q) == fresh.contacts(q)
                assert checker.human_distances([q])[0] == pytest.approx(fresh.human_distances([q])[0], abs=1e-9)
                mine, theirs = checker.person_pairs(q, "bob"), fresh.person_pairs(q, "bob")
                assert np.allclose(mine.distance, theirs.distance, atol=1e-9)
    assert any(checker.contacts(q) for q in states)  # near: the person and her zones are touched


def test_a_build_remembered_where_an_obstacle_stood_places_it_where_it_is_now(rng):
    """Builds are remembered without obstacles' poses (a keep-out follows its person, a released
    object lands elsewhere): a reused build puts each obstacle where the scene has it, and a table
    moved up into the fixed base changes the pairs. Contacts equal a fresh checker's each time."""

    ur5 = load_robot("ur5")
    up = np.array([0.0, -1.57, 0.0, -1.57, 0.0, 0.0])  # arm straight up: clear of a table under the base
    states = [up, *(up + rng.normal(0.0, 0.8, 6) for _ in range(30))]
    table_at = lambda z: Obstacle(name="table", shape=Box(size=(0.5, 0.7, 0.76)), pose=Pose(xyz=(0.0, 0.0, z)))  # noqa: E731
    ball_at = lambda x: Obstacle(name="keep-out:ball", shape=Sphere(radius=0.2), pose=Pose(xyz=(x, 0.3, 0.5)))  # noqa: E731
    other = Scene(obstacles=[table_at(-0.39)])
    checker = CollisionChecker(ur5, other)
    built = None
    for table_z, ball_x in ((-0.39, 0.6), (-0.39, 0.1), (-0.37, 0.6), (-0.39, -0.2), (-0.37, 0.1)):
        scene = Scene(obstacles=[table_at(table_z), ball_at(ball_x)])
        checker.set_scene(scene)
        built = built or checker.geom_model
        assert checker.geom_model is built  # the first build of this scene's contents, reused
        fresh = CollisionChecker(ur5, scene)
        for q in states:
            assert checker.contacts(q) == fresh.contacts(q)
            assert checker.in_collision(q) == fresh.in_collision(q)
        into_base = ("base_link", "table") in [(c.a, c.b) for c in checker.contacts(up)]
        assert into_base == (table_z == -0.37)
        checker.set_scene(other)
    checker.set_scene(Scene(obstacles=[table_at(-0.39), ball_at(0.6)]))
    checker.move_obstacle("table", Pose(xyz=(0.0, 0.0, -0.37)))  # in place, into the base
    checker.set_scene(other)
    checker.set_scene(Scene(obstacles=[table_at(-0.37), ball_at(0.6)]))  # the moved build, as moved
    assert checker.in_collision(up)
    checker.set_scene(other)
    checker.set_scene(Scene(obstacles=[table_at(-0.39), ball_at(0.6)]))  # table back under
    assert not checker.in_collision(up) and checker.contacts(up) == []


def test_the_fixed_base_is_asked_again_about_another_shape_where_an_obstacle_stood():
    """Whether the fixed base touches an obstacle is remembered per shape and placement: another
    shape where the first stood (a taller table, a larger ball) is asked anew, the first again
    answers as before. A table top 1 cm under the UR5's base does not touch it, 1 cm into it does."""
    ur5 = load_robot("ur5")
    up = np.array([0.0, -1.57, 0.0, -1.57, 0.0, 0.0])
    low, tall = Box(size=(0.5, 0.7, 0.76)), Box(size=(0.5, 0.7, 0.80))
    checker = CollisionChecker(ur5)
    for shape, touches in (
        (low, False),
        (tall, True),
        (low, False),
        (Sphere(radius=0.38), False),
        (Sphere(radius=0.42), True),
        (tall, True),
    ):
        for where in ((0.0, 0.0, -0.39), (0.0, 0.0, -0.39), (0.3, 2.0, -0.39)):
            checker.set_scene(Scene(obstacles=[Obstacle(name="table", shape=shape, pose=Pose(xyz=where))]))
            into_base = ("base_link", "table") in [(c.a, c.b) for c in checker.contacts(up)]
            assert into_base == (touches and where[1] == 0.0), (shape, where)
            assert checker.in_collision(up) == into_base


@pytest.mark.parametrize("name", ["ur5", "madar"])
def test_an_obstacle_moved_about_the_fixed_base_touches_it_as_in_a_checker_built_there(name, rng):
    """A moved obstacle is asked about only the fixed parts whose ball comes near it
    (`_near_base`): about the balls' surfaces, for every kind of shape, the fixed base touches
    it exactly where a checker built there (every part asked) finds it touching, with the same pairs."""
    robot = load_robot(name)
    shapes = [
        Box(size=(0.3, 0.1, 0.2)),
        Sphere(radius=0.08),
        Cylinder(radius=0.05, height=0.4),
        Cone(radius=0.1, height=0.2),
    ]
    shapes.append(Capsule(radius=0.04, length=0.3))
    checker = CollisionChecker(robot, Scene(obstacles=[Obstacle(name="thing", shape=shapes[0])]))
    centres, radii = checker._robot.fixed_balls
    touched = 0
    for k in range(150):
        shape = shapes[k % len(shapes)]
        part = int(rng.integers(len(radii)))
        direction = rng.normal(size=3)
        at = centres[part] + direction / np.linalg.norm(direction) * (radii[part] + rng.uniform(-0.3, 0.3))
        pose = Pose(xyz=tuple(at.tolist()), rpy=tuple(rng.uniform(-np.pi, np.pi, 3).tolist()))
        checker.set_scene(Scene(obstacles=[Obstacle(name="thing", shape=shape, pose=Pose(xyz=(5.0, 5.0, 5.0)))]))
        assert _fixed_contacts(checker) == set()  # far away: the move below places it
        checker.move_obstacle("thing", pose)
        built = CollisionChecker(robot, checker.scene)
        assert checker._fixed_contacts == _fixed_contacts(built)
        assert np.array_equal(checker._pair_table, built._pair_table)
        touched += bool(built._fixed_contacts)
    assert 20 < touched < 130


def _fixed_contacts(checker: CollisionChecker) -> set[tuple[int, int]]:
    """The (fixed part, obstacle) pairs that touch in the checker's build (built if it was not)."""
    assert checker.geom_model.ngeoms
    return checker._fixed_contacts
