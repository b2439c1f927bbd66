"""Speed and separation benchmark: what ISO/TS 15066 timing costs and how much it slows motions.

For every step of the examples that plans: the validated path timed without and with the step's
separation policy (same path, same knots), the motion durations, the timing's compute time, and
how close each person's speed came to its limit.

Run: .venv/bin/python benchmarks/bench_separation.py   (REPORT-separation.md records a run)
"""

from __future__ import annotations

import functools
import platform
import time
from pathlib import Path

import numpy as np

from hriplan.planner.timing import time_parameterize
from hriplan.planner.validate import densify
from hriplan.safety.approach import ApproachMonitor
from hriplan.tasks.load import load_task
from hriplan.tasks.pipeline import TaskRunner

EXAMPLES = Path(__file__).parents[1] / "examples"
KNOT_STEP = 0.05  # as the session's first timing attempt


def _timed(fn):
    start = time.perf_counter()
    result = fn()
    return result, time.perf_counter() - start


def main() -> None:
    print(
        f"# Speed and separation timing ({platform.processor() or platform.machine()}, {platform.python_version()})\n"
    )
    print(
        "| example / step | people | duration free (s) | duration SSM (s) | slower | timing free (ms) | timing SSM (ms) | max speed / allowed |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for path in sorted(EXAMPLES.glob("*.yaml")):
        runner = TaskRunner(load_task(path), EXAMPLES)
        outcome = runner.run()
        session = runner.session
        for step in outcome.steps:
            if step.trajectory is None:
                print(f"| {path.stem} / {step.name} | - | {step.status} | | | | | |")
                continue
            traj, policy = step.trajectory, step.derivation.separation
            robot = session.robot
            session.set_scene(step.scene)
            group = next(g for g in robot.groups if robot.group_joints(g) == traj.joint_names)
            q0 = robot.configuration(traj.start)
            knots = densify([np.array(p.positions) for p in traj.points], KNOT_STEP)
            vmax = robot.velocity_limit(group)
            amax = np.full(len(vmax), 3.14159)
            scale = traj.report.velocity_scale
            monitor = ApproachMonitor(robot, session.checker, policy, group, q0)
            free, t_free = _timed(functools.partial(time_parameterize, knots, vmax, amax, velocity_scale=scale))
            limited, t_ssm = _timed(
                functools.partial(
                    time_parameterize, knots, vmax, amax, velocity_scale=scale, speed_scale=monitor.speed_scale
                )
            )
            ratio = max(
                (
                    a / b
                    for t in traj.report.separation
                    for a, b in zip(t.approach_speed, t.allowed_speed)
                    if a is not None and b
                ),
                default=0.0,
            )
            d_free, d_ssm = free.times[-1], limited.times[-1]
            print(
                f"| {path.stem} / {step.name} | {len(step.scene.humans)} | {d_free:.3f} | {d_ssm:.3f} | {100 * (d_ssm / d_free - 1):+.1f}% "
                f"| {1e3 * t_free:.0f} | {1e3 * t_ssm:.0f} | {ratio:.3f} |"
            )


if __name__ == "__main__":
    main()
