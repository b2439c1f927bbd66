"""`hriplan` command line: every command maps bad input to one line on stderr and exit code 2."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from hriplan import HriplanError, __version__
from hriplan.cli.errors import clear_errors
from hriplan.cli.sweeps import SWEEP_COMMANDS
from hriplan.cli.tasks import TASK_COMMANDS
from hriplan.cli.view import plot, view

app = typer.Typer(help="Safe human-robot collaboration planning.", no_args_is_help=True, add_completion=False)
robot_app = typer.Typer(help="Inspect the robot models.", no_args_is_help=True)
app.add_typer(robot_app, name="robot")

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


for _name, _command in {"view": view, "plot": plot, **TASK_COMMANDS, **SWEEP_COMMANDS}.items():
    app.command(_name)(clear_errors(_command))
