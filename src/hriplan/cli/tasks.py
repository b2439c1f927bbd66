"""Task commands: plan, constraints, explain, query, import-kautham, schema (validate: cli/validate.py).

Exit codes: 0 success, 1 planning (or validation) failed with the reason, 2 bad input, 130
interrupted. Outputs are checked before the work starts (`cli/outputs.py`).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Literal

import typer

from hriplan import HriplanError
from hriplan.cli.outputs import directory_output, file_output
from hriplan.cli.progress import progress
from hriplan.collector import collector_paused_while_importing
from hriplan.ontology.reasoners import Reasoner, use_reasoner
from hriplan.planner.outcome import Status

TaskArgument = Annotated[Path, typer.Argument(help="A task file (YAML or JSON).", show_default=False)]
Quiet = Annotated[bool, typer.Option("--quiet", "-q", help="No progress messages.")]
Verbose = Annotated[bool, typer.Option("--verbose", "-v", help="More detail: rules and facts, constraint calls.")]
ReasonerOption = Annotated[
    Reasoner, typer.Option(callback=use_reasoner, help="fast: the rules in process; pellet: the reference.")
]


def load_checked_task(task_path: Path, seed: int | None = None, project_start: bool | None = None):
    """The task file, its joint values checked against the robot, with the command line's overrides."""
    from hriplan.tasks.joints import check_task_joints
    from hriplan.tasks.load import load_task

    task = load_task(task_path)
    overrides = {k: v for k, v in {"seed": seed, "project_start": project_start}.items() if v is not None}
    if overrides:
        task = task.model_copy(update={"planning": task.planning.model_copy(update=overrides)})
    check_task_joints(task)
    return task


def _runner(task_path: Path, report: Callable[[str], None], task=None):
    from hriplan.tasks.pipeline import TaskRunner

    return TaskRunner(task or load_checked_task(task_path), task_path.parent, report)


def load_for_task(trajectory: Path, task: Path | None, quiet: bool = True):
    """A trajectory file, with its step's constraints and scene taken from `task` if given."""
    from hriplan.planner.trajectory import load_trajectory
    from hriplan.tasks.joints import check_joint_values

    plan_file = load_trajectory(trajectory)
    check_joint_values(
        dict(zip(plan_file.joint_names, plan_file.points[0].positions)), plan_file.robot, f"{trajectory}: joint_names"
    )
    if task is None:
        return plan_file
    from hriplan.tasks.pipeline import against_task  # the reasoning (rdflib, the rules) only for a task

    with progress(quiet) as report:
        return against_task(plan_file, _runner(task, report))


TaskOption = Annotated[
    Path | None, typer.Option("--task", help="Take the constraints, reasons and scene from this task file.")
]


def _step_path(output: Path, step: str, several: bool) -> Path:
    return output.with_name(f"{output.stem}.{step}{output.suffix}") if several else output


def plan(
    task: TaskArgument,
    output: Annotated[
        Path | None,
        typer.Option("-o", "--output", help="Trajectory file (default out/TASK.json; several steps: NAME.STEP.json)."),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the outcome as JSON.")] = False,
    html: Annotated[
        Path | None,
        typer.Option("--html", help="Also write the 3D viewer of the whole task (one page, a step selector)."),
    ] = None,
    plots: Annotated[Path | None, typer.Option("--plots", help="Also write figures into this directory.")] = None,
    seed: Annotated[
        int | None, typer.Option("--seed", help="Planner seed (overrides the task's planning.seed).")
    ] = None,
    project_start: Annotated[
        bool,
        typer.Option(
            "--project-start", help="Move a start that violates a constraint onto it first (as planning.project_start)."
        ),
    ] = False,
    quiet: Quiet = False,
    verbose: Verbose = False,
    reasoner: ReasonerOption = "fast",
) -> None:
    """Run the pipeline: derive each step's constraints, plan, validate, time, write trajectories."""
    with collector_paused_while_importing():
        from hriplan.cli.summary import summarize
        from hriplan.tasks.model import step_name

    loaded = load_checked_task(task, seed, project_start or None)
    output = file_output(output or Path("out") / f"{loaded.name}.json")
    several = len(loaded.steps) > 1
    paths = {
        step_name(s, k): file_output(_step_path(output, step_name(s, k), several)) for k, s in enumerate(loaded.steps)
    }
    if html is not None:
        file_output(html, "--html")
    if plots is not None:
        directory_output(plots, "--plots")
    with progress(quiet) as report:
        runner = _runner(task, report, loaded)
        outcome = runner.run(plan=True)
        written = _write_outcome(outcome, output, paths, html, plots, report)
    if as_json:
        typer.echo(json.dumps(_json(outcome, written), indent=1))
    else:
        typer.echo(summarize(outcome, verbose))
        typer.echo("\n".join(f"wrote {p}" for p in written))
    if not outcome.solved:
        failed = next(s for s in outcome.steps if s.status != Status.SOLVED)
        typer.echo(f"planning failed at step {failed.name} ({failed.status}): {failed.message}", err=True)
        raise typer.Exit(1)


def _write_outcome(
    outcome, output: Path, paths: dict[str, Path], html: Path | None, plots: Path | None, report: Callable[[str], None]
) -> list[Path]:
    """Write the solved steps' trajectories, and the viewer page and figures if asked for. A step
    the pipeline adds (a preparatory motion, a lift after a pick) is written beside its task step's file."""
    written = []
    solved = [step for step in outcome.steps if step.trajectory is not None]
    several = len(outcome.steps) > 1
    for step in solved:
        path = paths.get(step.name) or file_output(_step_path(output, step.name, True))
        path.parent.mkdir(parents=True, exist_ok=True)
        step.trajectory.save(path)
        written.append(path)
    if html is not None and solved:
        from hriplan.viewer import write_task_viewer

        report("writing the 3D viewer")
        written.append(write_task_viewer([step.trajectory for step in solved], html))
    if plots is not None:
        from hriplan.viewer import write_plots

        for step in solved:
            report(f"{step.name}: drawing figures")
            written += write_plots(step.trajectory, plots / step.name if several else plots)
    return written


def _json(outcome, written: list[Path]) -> dict:
    steps = []
    for s in outcome.steps:
        entry = s.model_dump(mode="json", include={"name", "kind", "arms", "status", "message", "derivation"})
        entry["report"] = s.trajectory.report.model_dump(mode="json") if s.trajectory else None
        steps.append(entry)
    return {"task": outcome.task, "solved": outcome.solved, "steps": steps, "files": [str(p) for p in written]}


def constraints(
    task: TaskArgument,
    as_json: Annotated[bool, typer.Option("--json", help="Print the derivation as JSON.")] = False,
    quiet: Quiet = False,
    reasoner: ReasonerOption = "fast",
) -> None:
    """What each step would have to respect, with one-line reasons (no planning)."""
    with collector_paused_while_importing():
        from hriplan.cli.summary import constraint_lines

    with progress(quiet) as report:
        outcome = _runner(task, report).run(plan=False)
    if as_json:
        typer.echo(json.dumps(_json(outcome, []), indent=1))
        return
    for step in outcome.steps:
        typer.echo(f"step {step.name} ({step.kind}, {'/'.join(step.arms)} arm):")
        typer.echo("\n".join(constraint_lines(step.derivation)) or "  no constraints")


def explain(
    task: Annotated[
        Path,
        typer.Argument(
            help="A task file (YAML or JSON), or a trajectory file: why its constraints were there.", show_default=False
        ),
    ],
    quiet: Quiet = False,
    reasoner: ReasonerOption = "fast",
) -> None:
    """The full reasoning chain in words: for every constraint, the rules and the facts."""
    from hriplan.planner.trajectory import is_trajectory_file, load_trajectory
    from hriplan.rules.explain import explain as explain_derivation

    if is_trajectory_file(task):  # the reasons kept with a planned motion, not derived again
        typer.echo(explain_derivation(load_trajectory(task)))
        return
    with progress(quiet) as report:
        outcome = _runner(task, report).run(plan=False)
    for step in outcome.steps:
        typer.echo(f"== step {step.name}: {step.kind}, {'/'.join(step.arms)} arm ==")
        typer.echo(explain_derivation(step.derivation))
        typer.echo("")


def query(
    sparql: Annotated[
        str | None, typer.Argument(help="A SPARQL 1.1 query (prefixes hp:, rdf:, rdfs:, owl:, xsd: are predefined).")
    ] = None,
    file: Annotated[Path | None, typer.Option("--file", help="Read the query from a .rq file.")] = None,
    task: Annotated[
        Path | None, typer.Option("--task", help="Query this task's knowledge base (else the ontology alone).")
    ] = None,
    step: Annotated[
        str | None, typer.Option("--step", help="Only this step's situation (default: every step, a `step` column).")
    ] = None,
    output_format: Annotated[
        Literal["table", "json", "csv", "turtle"], typer.Option("--format", help="turtle: CONSTRUCT results.")
    ] = "table",
    quiet: Quiet = False,
) -> None:
    """Query the knowledge base (asserted + inferred facts) with SPARQL."""
    from hriplan.files import read_text
    from hriplan.tasks.knowledge import knowledge_base_for, ontology_graph_query, query_every_step

    if (sparql is None) == (file is None):
        raise HriplanError("give a query or --file, not both" if sparql else "give a query, or --file with a .rq file")
    text = sparql if sparql is not None else read_text(file, "SPARQL query file")
    if task is None:
        result = ontology_graph_query(text)
    else:
        with progress(quiet) as report:
            runner = _runner(task, report)
            result = query_every_step(runner, text) if step is None else knowledge_base_for(runner, step).query(text)
    typer.echo(result.render(output_format))


def import_kautham(
    problem: Annotated[Path, typer.Argument(help="A Kautham problem file (XML).", show_default=False)],
    output: Annotated[
        Path | None, typer.Option("-o", "--output", help="Write the hriplan problem here (JSON).")
    ] = None,
    plan_it: Annotated[bool, typer.Option("--plan", help="Also plan it (as `hriplan solve`).")] = False,
    rpy: Annotated[
        Literal["kautham", "urdf"], typer.Option(help="How to read <Origin rpy>: Kautham's Rx Ry Rz, or URDF.")
    ] = "kautham",
    models: Annotated[
        list[Path] | None,
        typer.Option(
            "--models",
            help="A folder with Kautham's robot, obstacle and controls files, like its demos/models (repeatable).",
        ),
    ] = None,
    robot: Annotated[
        str | None,
        typer.Option("--robot", help="Plan with this robot (a name or a robot file) instead of the one Kautham names."),
    ] = None,
) -> None:
    """Convert a Kautham problem (robot, obstacles, constraints, controls, query) to hriplan's problem format, and plan it."""
    from hriplan.cli.solve import solve_problem_file
    from hriplan.formats.kautham import import_kautham as convert

    target = file_output(output or Path("out") / f"{problem.stem}.problem.json")
    if plan_it:
        file_output(target.with_suffix(".trajectory.json"))
    from hriplan.files import write_atomically

    converted = convert(
        problem, rpy, models or (), warn=lambda message: typer.echo(f"warning: {message}", err=True), robot=robot
    )
    write_atomically(target, converted.model_dump_json(indent=1))
    typer.echo(
        f"{len(converted.constraints.constraints)} constraints, group {converted.group}, "
        f"{len(converted.scene.obstacles)} obstacles: wrote {target}"
    )
    if plan_it:
        raise typer.Exit(solve_problem_file(target, target.with_suffix(".trajectory.json"), None, False))


def schema() -> None:
    """Print the task file's JSON Schema."""
    from hriplan.tasks.model import TaskFile

    typer.echo(json.dumps(TaskFile.model_json_schema(), indent=1))


TASK_COMMANDS = {
    "plan": plan,
    "constraints": constraints,
    "explain": explain,
    "query": query,
    "import-kautham": import_kautham,
    "schema": schema,
}
