"""The glass benchmark's problems (benchmarks/glass/, benchmarks/bench_glass.py): the generator
writes exactly the shipped files, every problem loads with its start and goal upright within its
tolerance (the orientation by tests/independent.py, not hriplan's evaluator), the path check
finds a tilt, a collision and a keep-out entry where they are, and one problem (the Panda in
clutter, whose path uses its band) solves through `hriplan solve` into a motion the tests' own
geometry finds upright and collision-free."""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from hriplan.cli.main import app
from hriplan.planner.problem import load_problem
from hriplan.planner.trajectory import load_trajectory
from independent import UrdfRobot, check_path, densified

GLASS = Path(__file__).parents[2] / "benchmarks" / "glass"
SHIPPED = sorted(GLASS.glob("*.json"))

pytestmark = pytest.mark.usefixtures("module_robot_registry")


def make_glass():
    spec = importlib.util.spec_from_file_location("make_glass", GLASS / "make_glass.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["make_glass"] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def problems():
    return {path.stem: load_problem(path) for path in SHIPPED}


def test_the_generator_writes_the_shipped_files():
    generator = make_glass()
    written = {f"{p.name}.json": generator.file_text(p) for p in generator.glass_problems()}
    assert sorted(written) == [path.name for path in SHIPPED]
    for path in SHIPPED:
        assert written[path.name] == path.read_text(), f"{path.name} is not what make_glass.py writes"


def test_twenty_problems_over_three_robots_hold_the_glass_upright_and_free_about_vertical(problems):
    robots = [p.robot for p in problems.values()]
    assert len(problems) == 20
    assert (robots.count("ur5"), robots.count("franka_panda"), robots.count("madar")) == (8, 6, 6)
    tolerances = []
    for p in problems.values():
        upright = next(c for c in p.constraints.constraints if c.type == "orientation")
        tolerances.append(upright.tolerance)
        assert len(upright.free_axes) == 1 and upright.tolerance_gradient == 0.0
        # The free axis is the glass's: at the target it stands vertical in the world.
        axis = "xyz".index(upright.free_axes[0])
        assert abs(upright.target.rotation()[:, axis] @ (0.0, 0.0, 1.0)) == pytest.approx(1.0)
        assert len(p.scene.attached) == 1 and p.scene.attached[0].name == "glass"
        # Each person has a keep-out cylinder that every link stays out of.
        keep_outs = [c for c in p.constraints.constraints if c.type == "cylinder" and c.keep_out_all_links]
        assert sorted(c.frame.entity for c in keep_outs) == sorted(f"{h.name}/base" for h in p.scene.humans)
    assert tolerances.count(0.01) == 6 and tolerances.count(0.05) == 14
    assert sum(bool(p.scene.humans) for p in problems.values()) == 5


def spin_and_tilt(robot: UrdfRobot, problem, values: dict[str, float]) -> tuple[float, float]:
    """The tool's glass axis angle from vertical and its spin about vertical, by pinocchio on
    the URDF (the tool's other axes projected on the floor)."""
    upright = next(c for c in problem.constraints.constraints if c.type == "orientation")
    robot.configure(dict(problem.start) | values)
    rotation = robot.pose(upright.target_link).rotation
    axis = "xyz".index(upright.free_axes[0])
    tilt = math.acos(min(1.0, abs(rotation[2, axis])))
    other = rotation[:, (axis + 1) % 3]
    return tilt, math.atan2(other[1], other[0])


def test_every_start_and_goal_is_upright_within_its_tolerance_and_the_spin_differs(problems):
    robots = {}
    for p in problems.values():
        key = (p.robot, tuple(p.hands.items()))
        robot = robots[key] = robots.get(key) or UrdfRobot(p.robot, dict(p.hands))
        tolerance = next(c.tolerance for c in p.constraints.constraints if c.type == "orientation")
        joints = list(p.goal.values)
        start_tilt, start_spin = spin_and_tilt(robot, p, {j: p.start[j] for j in joints})
        goal_tilt, goal_spin = spin_and_tilt(robot, p, dict(p.goal.values))
        assert start_tilt <= tolerance and goal_tilt <= tolerance, p.name
        turned = abs(math.remainder(goal_spin - start_spin, 2 * math.pi))
        assert turned > 0.3, f"{p.name}: start and goal spin alike ({turned:.2f} rad)"
        # Both free of obstacles and keep-out volumes, by coal on the URDF's meshes.
        ends = np.array([[p.start[j] for j in joints], list(p.goal.values.values())])
        assert check_path(p, joints, ends, step=10.0, robot=robot).breaches({"glass_upright": tolerance}) == [], p.name


def test_the_path_check_measures_a_tilt_along_the_path(problems):
    """The UR5's wrist_2 tilts its downward tool by exactly the angle it turns: a path turning it
    0.03 rad stays within 0.05 rad, 0.08 rad breaks it by what it turned, found between the rows."""
    p = problems["ur5_open"]
    joints = list(p.goal.values)
    start = np.array([p.start[j] for j in joints])
    wrist = joints.index("wrist_2_joint")
    for turn, broken in ((0.03, False), (0.08, True)):
        there = start.copy()
        there[wrist] += turn
        path = np.array([start, there, start])
        check = check_path(p, joints, path)
        assert check.orientation["glass_upright"] == pytest.approx(turn, abs=1e-6)
        states = densified(path, 0.01)
        assert check.states == len(states) > 2 * turn / 0.01 and np.abs(np.diff(states, axis=0)).max() <= 0.01 + 1e-12
        assert bool(check.breaches({"glass_upright": 0.05})) == broken


def test_the_path_check_finds_the_glass_in_the_table_and_an_arm_in_a_keep_out(problems):
    """Lowering the UR5's shoulder and raising its wrist as much keeps the tool pointing down
    and puts the glass into the table; an arm turned towards a person brought 0.3 m closer
    enters their keep-out cylinder, which it stays 0.1 m out of where they stand."""
    p = problems["ur5_open"]
    joints = list(p.goal.values)
    start = np.array([p.start[j] for j in joints])
    lowered = start + 0.6 * (np.array(joints) == "shoulder_lift_joint") - 0.6 * (np.array(joints) == "wrist_1_joint")
    check = check_path(p, joints, np.array([start, lowered]))
    assert check.orientation["glass_upright"] < 1e-6
    assert check.clearance[0] < -0.03 and check.clearance[1] == "glass - table"
    assert check.breaches({"glass_upright": 0.05}) == [f"collision glass - table ({check.clearance[0]:.4f} m)"]
    p = problems["ur5_person"]
    turned = np.array([4.0, *[p.start[j] for j in joints[1:]]])  # shoulder_pan towards pat
    assert check_path(p, joints, turned[None]).keep_out[0] > 0.1
    pat = p.scene.humans[0]
    closer = pat.model_copy(update={"position": (pat.position[0] - 0.2, pat.position[1] - 0.25)})
    nearer = p.model_copy(update={"scene": p.scene.model_copy(update={"humans": [closer]})})
    check = check_path(nearer, joints, turned[None])
    assert check.keep_out[0] < 0.0 and check.breaches({"glass_upright": 0.05}) == [
        f"keep-out entered by {check.keep_out[1]}"
    ]


@pytest.mark.parametrize("name", ["panda_clutter"])
def test_a_problem_solves_into_a_motion_the_tests_geometry_accepts(name, problems, tmp_path):
    out = tmp_path / f"{name}.json"
    result = CliRunner().invoke(app, ["solve", str(GLASS / f"{name}.json"), "--seed", "1", "-o", str(out)])
    assert result.exit_code == 0, result.output
    trajectory = load_trajectory(out)
    p = problems[name]
    positions = np.array([point.positions for point in trajectory.points])
    check = check_path(p, trajectory.joint_names, positions)
    tolerance = next(c.tolerance for c in p.constraints.constraints if c.type == "orientation")
    assert check.breaches({"glass_upright": tolerance}) == []
    assert check.orientation["glass_upright"] <= tolerance and check.clearance[0] > 0.0
    assert check.keep_out[0] > 0.0 if p.scene.humans else check.keep_out[0] == math.inf
    assert np.allclose(positions[0], [p.start[j] for j in trajectory.joint_names], atol=1e-6)
    assert np.allclose(positions[-1], [p.goal.values[j] for j in trajectory.joint_names], atol=1e-6)
