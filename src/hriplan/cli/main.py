"""`hriplan` command line: every command maps bad input to one line on stderr and exit code 2."""

from __future__ import annotations

import functools
import sys
from pathlib import Path
from collections.abc import Callable
from typing import Annotated, TypeVar

import typer

from hriplan import HriplanError, __version__

app = typer.Typer(help="Safe human-robot collaboration planning.", no_args_is_help=True, add_completion=False)
robot_app = typer.Typer(help="Inspect the robot models.", no_args_is_help=True)
app.add_typer(robot_app, name="robot")

F = TypeVar("F", bound=Callable)


def clear_errors(func: F) -> F:
    """Turn a user error into `error: ...` and exit code 2 instead of a traceback."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
        try:
            return func(*args, **kwargs)
        except HriplanError as exc:
            typer.echo(f"error: {exc}", err=True)
            raise typer.Exit(2) from None

    return wrapper  # type: ignore[return-value]


def _version(value: bool) -> None:
    if value:
        typer.echo(f"hriplan {__version__}")
        raise typer.Exit()


@app.callback()
def main(
    version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True, help="Print the version.")] = False,
) -> None:
    """Safe human-robot collaboration planning."""


def _postures(items: list[str]) -> dict[str, str]:
    postures = {}
    for item in items:
        side, sep, posture = item.partition("=")
        if not sep:
            raise HriplanError(f"--hand takes SIDE=POSTURE (e.g. right=power), got {item!r}")
        postures[side] = posture
    return postures


HandOption = Annotated[list[str], typer.Option("--hand", help="Hand posture, SIDE=open|power|pinch (repeatable).")]


@robot_app.command("info")
@clear_errors
def robot_info(name: str, hand: HandOption = []) -> None:  # noqa: B006 - typer needs a literal default
    """Joints, groups, limits, tool frames and collision parts of a robot."""
    from hriplan.robots.info import describe
    from hriplan.robots.model import load_robot

    typer.echo(describe(load_robot(name, _postures(hand))))


@robot_app.command("urdf")
@clear_errors
def robot_urdf(name: str) -> None:
    """Print the assembled robot as URDF (pinocchio loads it back)."""
    from hriplan.robots.descriptions import DESCRIPTIONS

    if name not in DESCRIPTIONS:
        raise HriplanError(f"unknown robot {name!r}; known robots: {', '.join(DESCRIPTIONS)}")
    sys.stdout.write(DESCRIPTIONS[name]() + "\n")


@app.command()
@clear_errors
def solve(
    problem: Annotated[Path, typer.Argument(help="A planning problem file (JSON).")],
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Write the trajectory here.")] = None,
    seed: Annotated[int | None, typer.Option(help="Seed (overrides the file's).")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the trajectory report as JSON.")] = False,
) -> None:
    """Plan a planning-problem file: constraints, start, goal -> validated trajectory."""
    from hriplan.cli.solve import solve_problem_file

    code = solve_problem_file(problem, output, seed, as_json)
    raise typer.Exit(code)


@app.command()
@clear_errors
def demo() -> None:
    """The main job: for now, MADAR beside a person reaching out, a reach pose, clearance."""
    from hriplan.cli.demo import run_demo

    typer.echo(run_demo())


from hriplan.cli.view import register as _register_view  # noqa: E402 - after `app` and `clear_errors`

_register_view(app)
