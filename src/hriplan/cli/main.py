"""`hriplan` command line: every command maps bad input to one line on stderr and exit code 2."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from hriplan import HriplanError, __version__
from hriplan.blas_threads import single_threaded_blas
from hriplan.cli.errors import OneLineErrors, clear_errors
from hriplan.cli.export import export
from hriplan.cli.one_command import OneCommandTyper
from hriplan.cli.ontology import ontology_app
from hriplan.cli.serve import serve
from hriplan.cli.sweeps import SWEEP_COMMANDS
from hriplan.cli.tasks import TASK_COMMANDS
from hriplan.cli.validate import validate
from hriplan.cli.view import plot, view

single_threaded_blas()  # before any command imports numpy
app = OneCommandTyper(
    cls=OneLineErrors, no_args_is_help=True, add_completion=False, rich_markup_mode=None, pretty_exceptions_enable=False
)
robot_app = typer.Typer(
    help="Inspect the robot models; write and check robot files.", no_args_is_help=True, rich_markup_mode=None
)
app.add_typer(robot_app, name="robot")
app.add_typer(ontology_app, name="ontology")


def _version(value: bool) -> None:
    if value:
        typer.echo(f"hriplan {__version__}")
        raise typer.Exit()


@app.callback()
def main(
    version: Annotated[
        bool, typer.Option("--version", callback=_version, is_eager=True, help="Print the version.")
    ] = False,
) -> None:
    """Safe human-robot collaboration planning: constraints derived from an ontology and rules,
    planned on a constrained OMPL planner, validated and timed.

    \b
    Examples:
      hriplan constraints examples/handover_full_can.yaml      what each step must respect, and why
      hriplan explain examples/handover_full_can.yaml          the rules and facts behind each one
      hriplan plan examples/handover_full_can.yaml -o out/can.json --html out/can.html --plots out/plots
      hriplan validate out/can.take_can.json                   re-check a trajectory densely
      hriplan validate msg.yaml --task TASK --step NAME        a ROS JointTrajectory, checked in a task step
      hriplan export out/can.take_can.json out/can.place_can.json -o out/can_bag   steps in order, as a ROS 2 bag
      hriplan query --task examples/handover_full_can.yaml "SELECT ?c WHERE { ?h hp:isConstrainedBy ?c }"
      hriplan import-kautham problem.xml --plan                a Kautham problem, converted and planned
      hriplan robot info madar                                 joints, groups, limits, tool frames
      hriplan robot init --urdf panda.urdf --srdf panda.srdf -o panda.yaml   a robot file for any robot
      hriplan robot check panda.yaml                           what it holds, its IK measured
      hriplan robot srdf madar -o madar.srdf                   its SRDF, for MoveIt
      hriplan ontology export --format rdfxml -o hriplan.owl   the ontology for OWL tools (ttl, rdfxml, owx)

    \b
    Exit codes:
      0    success
      1    planning or validation failed (one line on stderr says why)
      2    bad input: a file, a field or an option (one line on stderr names it)
      130  interrupted (Ctrl-C); nothing is left half written
    """


def _postures(items: list[str]) -> dict[str, str]:
    postures = {}
    for item in items:
        side, sep, posture = item.partition("=")
        if not sep:
            raise HriplanError(f"--hand takes SIDE=POSTURE (e.g. right=power), got {item!r}")
        postures[side] = posture
    return postures


HandOption = Annotated[
    list[str], typer.Option("--hand", help="Hand posture, SIDE=open|power|pinch|release (repeatable).")
]


RobotName = Annotated[
    str | None, typer.Argument(help="madar, ur5 or a robot file (none: list the robots).", show_default=False)
]


@robot_app.command("info")
@clear_errors
def robot_info(name: RobotName = None, hand: HandOption = []) -> None:  # noqa: B006 - typer needs a literal default
    """Joints, groups, limits, tool frames and collision parts of a robot (no name: the robots)."""
    from hriplan.robots.descriptions.registry import DESCRIPTIONS

    if name is None:
        typer.echo("robots: " + ", ".join(DESCRIPTIONS) + " (hriplan robot info NAME for one)")
        return
    from hriplan.robots.descriptions.registry import robot_name
    from hriplan.robots.info import describe
    from hriplan.robots.model import load_robot

    typer.echo(describe(load_robot(robot_name(name), _postures(hand))))


@robot_app.command("urdf")
@clear_errors
def robot_urdf(
    name: Annotated[str, typer.Argument(help="madar, ur5 or a robot file.", show_default=False)],
    mesh_dir: Annotated[
        Path | None,
        typer.Option("--mesh-dir", help="Write mesh paths into this copy of example-robot-data's robots/ folder."),
    ] = None,
) -> None:
    """Print the assembled robot as URDF, meshes as package://example-robot-data/robots/... URIs.

    The package root (for ROS_PACKAGE_PATH, or pinocchio's package_dirs) is the folder that holds
    example-robot-data/: `python -c "from hriplan.cli.urdf_export import package_root; print(package_root())"`.
    """
    from hriplan.cli.urdf_export import portable_urdf
    from hriplan.robots.descriptions.registry import description_of, robot_name

    sys.stdout.write(portable_urdf(description_of(robot_name(name)).urdf(), mesh_dir) + "\n")


@robot_app.command("srdf")
@clear_errors
def robot_srdf(
    name: Annotated[str, typer.Argument(help="madar, ur5 or a robot file.", show_default=False)],
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Write the SRDF here.")] = None,
) -> None:
    """Print (or write) the robot's SRDF for MoveIt: a group per arm and the whole robot, an end
    effector per arm, a group state per posture, and the pairs hriplan does not check for self-collision."""
    from hriplan.cli.outputs import file_output
    from hriplan.files import write_atomically
    from hriplan.robots.descriptions.registry import robot_name
    from hriplan.robots.model import load_robot
    from hriplan.robots.srdf_export import srdf_text

    target = None if output is None else file_output(output)
    text = srdf_text(load_robot(robot_name(name)))
    if target is None:
        sys.stdout.write(text)
    else:
        write_atomically(target, text)
        typer.echo(f"wrote {target}")


@robot_app.command("check")
@clear_errors
def robot_check(robot_file: Annotated[Path, typer.Argument(help="A robot file (YAML).", show_default=False)]) -> None:
    """Load a robot file and print its SRDF groups, arms, joints, tool frames, IK kind with a
    measured success rate on random reachable poses, postures and collision matrix; or one line
    naming the problem (exit 2)."""
    from hriplan.robots.robot_check import check_report

    typer.echo(check_report(robot_file))


@robot_app.command("init")
@clear_errors
def robot_init(
    urdf: Annotated[str, typer.Option("--urdf", help="The robot's URDF (a path or package://).", show_default=False)],
    output: Annotated[Path, typer.Option("-o", "--output", help="Write the robot file here.", show_default=False)],
    srdf: Annotated[str | None, typer.Option("--srdf", help="Its SRDF (arms from its end effectors).")] = None,
) -> None:
    """Write a starting robot file: an arm per SRDF end effector, or the longest chain of the URDF
    by its base and tip links; a gripper from the joints below the tool; an analytic UR solver
    where one fits, else numeric IK."""
    from hriplan.robots.robot_check import write_starting_file

    typer.echo(write_starting_file(urdf, srdf, output))


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


for _name, _command in {
    "view": view,
    "plot": plot,
    "serve": serve,
    "export": export,
    **TASK_COMMANDS,
    "validate": validate,
    **SWEEP_COMMANDS,
}.items():
    app.command(_name)(clear_errors(_command))
