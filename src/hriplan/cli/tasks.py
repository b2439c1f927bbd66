"""Task commands: plan, constraints, explain, query, validate, import-kautham, schema.

Exit codes: 0 success, 1 planning (or validation) failed with the reason, 2 bad input.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Literal

import typer

from hriplan import HriplanError
from hriplan.ontology.reasoners import Reasoner, use_reasoner

TaskArgument = Annotated[Path, typer.Argument(help="A task file (YAML or JSON).")]
Quiet = Annotated[bool, typer.Option("--quiet", "-q", help="No progress messages.")]
Verbose = Annotated[bool, typer.Option("--verbose", "-v", help="More detail: rules and facts, constraint calls.")]
ReasonerOption = Annotated[Reasoner, typer.Option(callback=use_reasoner, help="fast: the rules in process; pellet: the reference.")]


def _progress(quiet: bool):  # noqa: ANN202
    return (lambda message: None) if quiet else (lambda message: typer.echo(f"... {message}", err=True))


def _runner(task_path: Path, quiet: bool):  # noqa: ANN202
    from hriplan.tasks.load import load_task
    from hriplan.tasks.pipeline import TaskRunner

    return TaskRunner(load_task(task_path), task_path.parent, _progress(quiet))


def load_for_task(trajectory: Path, task: Path | None, quiet: bool):  # noqa: ANN201
    """A trajectory file, with its step's constraints and scene taken from `task` if given."""
    from hriplan.planner.trajectory import load_trajectory
    from hriplan.tasks.pipeline import against_task

    plan_file = load_trajectory(trajectory)
    return plan_file if task is None else against_task(plan_file, _runner(task, quiet))


TaskOption = Annotated[Path | None, typer.Option("--task", help="Take the constraints, reasons and scene from this task file.")]


def _step_path(output: Path, step: str, several: bool) -> Path:
    return output.with_name(f"{output.stem}.{step}{output.suffix}") if several else output


def plan(
    task: TaskArgument,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Trajectory file (one per step: NAME.STEP.json).")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the outcome as JSON.")] = False,
    html: Annotated[Path | None, typer.Option("--html", help="Also write the 3D viewer (one per step).")] = None,
    plots: Annotated[Path | None, typer.Option("--plots", help="Also write figures into this directory.")] = None,
    quiet: Quiet = False,
    verbose: Verbose = False,
    reasoner: ReasonerOption = "fast",
) -> None:
    """Run the pipeline: derive each step's constraints, plan, validate, time, write trajectories."""
    from hriplan.tasks.summary import summarize

    runner = _runner(task, quiet)
    outcome = runner.run(plan=True)
    output = output or Path("out") / f"{runner.task.name}.json"
    several = len(runner.task.steps) > 1
    written = []
    for step in outcome.steps:
        if step.trajectory is None:
            continue
        path = _step_path(output, step.name, several)
        path.parent.mkdir(parents=True, exist_ok=True)
        step.trajectory.save(path)
        written.append(path)
        if html is not None:
            from hriplan.viewer import write_viewer

            written.append(write_viewer(step.trajectory, _step_path(html, step.name, several)))
        if plots is not None:
            from hriplan.viewer import write_plots

            written += write_plots(step.trajectory, plots / step.name if several else plots)
    if as_json:
        typer.echo(json.dumps(_json(outcome, written), indent=1))
    else:
        typer.echo(summarize(outcome, verbose))
        typer.echo("\n".join(f"wrote {p}" for p in written))
    if not outcome.solved:
        failed = next(s for s in outcome.steps if s.status != "solved")
        typer.echo(f"planning failed at step {failed.name} ({failed.status}): {failed.message}", err=True)
        raise typer.Exit(1)


def _json(outcome, written: list[Path]) -> dict:  # noqa: ANN001
    steps = []
    for s in outcome.steps:
        entry = s.model_dump(mode="json", include={"name", "kind", "arms", "status", "message", "derivation"})
        entry["report"] = s.trajectory.report.model_dump(mode="json") if s.trajectory else None
        steps.append(entry)
    return {"task": outcome.task, "solved": outcome.solved, "steps": steps, "files": [str(p) for p in written]}


def constraints(task: TaskArgument, as_json: Annotated[bool, typer.Option("--json")] = False, quiet: Quiet = False,
                reasoner: ReasonerOption = "fast") -> None:  # fmt: skip
    """What each step would have to respect, with one-line reasons (no planning)."""
    from hriplan.tasks.summary import constraint_lines

    outcome = _runner(task, quiet).run(plan=False)
    if as_json:
        typer.echo(json.dumps(_json(outcome, []), indent=1))
        return
    for step in outcome.steps:
        typer.echo(f"step {step.name} ({step.kind}, {'/'.join(step.arms)} arm):")
        typer.echo("\n".join(constraint_lines(step.derivation)) or "  no constraints")


def explain(task: TaskArgument, quiet: Quiet = False, reasoner: ReasonerOption = "fast") -> None:
    """The full reasoning chain in words: for every constraint, the rules and the facts."""
    from hriplan.rules.explain import explain as explain_derivation

    outcome = _runner(task, quiet).run(plan=False)
    for step in outcome.steps:
        typer.echo(f"== step {step.name}: {step.kind}, {'/'.join(step.arms)} arm ==")
        typer.echo(explain_derivation(step.derivation))
        typer.echo("")


def query(
    sparql: Annotated[str | None, typer.Argument(help="A SPARQL 1.1 query (prefixes hp:, rdf:, rdfs:, owl:, xsd: are predefined).")] = None,
    file: Annotated[Path | None, typer.Option("--file", help="Read the query from a .rq file.")] = None,
    task: Annotated[Path | None, typer.Option("--task", help="Query this task's knowledge base (else the ontology alone).")] = None,
    step: Annotated[str | None, typer.Option("--step", help="Which step's situation (default: the first).")] = None,
    output_format: Annotated[Literal["table", "json", "csv", "turtle"], typer.Option("--format", help="turtle: CONSTRUCT results.")] = "table",
    quiet: Quiet = False,
) -> None:
    """Query the knowledge base (asserted + inferred facts) with SPARQL."""
    from hriplan.tasks.knowledge import knowledge_base_for, ontology_graph_query

    if (sparql is None) == (file is None):
        raise HriplanError("give a query or --file, not both")
    text = sparql if sparql is not None else _read(file)
    result = knowledge_base_for(_runner(task, quiet), step).query(text) if task else ontology_graph_query(text)
    typer.echo(result.render(output_format))


def _read(path: Path) -> str:
    try:
        return path.read_text()
    except OSError:
        raise HriplanError(f"{path}: no such file") from None


def validate(
    trajectory: Annotated[Path, typer.Argument(help="A trajectory file.")],
    task: TaskOption = None,
    quiet: Quiet = False,
) -> None:
    """Re-check a trajectory densely against its constraints and collisions (exit 1 if it fails)."""
    from hriplan.planner.replay import PlannedWorld

    plan_file = load_for_task(trajectory, task, quiet)
    result = PlannedWorld.load(plan_file).validate()
    for check in result.constraints:
        typer.echo(f"{check.id:32s} worst margin {check.max_violation:+.4f} {'kept' if check.satisfied else 'VIOLATED'}")
    typer.echo(f"collision: {result.collision or 'none'}; checked {result.states_checked} states")
    if not result.valid:
        typer.echo(f"invalid: {result.message}", err=True)
        raise typer.Exit(1)


def import_kautham(
    problem: Annotated[Path, typer.Argument(help="A Kautham problem file (XML).")],
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Write the hriplan problem here (JSON).")] = None,
    plan_it: Annotated[bool, typer.Option("--plan", help="Also plan it (as `hriplan solve`).")] = False,
    rpy: Annotated[Literal["kautham", "urdf"], typer.Option(help="How to read <Origin rpy>: Kautham's Rx Ry Rz, or URDF.")] = "kautham",
    models: Annotated[list[Path] | None, typer.Option("--models", help="A folder with Kautham's robot, obstacle and controls files, like its demos/models (repeatable).")] = None,
) -> None:
    """Convert a Kautham problem (robot, obstacles, constraints, controls, query) to hriplan's problem format, and plan it."""
    from hriplan.cli.solve import solve_problem_file
    from hriplan.tasks.kautham import import_kautham as convert

    converted = convert(problem, rpy, models or (), warn=lambda message: typer.echo(f"warning: {message}", err=True))
    target = output or Path("out") / f"{problem.stem}.problem.json"
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(converted.model_dump_json(indent=1))
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
    "validate": validate,
    "import-kautham": import_kautham,
    "schema": schema,
}
