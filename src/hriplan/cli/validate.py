"""`hriplan validate`: re-check a trajectory file, or a bare ROS JointTrajectory message placed in a
task step or a planning problem, as a planned motion is checked: constraints densely, collisions,
joint limits and speeds (of the spline a controller follows), ISO/TS 15066 speed and separation.
Exit 1 when the motion fails a check, 2 on bad input."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hriplan import HriplanError
from hriplan.cli.progress import progress
from hriplan.cli.tasks import Quiet, TaskOption, _runner, load_for_task
from hriplan.collector import collector_paused_while_importing

StepOption = Annotated[
    str | None, typer.Option("--step", help="With --task: the task step a JointTrajectory message moves in.")
]
ProblemOption = Annotated[
    Path | None,
    typer.Option("--problem", help="Check a JointTrajectory message in this planning-problem file (as `solve` takes)."),
]


def _problem_setting(path: Path):
    """The setting of a planning-problem file: its robot from its start, scene, constraints, people's roles."""
    from hriplan.planner.problem import load_problem
    from hriplan.planner.session import PlanningSession
    from hriplan.tasks.joints import check_joint_values

    problem = load_problem(path)
    check_joint_values(problem.start, problem.robot, f"{path}: start")
    session = PlanningSession(problem.robot, problem.scene, problem.hands or None, problem.roles)
    session.set_constraints(problem.constraints)
    return session.setting(problem.start, problem.options.velocity_scale)


def _message_world(path: Path, task: Path | None, step: str | None, problem: Path | None, quiet: bool):
    """A JointTrajectory message placed in its setting: (trajectory, ISO/TS 15066 policy, velocity scale, notes)."""
    from hriplan.formats.ros_trajectory import load_joint_trajectory, place
    from hriplan.tasks.joints import check_joint_values
    from hriplan.tasks.pipeline import step_setting

    message = load_joint_trajectory(path)  # a bad message is said before any reasoning
    if (task is None) == (problem is None):
        raise HriplanError(
            f"{path} is a ROS JointTrajectory: give where it moves, a task step (--task TASK --step NAME) "
            "or a planning problem (--problem FILE)"
        )
    if task is not None and step is None:
        raise HriplanError("--task needs --step NAME for a JointTrajectory message: the task step it moves in")
    if problem is not None and step is not None:
        raise HriplanError("--step names a step of --task; a planning problem has one motion")
    if task is not None:
        with progress(quiet) as report:
            setting = step_setting(_runner(task, report), step)
    else:
        setting = _problem_setting(problem)
    placed = place(message, setting)
    first = dict(zip(message.joint_names, message.points[0].positions))
    check_joint_values(first, setting.robot, f"{path}: points.0")
    return placed, setting.policy, setting.velocity_scale, placed.notes


def _file_world(path: Path, task: Path | None, quiet: bool):
    """A trajectory file (its constraints and scene from `task` if given): (trajectory, policy, velocity scale, notes)."""
    from hriplan.safety.policy import default_policy
    from hriplan.safety.separation import NO_MARGIN

    plan_file = load_for_task(path, task, quiet)
    policy = None
    if plan_file.report.separation and plan_file.scene.humans:  # timed for people: re-check it, by their roles
        roles = {trace.person: trace.role for trace in plan_file.report.separation if trace.role}
        margin = plan_file.report.safety_margin or NO_MARGIN  # as the file was timed
        policy = default_policy(plan_file.robot, plan_file.scene.humans, roles).model_copy(update={"margin": margin})
    return plan_file, policy, plan_file.report.velocity_scale, []


def validate(
    trajectory: Annotated[
        Path,
        typer.Argument(
            help="A trajectory file, or a ROS JointTrajectory message (YAML as `ros2 topic echo --once` prints it, or JSON).",
            show_default=False,
        ),
    ],
    task: TaskOption = None,
    step: StepOption = None,
    problem: ProblemOption = None,
    quiet: Quiet = False,
) -> None:
    """Re-check a trajectory densely against its constraints and collisions, its joint limits and
    speeds (the spline a controller follows through the points), and its speed near people against
    ISO/TS 15066 (exit 1 if it fails). A JointTrajectory message is checked in a task step (--task,
    --step) or a planning problem (--problem); joints it omits stay at the start."""
    with collector_paused_while_importing():
        from hriplan.formats.ros_trajectory import is_joint_trajectory_message
        from hriplan.planner.replay import PlannedWorld

    if is_joint_trajectory_message(trajectory):
        planned, policy, velocity_scale, notes = _message_world(trajectory, task, step, problem, quiet)
    elif step is not None or problem is not None:
        raise HriplanError(f"--step and --problem place a JointTrajectory message; {trajectory} is a trajectory file")
    else:
        planned, policy, velocity_scale, notes = _file_world(trajectory, task, quiet)
    world = PlannedWorld.load(planned)
    for note in notes:
        typer.echo(f"note: {note}")
    result = world.validate()
    for check in result.constraints:
        typer.echo(
            f"{check.id:32s} worst margin {check.max_violation:+.4f} {'kept' if check.satisfied else 'VIOLATED'}"
        )
    typer.echo(f"collision: {result.collision or 'none'}; checked {result.states_checked} states")
    joints = world.joint_check(velocity_scale)
    typer.echo(f"joints: {'kept' if joints.kept else 'EXCEEDED'}, {joints.message}")
    speed = None
    if policy is not None and world.trajectory.scene.humans:
        speed = world.speed_check(policy)
        typer.echo(
            f"speed and separation (ISO/TS 15066, {policy.margin}): {'kept' if speed.kept else 'EXCEEDED'}, {speed.message}"
        )
    failures = [result.message] if not result.valid else []
    failures += [] if joints.kept else [f"beyond a joint's limits: {joints.message}"]
    failures += [] if speed is None or speed.kept else [f"faster than ISO/TS 15066 allows near people: {speed.message}"]
    if failures:
        typer.echo(f"invalid: {'; '.join(failures)}", err=True)
        raise typer.Exit(1)
