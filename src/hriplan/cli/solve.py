"""`hriplan solve`: plan a planning-problem file and report what the motion respected."""

from __future__ import annotations

from pathlib import Path

import typer

from hriplan.cli.outputs import file_output
from hriplan.cli.summary import separation_phrase
from hriplan.planner.motion import JointTarget
from hriplan.planner.problem import load_problem
from hriplan.planner.session import PlanningSession
from hriplan.safety.policy import default_policy
from hriplan.tasks.joints import check_joint_values


def solve_problem_file(path: Path, output: Path | None, seed: int | None, as_json: bool) -> int:
    """Exit code: 0 solved, 1 planning failed (with the reason)."""
    if output is not None:
        file_output(output)
    problem = load_problem(path)
    check_joint_values(problem.start, problem.robot, f"{path}: start")
    if isinstance(problem.goal, JointTarget) and isinstance(problem.goal.values, dict):
        check_joint_values(problem.goal.values, problem.robot, f"{path}: goal")
    session = PlanningSession(problem.robot, problem.scene, problem.hands or None)
    session.check_people_clear(problem.start)
    session.set_constraints(problem.constraints)
    options = problem.options if seed is None else problem.options.model_copy(update={"seed": seed})
    safety = default_policy(problem.robot, problem.scene.humans, problem.roles)  # ISO/TS 15066
    result = session.plan(problem.start, problem.goal, options, problem.group, safety=safety)
    if not result.solved:
        typer.echo(f"planning failed ({result.status}): {result.message}", err=True)
        return 1
    trajectory, leave = result.trajectory, result.leave
    left = None if output is None or leave is None else output.with_name(f"{output.stem}.leave{output.suffix}")
    if output is not None:
        output.parent.mkdir(parents=True, exist_ok=True)
        trajectory.save(output)
        if left is not None:
            leave.save(left)
    report = trajectory.report
    if as_json:
        typer.echo(report.model_dump_json(indent=1))
        return 0
    lines = (
        []
        if leave is None
        else [
            f"{problem.name}: the start lay in a keep-out volume or a person's minimum separation: a leave phase "
            f"first, {len(leave.points)} points over {leave.report.duration:.2f} s, coming closer to no one"
            + ("" if left is None else f" (written to {left})")
        ]
    )
    lines += [
        f"{problem.name}: solved in {report.planning_time:.3f} s ({report.planner} on the {report.space} space), "
        f"{len(trajectory.points)} points over {report.duration:.2f} s, path {report.path_length:.2f} rad (straight line {report.straight_length:.2f})",
        f"validated at {report.states_checked} states (<= {options.validation_step} rad apart):",
    ]
    for constraint in trajectory.constraints:
        spec = constraint.spec
        lines.append(f"  {spec.id:28s} {spec.type:12s} worst margin {report.max_violation[spec.id]:+.4f} (<= 0 kept)")
    if report.min_human_distance is not None:
        lines.append(
            f"closest approach to a person: {report.min_human_distance:.3f} m ({' - '.join(report.closest_pair)})"
        )
    lines += [f"speed and separation: {separation_phrase(trace)}" for trace in report.separation]
    if output is not None:
        lines.append(f"trajectory written to {output}")
    typer.echo("\n".join(lines))
    return 0
