"""`hriplan view` and `hriplan plot`: look at a trajectory file (3D viewer, figures)."""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Annotated, Any

import typer

from hriplan import HriplanError
from hriplan.cli.outputs import directory_output, file_output
from hriplan.cli.progress import progress
from hriplan.cli.tasks import Quiet, TaskOption, load_for_task

TrajectoryArgument = Annotated[
    Path, typer.Argument(help="A trajectory file written by `hriplan plan` or `solve -o`.", show_default=False)
]

HtmlOutput = Annotated[Path, typer.Option("-o", "--output", help="The HTML file to write.", show_default=False)]
FiguresOutput = Annotated[
    Path, typer.Option("-o", "--output", help="The directory for the figures.", show_default=False)
]


def view(trajectory: TrajectoryArgument, output: HtmlOutput, task: TaskOption = None, quiet: Quiet = False) -> None:
    """Write an offline 3D viewer of a plan: robot, people, scene, constraints, path, animation."""
    from hriplan.viewer import write_viewer

    file_output(output)
    path = _drawn(trajectory, task, quiet, output, "drawing the robot, the people and the constraints", write_viewer)
    typer.echo(f"viewer written to {path} ({path.stat().st_size / 1e6:.1f} MB); open it in a browser")


def plot(trajectory: TrajectoryArgument, output: FiguresOutput, task: TaskOption = None, quiet: Quiet = False) -> None:
    """Write figures of a plan: constraint margins, joint positions, velocities, accelerations, distance to people."""
    from hriplan.viewer import write_plots

    directory_output(output)
    paths = _drawn(trajectory, task, quiet, output, "replaying the motion and drawing the figures", write_plots)
    typer.echo("\n".join(f"figure written to {p}" for p in paths))


@contextlib.contextmanager
def _writing(output: Path) -> Iterator[None]:
    """An output that cannot be written is a user error (one line), not a traceback."""
    try:
        yield
    except OSError as exc:
        raise HriplanError(f"cannot write {output}: {exc.strerror or exc}") from None


def _drawn(trajectory: Path, task: Path | None, quiet: bool, output: Path, stage: str, draw: Callable) -> Any:
    """Load the plan (with its task, if given), then draw it into `output` under a progress line."""
    plan = load_for_task(trajectory, task, quiet)
    with _writing(output), progress(quiet) as report:
        report(stage)
        return draw(plan, output)
