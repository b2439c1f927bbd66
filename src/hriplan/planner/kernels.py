"""Turning the compiled kernels on in a long-running process, loaded before its first request.

Why: a process pays ~1 s to import numba and load the cached kernels (~16 s of CPU to compile
them on the first use after installation), more than a one-off `hriplan plan` spends where they
help, so the CLI leaves them off (`robots/kernel_switch.py`). A service's planning workers and a
motion manager plan for hours; they turn them on (constrained solves x0.59-0.86, re-plans
x0.92-0.93: benchmarks/REPORT-kernels.md) and load them here, at start, so that no request pays
the load. `python -m hriplan.planner.kernels` compiles them into numba's cache once, at
installation (the Makefile does), so that no first use pays the compile either.
"""

from __future__ import annotations

import numpy as np

from hriplan.planner.constraints.binding import bind
from hriplan.planner.constraints.evaluator import ConstraintEvaluator
from hriplan.planner.constraints.spec import BoxConstraint, FrameRef, OrientationConstraint
from hriplan.planner.session import PlanningSession
from hriplan.planner.validate import densify
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.descriptions.registry import posture
from hriplan.robots.human import HumanSpec
from hriplan.robots.kernel_switch import kernels_on, use_kernels
from hriplan.robots.model import load_robot
from hriplan.robots.scene import Scene
from hriplan.robots.spatial import Pose
from hriplan.safety.approach import ApproachMonitor
from hriplan.safety.person_distance import nearest_moving
from hriplan.safety.separation import PersonSeparation, RobotStopping, SeparationPolicy


def load_kernels() -> bool:
    """Turn the kernels on in this process, and load every one of them (compiling any not yet
    cached): the collision certifier's and the constraint terms' called once each on the
    built-in UR5 and CBiRRT's walk through them, the ISO/TS 15066 monitor's on MADAR, TOPP-RA's
    passes and its spline on a short UR5 motion (robots and checkers stay cached).
    False (and the kernels stay off) without numba, the `fast` extra."""
    use_kernels(True)
    if not kernels_on():
        return False
    robot = load_robot("ur5")
    checker = CollisionChecker(robot, Scene())
    q = robot.configuration(posture("ur5", "ready"))
    joints, tool = robot.group_joints("arm"), robot.tool_frame("arm")
    upright = OrientationConstraint(id="upright", joints=joints, target_link=tool, free_axes=["z"], tolerance=0.2)
    box = BoxConstraint(id="box", joints=joints, target_link=tool, frame=FrameRef(offset=Pose()), size=(2, 2, 2))
    evaluator = ConstraintEvaluator(robot, bind([upright, box], robot, checker), "arm", q)
    x = q[robot.group_indices("arm")]
    checker.in_collision(q)
    checker.first_collision(q[None])
    _mesh_pairs()
    evaluator.margins(q)  # a whole configuration; gradients take the planned joints' values
    evaluator.gradients(x)
    evaluator.margins_many(np.repeat(q[None], 2, axis=0))
    densify(np.repeat(x[None], 2, axis=0), 0.01)  # the validated and the timed paths' interpolation
    _band_walk(evaluator, checker, robot.limits("arm"), x)
    _monitor()
    _toppra(x)
    return True


def _band_walk(evaluator: ConstraintEvaluator, checker: CollisionChecker, bounds, x: np.ndarray) -> None:
    """CBiRRT's compiled projection, walk (with and without bands) and nearest node
    (`band_kernels.py`), and its whole loop (`loop_kernels.py`, given no time: compiled, not run)
    with the blocks where it asks Python."""
    from hriplan.planner.search.band_kernels import BandWalker
    from hriplan.planner.search.loop_kernels import load_callbacks, search

    walker = BandWalker.of(evaluator, bounds)
    certifier = checker.compiled_verdict(evaluator.full(x))
    walker.project(x, 4e-3, 2e-3)
    walker.nearest(np.repeat(x[None], 2, axis=0), 2, x)
    for bands in ((4e-3, 2e-3), None):
        walker.walk(x, x + 0.1, 0.05, 3, bands, certifier)
    arguments = walker.arguments(0.05, True, 4e-3, 2e-3, certifier)
    search(x, x + 0.1, np.random.default_rng(0), 0.0, 10, arguments, np.zeros(1, dtype=np.int64))
    load_callbacks()


def _mesh_pairs() -> None:
    """The tabled mesh pairs' walk over their triangles' trees (`mesh_pair_kernels.py`)."""
    from hriplan.robots.mesh_pairs import load_kernel

    load_kernel()


def _toppra(x: np.ndarray) -> None:
    """TOPP-RA's compiled retiming under joint limits (`retime_kernels.py`), its passes driven
    stage-wise under a path-speed limit (`toppra_kernels.py`) and its path's solve and
    evaluation (`spline_kernels.py`): a short motion of the UR5's arm timed without and with one."""
    from hriplan.planner.timing import time_parameterize

    velocity, acceleration = np.full(len(x), 1.0), np.full(len(x), 2.0)
    waypoints = x + np.linspace(0.0, 0.3, 5)[:, None]
    time_parameterize(waypoints, velocity, acceleration)
    time_parameterize(waypoints, velocity, acceleration, speed_scale=lambda q, dq: np.full(len(q), 2.0))


def _monitor() -> None:
    """The monitor's kernels and the closest approach's, on MADAR's right arm with its hand open
    (palm boxes, adapter cylinders) moving beside a person whose right hand holds the tool frame
    (rows touching her: left to coal and folded in), at rest (so never closing in on her)."""
    session = PlanningSession("madar", hands={"right": "open"})
    q = session.robot.configuration(posture("madar", "ready"))
    tool = session.robot.frame_pose(session.robot.tool_frame("right"), q)[:3, 3]
    person = HumanSpec(
        name="visitor", position=(tool[0] + 0.55, tool[1]), yaw=1.25 * np.pi, reach={"right": tuple(tool)}
    )
    session.set_scene(Scene(humans=[person]))
    stopping = RobotStopping(reaction_time=0.1, stopping_time=0.2, position_uncertainty=0.01, moving_mass=10.0)
    visitor = PersonSeparation(name="visitor", approach_speed=1.6, intrusion=0.2, sensor_uncertainty=0.05)
    policy = SeparationPolicy(robot=stopping, people=[visitor])
    x = session.robot.group_values(q, "right_arm")
    xs = x + np.linspace(0.0, 1.0, 8)[:, None] * np.array([0.8, -0.4, 0.4, 0.3, -0.2, 0.5])
    monitor = ApproachMonitor(session.robot, session.checker, policy, "right_arm", q)
    monitor.speed_scale(xs, np.zeros(xs.shape))
    states = np.repeat(q[None], len(xs), axis=0)
    states[:, session.robot.group_indices("right_arm")] = xs
    session.checker.closest_human(states, nearest_moving)  # a path report's closest approach


if __name__ == "__main__":
    import time

    started = time.perf_counter()
    if load_kernels():
        print(f"hriplan: compiled kernels loaded (compiled if not cached) in {time.perf_counter() - started:.1f} s")
    else:
        print("hriplan: numba is not installed (the fast extra): the compiled kernels stay off")
