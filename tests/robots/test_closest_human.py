"""The path report's closest approach to a person (`CollisionChecker.closest_human`) is the least
of `human_distances` over the same states, same pair, by branch and bound over the states; and
the bound it orders them by (`PartSpheres.floor`) is below coal's distance of every moving pair."""

import coal
import numpy as np
import pinocchio as pin
import pytest

from hriplan.robots.collision import CollisionChecker
from hriplan.robots.human import HumanSpec
from hriplan.robots.part_spheres import PartSpheres
from hriplan.robots.scene import AttachedObject, Cylinder, Scene
from independent import closest_robot_person
from madar_states import CLEAR

PEOPLE = [
    HumanSpec(name="kim", position=(0.0, 0.55), yaw=-np.pi / 2, margin=0.05, reach={"right": (0.05, 0.4, 1.0)}),
    HumanSpec(name="lou", position=(1.3, 0.2), yaw=np.pi),
]


@pytest.fixture(scope="module")
def checker(madar):
    can = AttachedObject(name="can", shape=Cylinder(radius=0.033, height=0.12), arm="right")
    return CollisionChecker(madar, Scene(humans=PEOPLE, attached=[can]))


def _paths(madar, rng) -> list[np.ndarray]:
    """Smooth right-arm paths from CLEAR (reaching towards kim, into her, past lou), random
    states, the shoulder alone turning, and a path that moves nothing."""
    q0 = madar.configuration(CLEAR)
    arm = madar.group_indices("right_arm")
    paths = []
    for _ in range(12):
        ends = q0[arm] + rng.normal(0.0, 0.9, (3, arm.size))
        line = np.concatenate([np.linspace(a, b, 50) for a, b in zip(ends, ends[1:])])
        path = np.repeat(q0[None], len(line), axis=0)
        path[:, arm] = line
        paths.append(path)
    scattered = np.repeat(q0[None], 60, axis=0)
    scattered[:, arm] += rng.normal(0.0, 0.8, (60, arm.size))
    swing = np.repeat(q0[None], 30, axis=0)
    swing[:, arm[0]] += np.linspace(-1.2, 1.2, 30)
    return [*paths, scattered, swing, np.repeat(q0[None], 5, axis=0)]


def test_closest_human_is_the_least_of_human_distances(madar, checker, rng):
    touching = 0
    for path in _paths(madar, rng):
        every = checker.human_distances(path)
        least = min(every, key=lambda found: found[0])
        found = checker.closest_human(path)
        assert found[1:] == least[1:]
        assert found[0] == pytest.approx(least[0], abs=1e-5)
        touching += least[0] < 0.0
        # and coal over every pair of the full geometry, from fresh data, at the state it names
        state = next(k for k, d in enumerate(every) if d == least)
        reference = closest_robot_person(madar.model, checker.geom_model, checker.kind, path[state])
        assert reference[1:] == found[1:] and reference[0] == pytest.approx(found[0], abs=1e-5)
    assert touching  # some paths run into kim's grown capsules: negative distances compared too


def test_closest_human_without_states_or_people(madar, checker):
    q = madar.configuration(CLEAR)
    assert checker.closest_human(np.zeros((0, madar.model.nq))) == (np.inf, "", "")
    assert CollisionChecker(madar).closest_human(q[None]) == (np.inf, "", "")


def test_closest_human_follows_the_person(madar):
    """The bound reads the people where they stand now: moved next to the hand, she is closest."""
    checker = CollisionChecker(madar, Scene(humans=[HumanSpec(name="bob", position=(0.0, 2.2), yaw=-np.pi / 2)]))
    q = madar.configuration(CLEAR)
    path = np.repeat(q[None], 20, axis=0)
    path[:, madar.group_indices("right_arm")[0]] += np.linspace(0.0, 0.5, 20)
    far = checker.closest_human(path)
    tool = madar.frame_pose("right_tool", path[-1])[:3, 3]
    checker.pose_human(HumanSpec(name="bob", position=(tool[0], tool[1] + 0.45), yaw=-np.pi / 2))
    near = checker.closest_human(path)
    assert near[0] < far[0] - 0.5
    assert near == min(checker.human_distances(path), key=lambda found: found[0])


def test_part_spheres_bound_every_moving_pair_from_below(madar, checker, rng):
    """At random states, the floor of every pair of a moving part and a grown capsule is at most
    coal's distance of that pair (the parts' placements from pinocchio, fresh data)."""
    model = checker.robot.model
    q0 = madar.configuration(CLEAR)
    arm = madar.group_indices("right_arm")
    qs = np.repeat(q0[None], 200, axis=0)
    qs[:, arm] += rng.normal(0.0, 1.0, (200, arm.size))
    checker.human_distances(qs[:1])  # the distance model, placed
    geometry = checker._distance_model
    moved = {
        j
        for j in range(model.njoints)
        if set(model.supports[j]) & {model.getJointId(n) for n in madar.group_joints("right_arm")}
    }
    parts = [a for a in range(len(checker.parts)) if geometry.geometryObjects[a].parentJoint in moved]
    capsules = list(range(len(checker.parts), geometry.ngeoms))
    placements = [geometry.geometryObjects[b].placement for b in capsules]
    floor = PartSpheres(model, geometry, parts).floors(
        qs,
        np.array([m.translation for m in placements]),
        np.array([m.rotation[:, 2] for m in placements]),
        np.array([geometry.geometryObjects[b].geometry.halfLength for b in capsules]),
        np.array([geometry.geometryObjects[b].geometry.radius for b in capsules]),
    )
    data, coals = model.createData(), np.empty(floor.shape)
    for n, q in enumerate(qs):
        pin.forwardKinematics(model, data, q)
        for p, a in enumerate(parts):
            part = geometry.geometryObjects[a]
            at = data.oMi[part.parentJoint] * part.placement
            for s, b in enumerate(capsules):
                other = geometry.geometryObjects[b]
                result = coal.DistanceResult()
                coal.distance(
                    part.geometry,
                    coal.Transform3s(at.rotation, at.translation),
                    other.geometry,
                    coal.Transform3s(other.placement.rotation, other.placement.translation),
                    coal.DistanceRequest(),
                    result,
                )
                coals[n, p, s] = result.min_distance
    assert np.all(floor <= coals)
    least, floor = coals.min(axis=(1, 2)), floor.min(axis=(1, 2))
    assert np.median(least - floor) < 0.2  # and not a useless bound (spheres about long capsules are loose)
    assert (least < 0.05).any()  # states near the people were among them


def test_moving_pairs_are_those_whose_chain_holds_a_varying_joint(madar, checker, rng):
    """The pairs whose robot part a joint varying along the states moves: against the chains
    walked in Python (pinocchio's supports), for each single joint varying, each arm, and all."""
    model, q0 = madar.model, madar.configuration(CLEAR)
    _, carriers = checker._distance_pair_table()
    varied = [[i] for i in range(model.nq)] + [list(madar.group_indices(g)) for g in ("right_arm", "left_arm")]
    for entries in [*varied, list(range(model.nq)), []]:
        qs = np.repeat(q0[None], 4, axis=0)
        qs[1:, entries] += rng.uniform(0.05, 0.3, (3, len(entries)))
        changed = {
            j
            for j in range(1, model.njoints)
            if set(range(model.idx_qs[j], model.idx_qs[j] + model.nqs[j])) & set(entries)
        }
        moved = [bool(changed.intersection(model.supports[int(j)])) for j in carriers]
        route = checker._route(qs)
        assert route.moving.tolist() == moved
        # and the entries that move a still pair's part
        still = {int(c) for j, m in zip(carriers, moved) if not m for c in model.supports[int(j)] if c > 0}
        entries = {i for c in still for i in range(model.idx_qs[c], model.idx_qs[c] + model.nqs[c])}
        assert np.flatnonzero(route.still_entries).tolist() == sorted(entries)
    assert checker._route(np.repeat(q0[None], 3, axis=0)).moving.sum() == 0


def test_the_compiled_route_finds_the_same_closest_pair(madar, checker, rng):
    """`closest_human` with `person_distance.nearest_moving` (numba: capsules, boxes and cylinders
    exactly, a shape touching a person by coal) names the same pair at the same distance as the
    coal route, within 1e-9 m, on the same paths: into kim (capsules and the palm touching her
    grown capsules), past lou, scattered, still."""
    pytest.importorskip("numba")
    from hriplan.safety.person_distance import nearest_moving

    touching = 0
    for path in _paths(madar, rng):
        coal_route, compiled = checker.closest_human(path), checker.closest_human(path, nearest_moving)
        assert compiled[1:] == coal_route[1:]
        assert compiled[0] == pytest.approx(coal_route[0], abs=1e-9)
        touching += compiled[0] < 0.0
    assert touching


def test_a_palm_inside_a_person_is_measured_by_coal_on_the_compiled_route():
    """MADAR's open palm (a box) 4 cm inside a person's lower arm, the closest pair of a short
    path: the compiled route leaves a shape touching a person to coal (its depth) and names it."""
    pytest.importorskip("numba")
    from hriplan.planner.session import PlanningSession
    from hriplan.robots.descriptions.registry import posture
    from hriplan.safety.person_distance import nearest_moving

    session = PlanningSession("madar", Scene(), hands={"right": "open"})
    robot = session.robot
    q0 = robot.configuration(posture("madar", "ready"))
    x, y, z = robot.frame_pose(robot.tool_frame("right"), q0)[:3, 3]
    reach = {"right": (x, y, z - 0.05)}
    session.set_scene(Scene(humans=[HumanSpec(name="v", position=(x + 0.55, y - 0.1), yaw=1.25 * np.pi, reach=reach)]))
    path = np.repeat(q0[None], 8, axis=0)
    path[:, robot.group_indices("right_arm")[0]] += np.linspace(0.0, 0.01, 8)
    coal_route = session.checker.closest_human(path)
    assert coal_route[1:] == ("right_hand_palm_link", "v/right_lowerarm") and coal_route[0] < -0.03
    assert session.checker.closest_human(path, nearest_moving) == coal_route


def test_what_closest_human_keeps_is_read_again_when_it_moves(madar):
    """`closest_human` keeps the still pairs' answer, and the compiled route the person's capsules,
    between calls: after the person is re-posed (by the still left arm, by the moving right hand),
    with the left arm standing elsewhere, and in a scene set anew, both routes answer as a fresh
    checker does, to the bit, and as coal over every pair of the full geometry."""
    pytest.importorskip("numba")
    from hriplan.safety.person_distance import nearest_moving

    q = madar.configuration(CLEAR)
    path = np.repeat(q[None], 10, axis=0)
    path[:, madar.group_indices("right_arm")[0]] += np.linspace(0.0, 0.5, 10)
    folded = path.copy()
    folded[:, madar.group_indices("left_arm")[1]] += 0.4  # still along the path, elsewhere
    left, right = (madar.frame_pose(f"{side}_tool", q)[:3, 3] for side in ("left", "right"))
    far = HumanSpec(name="bob", position=(0.0, 2.2), yaw=-np.pi / 2)
    by_left = HumanSpec(name="bob", position=(left[0], left[1] + 0.45), yaw=-np.pi / 2)
    by_right = HumanSpec(name="bob", position=(right[0], right[1] + 0.45), yaw=-np.pi / 2)
    checker = CollisionChecker(madar, Scene(humans=[far]))
    parts = set()
    for scene, states in [
        (Scene(humans=[far]), path),
        (Scene(humans=[by_left]), path),
        (Scene(humans=[by_left]), folded),
        (Scene(humans=[by_right]), folded),
        (Scene(humans=[by_left.model_copy(update={"name": "kim"})]), path),
    ]:
        if scene.humans[0].name != checker.scene.humans[0].name:
            checker.set_scene(scene)
        elif scene.humans != checker.scene.humans:
            checker.pose_human(scene.humans[0])
        fresh = CollisionChecker(madar, scene)
        for nearest in (None, nearest_moving):
            found = checker.closest_human(states, nearest)
            assert found == fresh.closest_human(states, nearest)
        reference = min(
            (closest_robot_person(madar.model, fresh.geom_model, fresh.kind, s) for s in states), key=lambda f: f[0]
        )
        assert reference[1:] == found[1:] and reference[0] == pytest.approx(found[0], abs=1e-9)
        parts.add(found[1].split("_")[0])
    assert parts == {"left", "right"}  # the closest pair both a still part and a moving one
