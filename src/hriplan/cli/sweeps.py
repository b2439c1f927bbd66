"""Sweep and batch commands: many variants of a task, or many task files, planned as `plan` does.

Workers reason with the default in-process rules (`fast`).
Exit codes: 0 the sweep ran (failed variants are results, in the table), 2 bad input (a Ray
cluster that cannot be joined included), 130 interrupted by Ctrl-C, 143 by SIGTERM (what finished
is kept, the workers are stopped; rerunning resumes).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

import typer

from hriplan import HriplanError

Output = Annotated[
    Path | None, typer.Option("-o", "--output", help="Results directory (results.parquet; rerun to resume).")
]
Format = Annotated[Literal["parquet", "csv"], typer.Option("--format", help="csv: also write results.csv.")]
EngineName = Annotated[
    Literal["local", "ray"], typer.Option("--engine", help="local: worker processes; ray: Ray actors.")
]
Workers = Annotated[int | None, typer.Option("--workers", help="Worker processes / actors (default: one per core).")]
RayAddress = Annotated[
    str | None,
    typer.Option(
        "--ray-address", help="Join this Ray cluster, HOST:PORT (implies --engine ray; RAY_ADDRESS is not used)."
    ),
]
RuntimeEnv = Annotated[
    str | None,
    typer.Option("--ray-runtime-env", help="A Ray runtime_env for the cluster's workers: JSON, or a JSON/YAML file."),
]
DeriveOnly = Annotated[bool, typer.Option("--derive-only", help="Derive the constraints only, do not plan.")]
Merge = Annotated[bool, typer.Option("--merge", help="Add to a folder holding another task's or mode's results.")]
RetryFailed = Annotated[bool, typer.Option("--retry-failed", help="Run again the variants whose last run failed.")]
SaveTrajectories = Annotated[
    bool, typer.Option("--save-trajectories", help="Keep each variant's trajectories (DIR/trajectories/KEY/STEP.json).")
]
Quiet = Annotated[bool, typer.Option("--quiet", "-q", help="No progress.")]


def _runtime_env(text: str | None) -> dict | None:
    """--ray-runtime-env: inline JSON or a file holding it (one line if it is not a mapping)."""
    from hriplan.files import parse_data, read_data

    if text is None:
        return None
    try:
        data = parse_data(text, "json") if text.lstrip()[:1] in "{[" else read_data(Path(text))
    except HriplanError as exc:
        raise HriplanError(f"--ray-runtime-env: {exc}") from None
    if not isinstance(data, dict):
        raise HriplanError(
            f"--ray-runtime-env: a runtime_env is a mapping (pip, py_modules, env_vars, ...), got {text!r}"
        )
    return data


def _engine(engine: str, workers: int | None, address: str | None, runtime_env: str | None = None):
    from hriplan.sweeps.engines import LocalEngine, RayEngine

    if workers is not None and workers < 1:
        raise HriplanError("--workers must be at least 1")
    if engine == "ray" or address:
        try:
            import ray  # noqa: F401
        except ImportError:
            raise HriplanError("--engine ray needs Ray: pip install 'hriplan[ray]'") from None
        return RayEngine(workers, address, _runtime_env(runtime_env))
    if runtime_env is not None:
        raise HriplanError("--ray-runtime-env is for --engine ray")
    return LocalEngine(workers)


class _Terminated(KeyboardInterrupt):
    """SIGTERM (a scheduler, `timeout`, `docker stop`): stopped like Ctrl-C, exit 143."""


def _terminate(signum: int, frame: object) -> None:
    raise _Terminated


def _run(variants, output: Path, output_format: str, engine, derive_only: bool, quiet: bool, **options) -> None:
    import signal

    from hriplan.sweeps.run import SweepInterrupted, run_sweep

    # A sweep stops cleanly itself on Ctrl-C and SIGTERM (its workers stopped, what is done kept and
    # compacted), so here both are Python exceptions, not the CLI's immediate exit.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    previous = signal.signal(signal.SIGTERM, _terminate)
    terminated = False
    try:
        summary = run_sweep(
            variants, output, engine, plan=not derive_only, csv=output_format == "csv", progress=not quiet, **options
        )
    except SweepInterrupted as exc:
        terminated = isinstance(exc.__context__, _Terminated)
        typer.echo(str(exc), err=True)
        raise typer.Exit(128 + signal.SIGTERM if terminated else 130) from None
    finally:
        signal.signal(signal.SIGTERM, previous)
    typer.echo(summary.text())


def sweep(
    task: Annotated[Path | None, typer.Argument(help="The task file to vary.")] = None,
    vary: Annotated[
        list[str],
        typer.Option("--vary", help="PATH=VALUES: a,b,c | JSON list | LOW:HIGH:STEP | [RANGE, RANGE] (repeatable)."),
    ] = [],  # noqa: B006
    output: Output = None,
    samples: Annotated[int | None, typer.Option("--samples", help="Random draws instead of the cross product.")] = None,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the random draws.")] = 0,
    output_format: Format = "parquet",
    engine: EngineName = "local",
    workers: Workers = None,
    ray_address: RayAddress = None,
    ray_runtime_env: RuntimeEnv = None,
    derive_only: DeriveOnly = False,
    merge: Merge = False,
    retry_failed: RetryFailed = False,
    save_trajectories: SaveTrajectories = False,
    report: Annotated[
        Path | None, typer.Option("--report", help="Draw the maps of a finished sweep's directory (no planning).")
    ] = None,
    quiet: Quiet = False,
) -> None:
    """Plan every variant of a task (the cross product of --vary, or --samples draws) into a table."""
    from hriplan.sweeps.variants import expand, load_base, parse_vary, task_key

    if report is not None:
        from hriplan.sweeps.report import write_report

        typer.echo(f"wrote {write_report(report)}")
        return
    if task is None or output is None:
        raise HriplanError("sweep needs a TASK file and -o DIR (or --report DIR)")
    if not vary:
        raise HriplanError("sweep needs at least one --vary PATH=VALUES")
    variants = expand(task, [parse_vary(v) for v in vary], samples, seed)
    spec = {"command": "sweep", "task": f"{task.name} {task_key(load_base(task)[1])}", "file": str(task)}
    _run(
        variants,
        output,
        output_format,
        _engine(engine, workers, ray_address, ray_runtime_env),
        derive_only,
        quiet,
        spec=spec | {"vary": vary, "samples": samples, "seed": seed},
        merge=merge,
        retry_failed=retry_failed,
        save_trajectories=save_trajectories,
    )


def batch(
    files: Annotated[list[Path], typer.Argument(help="Task files.")],
    output: Output = None,
    output_format: Format = "parquet",
    engine: EngineName = "local",
    workers: Workers = None,
    ray_address: RayAddress = None,
    ray_runtime_env: RuntimeEnv = None,
    derive_only: DeriveOnly = False,
    merge: Merge = False,
    retry_failed: RetryFailed = False,
    save_trajectories: SaveTrajectories = False,
    quiet: Quiet = False,
) -> None:
    """Plan many task files the same way as a sweep (one variant per file)."""
    from hriplan.sweeps.variants import batch as batch_variants

    if output is None:
        raise HriplanError("batch needs -o DIR")
    _run(
        batch_variants(files),
        output,
        output_format,
        _engine(engine, workers, ray_address, ray_runtime_env),
        derive_only,
        quiet,
        spec={"command": "batch", "task": "a batch of task files", "files": [str(f) for f in files]},
        merge=merge,
        retry_failed=retry_failed,
        save_trajectories=save_trajectories,
    )


SWEEP_COMMANDS = {"sweep": sweep, "batch": batch}
