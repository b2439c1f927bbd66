"""Sweep and batch commands: many variants of a task, or many task files, planned as `plan` does.

Workers reason with the default in-process rules (`fast`).
Exit codes: 0 the sweep ran (failed variants are results, in the table), 2 bad input,
130 interrupted (what finished is kept; rerunning resumes).
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
RayAddress = Annotated[str | None, typer.Option("--ray-address", help="Join this Ray cluster (implies --engine ray).")]
DeriveOnly = Annotated[bool, typer.Option("--derive-only", help="Derive the constraints only, do not plan.")]
Quiet = Annotated[bool, typer.Option("--quiet", "-q", help="No progress.")]


def _engine(engine: str, workers: int | None, address: str | None):
    from hriplan.sweeps.engines import LocalEngine, RayEngine

    if workers is not None and workers < 1:
        raise HriplanError("--workers must be at least 1")
    if engine == "ray" or address:
        try:
            import ray  # noqa: F401
        except ImportError:
            raise HriplanError("--engine ray needs Ray: pip install 'hriplan[ray]'") from None
        return RayEngine(workers, address)
    return LocalEngine(workers)


def _run(variants, output: Path, output_format: str, engine, derive_only: bool, quiet: bool) -> None:
    import signal

    from hriplan.sweeps.run import SweepInterrupted, run_sweep

    # A sweep stops cleanly itself on Ctrl-C (its workers stopped, what is done kept and compacted),
    # so here Ctrl-C is Python's KeyboardInterrupt, not the CLI's immediate exit.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        summary = run_sweep(
            variants, output, engine, plan=not derive_only, csv=output_format == "csv", progress=not quiet
        )
    except SweepInterrupted as exc:
        typer.echo(str(exc), err=True)
        raise typer.Exit(130) from None
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
    derive_only: DeriveOnly = False,
    report: Annotated[
        Path | None, typer.Option("--report", help="Draw the maps of a finished sweep's directory (no planning).")
    ] = None,
    quiet: Quiet = False,
) -> None:
    """Plan every variant of a task (the cross product of --vary, or --samples draws) into a table."""
    from hriplan.sweeps.variants import expand, parse_vary

    if report is not None:
        from hriplan.sweeps.report import write_report

        typer.echo(f"wrote {write_report(report)}")
        return
    if task is None or output is None:
        raise HriplanError("sweep needs a TASK file and -o DIR (or --report DIR)")
    if not vary:
        raise HriplanError("sweep needs at least one --vary PATH=VALUES")
    variants = expand(task, [parse_vary(v) for v in vary], samples, seed)
    _run(variants, output, output_format, _engine(engine, workers, ray_address), derive_only, quiet)


def batch(
    files: Annotated[list[Path], typer.Argument(help="Task files.")],
    output: Output = None,
    output_format: Format = "parquet",
    engine: EngineName = "local",
    workers: Workers = None,
    ray_address: RayAddress = None,
    derive_only: DeriveOnly = False,
    quiet: Quiet = False,
) -> None:
    """Plan many task files the same way as a sweep (one variant per file)."""
    from hriplan.sweeps.variants import batch as batch_variants

    if output is None:
        raise HriplanError("batch needs -o DIR")
    _run(batch_variants(files), output, output_format, _engine(engine, workers, ray_address), derive_only, quiet)


SWEEP_COMMANDS = {"sweep": sweep, "batch": batch}
