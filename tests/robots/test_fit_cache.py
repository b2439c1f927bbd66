"""Fitted shapes kept on disk (robots/fit_cache.py): the same shapes, fitted once per machine."""

import base64
import gzip
import json
import subprocess
import sys
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
import pytest

from hriplan.robots import human
from hriplan.robots.fit_cache import array, array_data, cached_fit, shape, shape_data
from hriplan.robots.model import load_robot
from hriplan.robots.robot_geometry import _fitted_parts, _parts


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    return tmp_path / "hriplan"


def test_a_fit_is_computed_once_then_read_and_a_broken_file_is_fitted_again(cache):
    calls = []

    def fit():
        calls.append(1)
        return {"value": [1.5, 2.25]}

    assert cached_fit("thing", ("rules", 1), fit) == {"value": [1.5, 2.25]}
    assert cached_fit("thing", ("rules", 1), fit) == {"value": [1.5, 2.25]} and len(calls) == 1
    assert cached_fit("thing", ("rules", 2), fit) and len(calls) == 2  # another key: fitted
    files = sorted(cache.glob("thing-*.json"))
    assert len(files) == 2
    for broken in files:
        broken.write_text("{not json")
    assert cached_fit("thing", ("rules", 1), fit) == {"value": [1.5, 2.25]} and len(calls) == 3


def test_the_robot_parts_read_back_are_the_parts_fitted(cache):
    robot = load_robot("madar", {"right": "power"})
    fitted, first, again = _fitted_parts(robot, 0.0), _parts(robot, 0.0), _parts(robot, 0.0)
    assert len(list(cache.glob("parts-madar-*.json"))) == 1
    for a, b, c in zip(fitted, first, again, strict=True):
        assert (a.name, a.link, a.joint) == (b.name, b.link, b.joint) == (c.name, c.link, c.joint)
        assert shape_data(a.geometry) == shape_data(b.geometry) == shape_data(c.geometry)
        assert np.array_equal(a.placement.homogeneous, c.placement.homogeneous)
    kinds = {type(p.geometry) for p in again}
    assert {coal.Capsule, coal.Box, coal.Cylinder, coal.Sphere} <= kinds


def test_the_person_read_back_is_the_person_fitted(cache):
    data = human._fitted(None)
    model, capsules, frames, hulls = human._loaded.__wrapped__(None)  # through the cache file
    assert len(list(cache.glob("human-*.json"))) == 1
    assert [c["name"] for c in data["capsules"]] == [c.name for c in capsules]
    assert [c["radius"] for c in data["capsules"]] == [c.radius for c in capsules]
    fresh = pin.Model()
    fresh.loadFromString(data["model"])
    assert model == fresh and model.names[1] == "root_joint"  # the scaled body, free flyer first
    assert frames["right_hand"][0] == data["frames"]["right_hand"][0]
    assert np.array_equal(frames["head"][1].homogeneous, np.array(data["frames"]["head"][1]))
    assert [j for j, _ in hulls] == [j for j, _ in data["hulls"]]
    for (_, got), (_, text) in zip(hulls, data["hulls"], strict=True):
        assert got.dtype == np.float64 and got.shape[1] == 3 and got.shape[0] >= 4
        assert np.array_equal(got, np.frombuffer(base64.b64decode(text), dtype="<f8").reshape(-1, 3))


def test_arrays_are_kept_bit_for_bit(rng):
    points = rng.normal(size=(50, 3)) * 10.0 ** rng.integers(-300, 300, size=(50, 3))
    points[0] = (-0.0, 5e-324, np.inf)  # a negative zero, the smallest subnormal, infinity
    back = array(json.loads(json.dumps(array_data(points))), 3)
    assert back.tobytes() == points.tobytes()
    assert array(array_data(points[:0]), 3).shape == (0, 3)


@pytest.mark.parametrize(
    "geometry", [coal.Capsule(0.05, 0.3), coal.Cylinder(0.4, 0.75), coal.Box(0.5, 0.08, 0.05), coal.Sphere(0.1)]
)
def test_each_kept_shape_comes_back_the_same(geometry):
    back = shape(json.loads(json.dumps(shape_data(geometry))))
    assert type(back) is type(geometry) and shape_data(back) == shape_data(geometry)


def test_deriving_constraints_loads_no_visual_mesh():
    # The visual meshes take about a second to load; only the viewer and a first fit need them.
    # In a fresh process: robots are shared within one.
    code = (
        "from pathlib import Path\n"
        "from hriplan.tasks.load import load_task\n"
        "from hriplan.tasks.pipeline import TaskRunner\n"
        "runner = TaskRunner(load_task(Path('examples/handover_full_can.yaml')))\n"
        "assert runner.run(plan=False).steps\n"
        "print(sorted({'visual', 'full_visual'} & set(vars(runner._robot()))))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=Path(__file__).parents[2], timeout=300
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"


def test_a_hand_posture_whose_finger_values_change_is_fitted_again(cache, monkeypatch):
    # Before: the parts were keyed by the posture's name only, so new finger values under the same
    # name read back the old fingers from disk (found when the release posture was tuned).
    from hriplan.robots import model
    from hriplan.robots.descriptions import allegro

    def fingers(robot) -> list[np.ndarray]:
        return [p.placement.translation.copy() for p in _parts(robot, 0.0) if "right_hand_finger_3" in p.name]

    model._cached_robot.cache_clear()
    before = load_robot("madar", {"right": "open"})
    thumb = fingers(before)
    monkeypatch.setitem(allegro._THUMB, "open", (1.3, 0.0, 0.0, 0.0))
    model._cached_robot.cache_clear()
    after = load_robot("madar", {"right": "open"})
    assert before.finger_values != after.finger_values
    assert max(np.linalg.norm(a - b) for a, b in zip(thumb, fingers(after))) > 0.01
    model._cached_robot.cache_clear()


def test_parts_are_fitted_again_for_a_robot_placed_elsewhere(cache):
    """The cached parts hold placements on the planning model: a part on the world (the UR5's
    base) moves with the base pose. Keyed by URDF and hands alone, a UR5 placed at x = 1 m was
    served the base part of one at the origin."""
    from hriplan.robots.spatial import Pose

    here, there = load_robot("ur5"), load_robot("ur5", base_pose=Pose(xyz=(1.0, 0.0, 0.5)))
    base_here = next(p for p in _parts(here, 0.0) if p.link == "base_link")
    base_there = next(p for p in _parts(there, 0.0) if p.link == "base_link")
    assert base_here.joint == base_there.joint == 0
    assert np.allclose(base_there.placement.translation - base_here.placement.translation, (1.0, 0.0, 0.5))
    assert len(list(cache.glob("parts-ur5-*.json"))) == 2


def test_parts_are_fitted_again_when_a_robot_file_changes_its_arm(cache, tmp_path, robot_registry):
    """A robot file rewritten with a shorter arm (the same name and URDF) plans fewer joints: the
    links it no longer moves are fixed to the last joint it does. The old key served the parts
    of the longer arm, on joints the new model does not have (found with TIAGo's `robot init`)."""
    from hriplan.robots.descriptions.registry import DESCRIPTIONS, load_robot_file

    urdf = "package://example-robot-data/robots/ur_description/urdf/ur5_robot.urdf"
    stopping = "stopping: {reaction_time: 0.1, stopping_time: 0.2, position_uncertainty: 0.02, moving_mass: 6.0}\n"
    joints_of = {}
    for tip in ("wrist_3_link", "forearm_link"):
        path = tmp_path / f"arm_to_{tip}.yaml"  # another file: a process keeps the robot a file loaded
        path.write_text(f"name: cached_arm\nurdf: {urdf}\narms:\n  arm: {{base: base_link, tip: {tip}}}\n{stopping}")
        DESCRIPTIONS.pop("cached_arm", None)
        robot = load_robot(load_robot_file(path).name)
        parts = {p.link: p for p in _parts(robot, 0.0)}
        joints_of[tip] = robot.model.njoints
        wrist = parts["wrist_3_link"]
        assert wrist.joint < robot.model.njoints
        # Where the part is, by the planning model, is where the URDF's link is (all joints at 0).
        data = robot.model.createData()
        pin.framesForwardKinematics(robot.model, data, pin.neutral(robot.model))
        link = data.oMf[robot.model.getFrameId("wrist_3_link")]
        part_at = data.oMi[wrist.joint] * wrist.placement
        assert np.linalg.norm(link.translation - part_at.translation) < 0.1  # the capsule's centre near its link
    assert joints_of == {"wrist_3_link": 7, "forearm_link": 4}
    assert len(list(cache.glob("parts-cached_arm-*.json"))) == 2


def test_a_shipped_fit_is_read_copied_into_the_cache_and_a_broken_one_fitted(cache, tmp_path, monkeypatch):
    from hriplan.robots import fit_cache

    seeds = tmp_path / "seeds"
    seeds.mkdir()
    monkeypatch.setattr(fit_cache, "SEEDS", seeds)
    name = fit_cache.fit_name("thing", ("rules", 1))
    (seeds / f"{name}.gz").write_bytes(gzip.compress(json.dumps({"value": [3.0]}).encode()))
    assert cached_fit("thing", ("rules", 1), lambda: pytest.fail("fitted though shipped")) == {"value": [3.0]}
    assert json.loads((cache / name).read_text()) == {"value": [3.0]}  # kept in the cache since
    other = fit_cache.fit_name("thing", ("rules", 2))
    (seeds / f"{other}.gz").write_bytes(b"not gzip")
    assert cached_fit("thing", ("rules", 2), lambda: {"value": [4.0]}) == {"value": [4.0]}


def test_the_built_in_robots_clearance_sub_cells_are_shipped_current(cache, monkeypatch):
    """A machine that never fitted them reads every built-in robot's sub-cells from the shipped
    files (tools/seed_fits.py writes them again when the rules or the meshes change), and so
    certifies the same states as where they were computed."""
    from hriplan.robots import fit_cache, mesh_clearance
    from hriplan.robots.collision import CollisionChecker

    shipped = json.loads((fit_cache.SEEDS / "versions.json").read_text())
    if shipped != fit_cache.fit_versions():  # a newer mesh package or library: they are computed, as before
        pytest.skip(f"the shipped fits are for {shipped}, this machine has {fit_cache.fit_versions()}")
    monkeypatch.setattr(mesh_clearance, "_fine_words", lambda *args: pytest.fail("sub-cells computed, not shipped"))
    for name in ("ur5", "madar"):
        checker = CollisionChecker(load_robot(name))
        checker._ready()
        tables = [table for table, _ in checker._tabled]
        assert tables and all(table.words is not None for table in tables)
        assert any(((table.words != 0) & ~table.free).any() for table in tables)  # sub-cells certified
