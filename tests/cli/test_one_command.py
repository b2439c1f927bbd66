"""The command line builds only the command its first argument names (cli/one_command.py), and
answers exactly as the root with every command built: help, parse errors, the command's work."""

import subprocess
import sys
from pathlib import Path

import pytest
from typer.main import get_command
from typer.testing import CliRunner

from hriplan.cli.main import app

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "handover_full_can.yaml"
NAMES = sorted(get_command(app).commands)


def _answer(typer_app, argv: list[str]) -> tuple[int, str, str]:
    result = CliRunner().invoke(typer_app, argv, prog_name="hriplan")
    return result.exit_code, result.stdout, result.stderr


def test_every_command_and_group_is_narrowed_to_itself_alone():
    assert {"plan", "validate", "constraints", "robot", "ontology", "import-kautham"} <= set(NAMES)
    for name in NAMES:
        assert list(get_command(app.narrowed_to([name])).commands) == [name]
    assert list(get_command(app.narrowed_to(["robot"])).commands["robot"].commands) == [
        "info",
        "urdf",
        "srdf",
        "check",
        "init",
    ]


@pytest.mark.parametrize("first", [[], ["--help"], ["--version"], ["plann"], ["Plan"], ["-q"]])
def test_anything_but_a_command_name_builds_them_all(first):
    assert app.narrowed_to(first) is app


@pytest.mark.parametrize("tail", [["--help"], ["--no-such-option"], ["info", "--help"]])
def test_narrowed_answers_as_the_whole_root(tail):
    """Every command and group: its help and a parse error (none of them runs a command)."""
    for name in NAMES:
        argv = [name, *tail]
        narrowed, whole = _answer(app.narrowed_to([name]), argv), _answer(app, argv)
        assert narrowed == whole, argv
        assert narrowed[1] or narrowed[2], argv


@pytest.mark.parametrize(
    "argv",
    [
        ["plan"],
        ["plan", "no/such/task.yaml", "-q"],
        ["constraints", "no/such/task.yaml"],
        ["validate", "no/such/trajectory.json"],
        ["robot"],
        ["robot", "info", "no-such-robot"],
        ["plan", str(EXAMPLE), "--seed", "x"],
    ],
)
def test_bad_input_gets_the_same_one_line(argv):
    narrowed, whole = _answer(app.narrowed_to(argv[:1]), argv), _answer(app, argv)
    assert narrowed == whole and narrowed[0] == 2 and narrowed[2].startswith(("error: ", "Usage: ")), (argv, narrowed)


WHOLE_ROOT = (
    "import sys\n"
    "from typer.main import get_command\n"
    "from hriplan.cli.main import app\n"
    "get_command(app)(sys.argv[1:], prog_name='hriplan')\n"
)


def test_the_process_runs_the_narrowed_root(tmp_path):
    """`python -m hriplan.cli` goes through OneCommandTyper.__call__: its help and errors are those
    of the root with every command built, a mistyped command still gets the root's suggestion, and
    `constraints` works."""

    def process(*argv: str, whole: bool = False) -> tuple[int, str, str]:
        how = ["-c", WHOLE_ROOT] if whole else ["-m", "hriplan.cli"]
        out = subprocess.run([sys.executable, *how, *argv], capture_output=True, text=True, timeout=300, cwd=tmp_path)
        return out.returncode, out.stdout, out.stderr

    for argv in (["plan", "--help"], ["validate"], ["robot", "info", "--bad"], ["plann", str(EXAMPLE)]):
        assert process(*argv) == process(*argv, whole=True), argv
    code, _, err = process("plann", str(EXAMPLE))
    assert code == 2 and "No such command 'plann'" in err
    code, out, _ = process("constraints", str(EXAMPLE), "-q")
    assert code == 0 and "approach_cone_alice" in out


def test_a_call_builds_only_the_command_it_runs(monkeypatch, capsys):
    """What the process pays for: typer turns only `plan` into a click command (before: all 20)."""
    import typer.main

    built = []
    build = typer.main.get_command_from_info

    def counted(command_info, **kwargs):
        built.append(command_info.name or command_info.callback.__name__)
        return build(command_info, **kwargs)

    monkeypatch.setattr(typer.main, "get_command_from_info", counted)
    with pytest.raises(SystemExit) as done:
        app(["plan", "--help"], prog_name="hriplan")
    assert done.value.code == 0 and "Usage: hriplan plan" in capsys.readouterr().out
    assert built == ["plan"]
