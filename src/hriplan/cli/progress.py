"""Progress of long commands on stderr: a live line with the elapsed time on a terminal (rich),
plain `... stage` lines when stderr is a file or a pipe, nothing with --quiet."""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Callable, Iterator

import typer

Progress = Callable[[str], None]


def _silent(message: str) -> None:
    return None


def _plain(message: str) -> None:
    typer.echo(f"... {message}", err=True)


@contextlib.contextmanager
def progress(quiet: bool) -> Iterator[Progress]:
    """A progress callable for the pipeline's stages, live while the block runs."""
    if quiet:
        yield _silent
        return
    if not sys.stderr.isatty():
        yield _plain
        return
    from rich.console import Console
    from rich.progress import Progress as Live
    from rich.progress import SpinnerColumn, TextColumn, TimeElapsedColumn

    started = time.monotonic()
    with Live(
        SpinnerColumn(),
        TextColumn("{task.description}"),
        TimeElapsedColumn(),
        console=Console(stderr=True),
        transient=True,
    ) as live:
        stage = live.add_task("starting", total=None)

        def update(message: str) -> None:
            live.console.print(f"[dim]{time.monotonic() - started:6.1f} s[/dim] {message}", highlight=False)
            live.update(stage, description=message)

        yield update
