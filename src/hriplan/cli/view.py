"""`hriplan view` and `hriplan plot`: look at a trajectory file (3D viewer, figures)."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path
from typing import Annotated

import typer

from hriplan import HriplanError
from hriplan.cli.tasks import TaskOption, load_for_task

TrajectoryArgument = Annotated[Path, typer.Argument(help="A trajectory file written by `hriplan solve -o`.")]


def view(
    trajectory: TrajectoryArgument,
    output: Annotated[Path, typer.Option("-o", "--output", help="The HTML file to write.")],
    task: TaskOption = None,
) -> None:
    """Write an offline 3D viewer of a plan: robot, people, scene, constraints, path, animation."""
    from hriplan.viewer import write_viewer

    plan = load_for_task(trajectory, task, quiet=True)
    with _writing(output):
        path = write_viewer(plan, output)
    typer.echo(f"viewer written to {path} ({path.stat().st_size / 1e6:.1f} MB); open it in a browser")


def plot(
    trajectory: TrajectoryArgument,
    output: Annotated[Path, typer.Option("-o", "--output", help="The directory for the figures.")],
    task: TaskOption = None,
) -> None:
    """Write figures of a plan: constraint margins, joint positions and velocities, distance to people."""
    from hriplan.viewer import write_plots

    plan = load_for_task(trajectory, task, quiet=True)
    with _writing(output):
        paths = write_plots(plan, output)
    typer.echo("\n".join(f"figure written to {p}" for p in paths))


@contextlib.contextmanager
def _writing(output: Path) -> Iterator[None]:
    """An output that cannot be written is a user error (one line), not a traceback."""
    try:
        yield
    except OSError as exc:
        raise HriplanError(f"cannot write {output}: {exc.strerror or exc}") from None
