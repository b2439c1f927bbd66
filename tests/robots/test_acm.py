"""Allowed-collision pairs, checked against the URDF collision meshes loaded independently.

The meshes come straight from the robot's URDF text (pinocchio + coal BVH meshes), not from
hriplan's fitted capsules: a pair the planner does not check must never touch at mesh level.
"""

import json
import threading
from pathlib import Path
from types import SimpleNamespace

import coal
import example_robot_data
import numpy as np
import pinocchio as pin
import pytest

from hriplan.robots import acm as acm_module
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.descriptions.registry import load_robot_file
from hriplan.robots.model import load_robot
from hriplan.robots.robot_geometry import part_collision_shapes, robot_parts
from independent import UrdfMeshes

MADAR_BARE = Path(__file__).parents[2] / "examples" / "robots" / "madar_bare.yaml"


@pytest.fixture(scope="module")
def ur5():
    return load_robot("ur5")


def _valid_states(checker: CollisionChecker, count: int, seed: int):
    robot = checker.robot
    rng = np.random.default_rng(seed)
    found = 0
    while found < count:
        q = rng.uniform(robot.model.lowerPositionLimit, robot.model.upperPositionLimit)
        if not checker.in_collision(q):
            found += 1
            yield q


@pytest.mark.parametrize("name, states", [("ur5", 2000), ("madar", 1000)])
def test_no_unchecked_pair_touches_at_mesh_level(name, states):
    robot = load_robot(name)
    checker = CollisionChecker(robot)
    skipped = [pair for pair, reason in checker.acm.items() if reason != "adjacent"]
    meshes = UrdfMeshes(robot)
    meshes.watch(skipped)
    touched: dict[str, int] = {}
    for q in _valid_states(checker, states, seed=3):
        for pair in meshes.touching(q):
            touched[pair] = touched.get(pair, 0) + 1
    assert touched == {}, f"pairs the planner skips touch at mesh level: {touched}"


@pytest.mark.parametrize("name", ["ur5", "madar", "madar_bare"])
@pytest.mark.usefixtures("robot_registry")
def test_no_state_is_free_where_the_meshes_touch(name):
    """10 000 random states: wherever two parts that are not adjacent touch on their URDF
    collision meshes, the checker reports a collision (the fitted parts contain the meshes, the
    pairs checked on meshes are exact and the skipped ones never touch). MADAR with its hands and
    the hand-less one of Kautham's demo (examples/robots/madar_bare.yaml)."""
    robot = load_robot(load_robot_file(MADAR_BARE).name if name == "madar_bare" else name)
    checker = CollisionChecker(robot)
    parts = [p.name for p in robot_parts(robot)]
    pairs = [
        f"{a}|{b}"
        for i, a in enumerate(parts)
        for b in parts[i + 1 :]
        if "adjacent" not in (checker.acm.get(f"{a}|{b}"), checker.acm.get(f"{b}|{a}"))
    ]
    meshes = UrdfMeshes(robot)
    meshes.watch(pairs)
    rng = np.random.default_rng(11)
    free = 0
    for _ in range(10000):
        q = rng.uniform(robot.model.lowerPositionLimit, robot.model.upperPositionLimit)
        if not checker.in_collision(q):
            free += 1
            assert meshes.touching(q) == set(), f"free at {q.round(3).tolist()}"
    assert free > 1000  # the check saw free states (MADAR: about 18 %, hand-less 27 %)


def test_forearm_and_wrist_3_three_links_apart_are_checked_on_their_meshes(ur5):
    """Their capsules collide in 29 % of the samples, their meshes in 7.6 %: 21 % of the joint
    space forbidden for nothing (Kautham's madar_dual_arm demo ends there, the meshes 2.4 cm
    apart). Here the capsules overlap by 1 cm with the meshes 2 cm apart, and the state is free."""
    checker = CollisionChecker(ur5)
    assert checker.acm["fore_arm_link|wrist_3_link"] == acm_module.MESH
    assert checker.acm["base_link|fore_arm_link"] == acm_module.MESH
    q = np.array([4.6, 5.21, 0.83, 6.04, 2.92, 4.15])
    parts = {p.name: p for p in robot_parts(ur5)}
    pin.framesForwardKinematics(ur5.model, ur5.data, q)

    def placed(geometry, joint, placement):
        where = ur5.data.oMi[joint] * placement
        return geometry, coal.Transform3s(where.rotation, where.translation)

    def distance(a, b):
        return coal.distance(*a, *b, coal.DistanceRequest(), coal.DistanceResult())

    fore_arm, wrist_3 = parts["fore_arm_link"], parts["wrist_3_link"]
    capsules = distance(
        placed(fore_arm.geometry, fore_arm.joint, fore_arm.placement),
        placed(wrist_3.geometry, wrist_3.joint, wrist_3.placement),
    )
    assert capsules < -0.005
    meshes = UrdfMeshes(ur5)
    meshes.watch(["fore_arm_link|wrist_3_link"])
    assert meshes.touching(q) == set()
    gap = min(
        distance(placed(s.geometry, s.parentJoint, s.placement), placed(t.geometry, t.parentJoint, t.placement))
        for s in part_collision_shapes(ur5, fore_arm)
        for t in part_collision_shapes(ur5, wrist_3)
    )
    assert gap > 0.015
    assert not checker.in_collision(q) and checker.contacts(q) == []


def test_forearm_and_wrist_2_are_checked_on_their_meshes(ur5):
    """Copied from the UR5 SRDF, this pair was skipped, yet here its meshes touch; two links
    apart, its capsules overlap around wrist 1 in 37 % of the samples, its meshes in 4 %."""
    checker = CollisionChecker(ur5)
    assert checker.acm["fore_arm_link|wrist_2_link"] == acm_module.MESH
    q = np.array([0.1, 4.67, -0.87, 1.23, -5.54, -1.41])
    meshes = UrdfMeshes(ur5)
    meshes.watch(["fore_arm_link|wrist_2_link"])
    assert meshes.touching(q) == {"fore_arm_link|wrist_2_link"}
    assert [(c.a, c.b) for c in checker.contacts(q)] == [("fore_arm_link (mesh)", "wrist_2_link (mesh)")]


def test_base_and_upper_arm_are_checked_on_their_meshes(ur5):
    """Their capsules overlap in every configuration: the meshes decide."""
    checker = CollisionChecker(ur5)
    assert checker.acm["base_link|upper_arm_link"] == acm_module.MESH
    meshes = UrdfMeshes(ur5)
    meshes.watch(["base_link|upper_arm_link"])
    touching = np.array([2.71, -3.81, -1.47, -2.2, 1.15, 1.61])
    assert meshes.touching(touching) == {"base_link|upper_arm_link"}
    assert [(c.a, c.b) for c in checker.contacts(touching)] == [("base_link (mesh)", "upper_arm_link (mesh)")]
    apart = np.array([-4.74, -4.07, 2.26, -0.2, -3.97, 2.13])
    assert meshes.touching(apart) == set() and not checker.in_collision(apart)


def test_no_pair_is_taken_from_an_srdf(madar):
    acm = acm_module.load_acm(madar, robot_parts(madar))
    for side in ("left_", "right_"):
        for a, b in (
            ("fore_arm_link", "wrist_2_link"),
            ("fore_arm_link", "wrist_3_link"),
            ("base_link", "upper_arm_link"),
        ):
            assert acm.get(f"{side}{a}|{side}{b}", "checked") in ("checked", acm_module.MESH)


def test_the_cache_key_follows_the_rules(ur5, monkeypatch):
    parts = robot_parts(ur5)
    key = acm_module._key(ur5, parts, 100)
    monkeypatch.setattr(acm_module, "RULES", acm_module.RULES + " (changed)")
    assert acm_module._key(ur5, parts, 100) != key
    monkeypatch.undo()
    monkeypatch.setattr(acm_module, "FALSE_SHARE", 0.1)
    assert acm_module._key(ur5, parts, 100) != key
    # A matrix cached under the rules before false collisions were measured is not read.
    monkeypatch.setattr(acm_module, "RULES", "adjacent; never (sampled); always or two apart -> mesh; no SRDF pairs")
    monkeypatch.setattr(acm_module, "FALSE_SHARE", 0.05)
    assert acm_module._key(ur5, parts, 100) != key


def test_workers_computing_the_same_matrix_at_once_all_get_it_and_leave_one_whole_file(tmp_path, monkeypatch):
    """Sweep workers that start together compute the same ACM and write the same cache file at
    once: each gets the matrix, the file is whole and no temporary stays (a fixed `NAME.tmp`, as
    before files.atomic_path, lost a rename or left a truncated file here)."""
    workers = 8
    matrix = {f"part_{i}|part_{j}": "never" for i in range(300) for j in range(i + 1, 300)}  # ~1.4 MB of JSON
    barrier = threading.Barrier(workers, timeout=30)

    def compute(robot, parts, samples):
        barrier.wait()  # every worker writes at the same moment
        return dict(matrix)

    monkeypatch.setattr(acm_module, "cache_dir", lambda: tmp_path)
    monkeypatch.setattr(acm_module, "_key", lambda robot, parts, samples: "k")
    monkeypatch.setattr(acm_module, "compute_acm", compute)
    results: list[object] = []

    def worker() -> None:
        try:
            results.append(acm_module.load_acm(SimpleNamespace(name="r"), ()))
        except BaseException as exc:
            results.append(exc)
            barrier.abort()

    threads = [threading.Thread(target=worker) for _ in range(workers)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert [r for r in results if r != matrix] == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["acm-r-k.json"]
    assert json.loads((tmp_path / "acm-r-k.json").read_text()) == matrix


@pytest.mark.usefixtures("robot_registry")
def test_a_pair_whose_parts_alone_forbid_a_named_posture_is_checked_on_its_meshes(tmp_path):
    """example-robot-data's xArm7, as `hriplan robot init` writes it: at its SRDF's postures the
    capsules of its first links and its wrist overlap while the URDF meshes are 4 cm apart (2 %
    of random states: too few for FALSE_SHARE). Each posture must be a start, so those pairs are
    checked on their meshes; and the meshes themselves, read here from the URDF, do not touch."""
    from hriplan.robots.descriptions.registry import posture
    from hriplan.robots.robot_check import write_starting_file

    share = Path(example_robot_data.getModelPath("xarm_description/urdf/xarm7.urdf")).resolve()
    write_starting_file(
        str(share / "xarm_description/urdf/xarm7.urdf"),
        str(share / "xarm_description/srdf/xarm7.srdf"),
        tmp_path / "x.yaml",
    )
    robot = load_robot(load_robot_file(tmp_path / "x.yaml").name)
    checker = CollisionChecker(robot)
    meshes = UrdfMeshes(robot)
    meshes.watch(["link1|link5", "link2|link5", "link1|link6"])
    for name in ("home", "hold-up", "ready"):
        q = robot.configuration(posture(robot.name, name))
        assert not checker.in_collision(q), name
        assert meshes.touching(q) == set(), name
    assert {checker.acm.get(p) for p in ("link1|link5", "link2|link5", "link1|link6")} == {acm_module.MESH}
