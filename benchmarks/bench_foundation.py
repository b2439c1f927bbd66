"""Foundation benchmark: kinematics, collision, clearance and IK costs on this machine.

Run: make bench   (or .venv/bin/python benchmarks/bench_foundation.py)
Prints a markdown table; REPORT-foundation.md records a run and what it means.
"""

from __future__ import annotations

import platform
import time

import numpy as np
import pinocchio as pin

from hriplan.robots.collision import CollisionChecker
from hriplan.robots.human import HumanSpec
from hriplan.robots.ik import solve_ik
from hriplan.robots.model import load_robot
from hriplan.robots.scene import Box, Cylinder, Obstacle, Scene, Sphere, table
from hriplan.robots.spatial import Pose

REPEATS = 5


def per_call_us(func, args_list) -> float:
    """Median over REPEATS runs of the mean cost of one call, in microseconds."""
    runs = []
    for _ in range(REPEATS):
        start = time.perf_counter()
        for args in args_list:
            func(*args)
        runs.append((time.perf_counter() - start) / len(args_list) * 1e6)
    return float(np.median(runs))


def bench_scene() -> Scene:
    objects = [
        Obstacle(name="can", shape=Cylinder(radius=0.033, height=0.12), pose=Pose(xyz=(0.45, 0.85, 0.78))),
        Obstacle(name="box", shape=Box(size=(0.1, 0.1, 0.1)), pose=Pose(xyz=(0.3, 1.0, 0.77))),
        Obstacle(name="ball", shape=Sphere(radius=0.05), pose=Pose(xyz=(0.6, 1.0, 0.77))),
    ]
    person = HumanSpec(name="human", position=(0.0, 1.6), yaw=-np.pi / 2, reach={"right": (0.0, 1.2, 1.05)})
    return Scene(obstacles=[table(position=(0.45, 0.9), size=(0.6, 0.6, 0.04), top=0.72), *objects], humans=[person])


def main() -> None:
    rng = np.random.default_rng(0)
    robot = load_robot("madar", {"right": "power", "left": "open"})
    checker = CollisionChecker(robot, bench_scene())
    lower, upper = robot.limits()
    qs = [rng.uniform(lower, upper) for _ in range(2000)]
    free = [q for q in qs if not checker.in_collision(q)]
    tool = robot.frame_id("right_tool")
    model, data = robot.model, robot.data
    # A path moves one group: the right arm through the free states' values, the rest standing still.
    arm_path = np.array([free[0]] * 300)
    arm_path[:, robot.group_indices("right_arm")] = np.array(free[:300])[:, robot.group_indices("right_arm")]

    def fk_frame(q: np.ndarray) -> None:
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacement(model, data, tool)

    rows = [
        ("FK + one frame (pinocchio, direct)", per_call_us(fk_frame, [(q,) for q in qs]), ""),
        (
            "robot.frame_pose (API, 4x4 out)",
            per_call_us(lambda q: robot.frame_pose("right_tool", q), [(q,) for q in qs]),
            "",
        ),
        (
            "frame Jacobian (pinocchio, FK included)",
            per_call_us(
                lambda q: pin.computeFrameJacobian(model, data, q, tool, pin.LOCAL_WORLD_ALIGNED), [(q,) for q in qs]
            ),
            "",
        ),
        (
            "robot.frame_jacobian (API, group columns)",
            per_call_us(lambda q: robot.frame_jacobian("right_tool", q), [(q,) for q in qs]),
            "",
        ),
        (
            "collision check, random configurations",
            per_call_us(checker.in_collision, [(q,) for q in qs]),
            f"{100 * (1 - len(free) / len(qs)):.0f} % in collision",
        ),
        (
            "collision check, collision-free configurations",
            per_call_us(checker.in_collision, [(q,) for q in free]),
            f"{len(free)} configurations, {len(checker.geom_model.collisionPairs)} pairs",
        ),
        (
            "robot-human minimum distance (300 configurations of the right arm in one call, per configuration)",
            per_call_us(checker.human_distances, [(arm_path,)]) / len(arm_path),
            f"{sum(1 for p in checker._distance_model.collisionPairs)} pairs",
        ),
    ]

    # IK: targets are tool poses of random joint values (reachable by construction).
    targets = [robot.frame_pose("right_tool", rng.uniform(*robot.limits("right_arm")), "right_arm") for _ in range(200)]
    times, ok = [], 0
    for target in targets:
        start = time.perf_counter()
        ok += solve_ik(robot, "right", target).success
        times.append((time.perf_counter() - start) * 1e3)
    coll_times, coll_ok = [], 0
    valid = lambda q: not checker.in_collision(q)  # noqa: E731
    for target in targets:
        start = time.perf_counter()
        coll_ok += solve_ik(robot, "right", target, base_q=free[0], is_valid=valid).success
        coll_times.append((time.perf_counter() - start) * 1e3)

    print(
        f"machine: {platform.processor() or platform.machine()}, Python {platform.python_version()}, pin {pin.__version__}"
    )
    print("| what | µs per call | note |\n|---|---|---|")
    for name, value, note in rows:
        print(f"| {name} | {value:.1f} | {note} |")
    print(
        "| IK, 200 random reachable poses | median "
        f"{np.median(times) * 1e3:.0f}, p95 {np.percentile(times, 95) * 1e3:.0f} | success {ok}/200 |"
    )
    print(
        "| IK + collision-free requirement (scene above) | median "
        f"{np.median(coll_times) * 1e3:.0f}, p95 {np.percentile(coll_times, 95) * 1e3:.0f} | success {coll_ok}/200 (some poses have no collision-free branch) |"
    )


if __name__ == "__main__":
    main()
