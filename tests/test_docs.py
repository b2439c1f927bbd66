"""Every command shown in README.md and docs/*.md runs, and the output shown is the output it gives.

A transcript in the documentation goes stale silently when the code changes; this test makes it
fail instead. Commands are written in ```console blocks: a line `$ COMMAND` is run with bash in a
scratch folder (a copy of `examples/`, links to the read-only inputs, outputs under `out/`), and
the lines after it up to the next `$ ` are its stdout as shown. Shown and real lines are compared
after timings are masked; a line `...` stands for any number of lines, and a line ending in `...`
for one line that starts with what comes before. A command shown without output is checked for
its exit status only; every command must exit 0.

`.venv/bin/hriplan` and `.venv/bin/python` are this interpreter, `make demo` is the Makefile's demo
recipe (run once, before the first command that reads its files), `.venv/bin/hriplan serve ARGS` starts a server on a free
port for the rest of its document and `localhost:8000` is mapped to it. ```python blocks run as
scripts. `make test` (README) is what runs this file; the commands in SKIPPED are not run.
"""

from __future__ import annotations

import contextlib
import os
import re
import shlex
import shutil
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
DOCUMENTS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
SHOWN_URL = "localhost:8000"
SHOWN_PYTHON_URL = "http://127.0.0.1:8000"
DEMO_OUTPUT = "out/handover_full_can."  # the files `make demo` writes

SKIPPED = {
    ".venv/bin/pip install -e '.[server]'": "installs packages: the test runs in the environment it would make",
    ".venv/bin/hriplan sweep examples/handover_full_can_receiver.yaml -o out/where --vary "
    "'humans.bob.position=[-0.5:0.5:0.1, 1.1:2.0:0.1]' --vary objects.can.fill_level=Full,Empty": (
        "220 variants take minutes; the two-variant sweep before it runs the same code"
    ),
    ".venv/bin/hriplan sweep --report out/where": "needs the 220-variant sweep above",
    ".venv/bin/hriplan batch examples/*.yaml -o out/all": "every example takes minutes; the demo and the sweeps plan tasks",
    ".venv/bin/hriplan sweep examples/handover_full_can_receiver.yaml -o out/cluster --vary planning.seed=1:64:1 "
    "--ray-address HEAD:6379": "needs a Ray cluster; tests/sweeps/test_sweeps_cluster.py joins a real one",
}

# Numbers that differ from run to run (planning and wall times); masked on both sides.
TIMINGS = [
    (re.compile(r"solved (in )?\d+(\.\d+)? s"), r"solved \1<t> s"),
    (re.compile(r"\(\d+(\.\d+)? s\)"), "(<t> s)"),
]


@dataclass
class Command:
    line: int
    text: str
    shown: list[str] = field(default_factory=list)


@dataclass
class Block:
    line: int
    language: str
    lines: list[str]


def blocks(path: Path) -> list[Block]:
    """The fenced blocks of a Markdown file, with the language after the opening fence."""
    found, current = [], None
    for number, raw in enumerate(path.read_text().splitlines(), 1):
        stripped = raw.strip()
        if stripped.startswith("```"):
            if current is None:
                current = Block(number, stripped[3:].strip(), [])
            else:
                found.append(current)
                current = None
        elif current is not None:
            current.lines.append(raw)
    assert current is None, f"{path.name}:{current.line}: a fenced block is not closed"
    return found


def commands(block: Block) -> list[Command]:
    """The `$ ` commands of a console block, each with the output lines shown after it."""
    found: list[Command] = []
    for offset, raw in enumerate(block.lines, 1):
        if raw.startswith("$ "):
            found.append(Command(block.line + offset, raw[2:].strip()))
        else:
            assert found, f"line {block.line + offset}: a console block starts with a `$ ` command"
            found[-1].shown.append(raw.rstrip())
    return found


def masked(line: str) -> str:
    for pattern, replacement in TIMINGS:
        line = pattern.sub(replacement, line)
    return line.rstrip()


def matches(shown: list[str], actual: list[str]) -> bool:
    """Whether the real lines fit the shown ones (`...` any lines; `text...` a line starting with text)."""

    @cache
    def fit(i: int, j: int) -> bool:
        if i == len(shown):
            return j == len(actual)
        pattern = masked(shown[i])
        if pattern == "...":
            return any(fit(i + 1, k) for k in range(j, len(actual) + 1))
        if j == len(actual):
            return False
        line = masked(actual[j])
        ok = line.startswith(pattern[:-3]) if pattern.endswith("...") else line == pattern
        return ok and fit(i + 1, j + 1)

    return fit(0, 0)


def demo_recipe() -> str:
    """The Makefile's `demo` command, as this interpreter runs it."""
    lines = (ROOT / "Makefile").read_text().splitlines()
    recipe = lines[lines.index(next(line for line in lines if line.startswith("demo:"))) + 1]
    assert recipe.startswith("\t$(BIN)/hriplan "), recipe
    return recipe.strip().replace("$(BIN)/hriplan", f"{shlex.quote(sys.executable)} -m hriplan.cli")


VENV_PROGRAM = re.compile(r"(?<![\w/])\.venv/bin/(hriplan|python)\b")


def shell_form(command: str, url: str | None) -> str:
    programs = {"hriplan": f"{shlex.quote(sys.executable)} -m hriplan.cli", "python": shlex.quote(sys.executable)}
    command = VENV_PROGRAM.sub(lambda m: programs[m.group(1)], command)
    if SHOWN_URL in command:
        assert url, f"{command!r} needs the server: start it with `.venv/bin/hriplan serve` in a console block first"
        command = command.replace(SHOWN_URL, url.removeprefix("http://"))
    return command


def environment() -> dict[str, str]:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]))
    env.pop("HRIPLAN_TOKEN", None)
    return env


def run(command: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        ["bash", "-c", command], cwd=cwd, env=environment(), capture_output=True, text=True, timeout=300
    )


def check(command: Command, result: subprocess.CompletedProcess[str], where: str) -> None:
    assert result.returncode == 0, f"{where}: `{command.text}` exited {result.returncode}:\n{result.stderr[-3000:]}"
    if command.shown:
        actual = result.stdout.rstrip().splitlines()  # a transcript shows no trailing blank lines
        assert matches(command.shown, actual), (
            f"{where}: `{command.text}` printed something else than shown.\nshown:\n"
            + "\n".join(command.shown)
            + "\nprinted:\n"
            + "\n".join(actual[:60])
        )


@pytest.fixture(scope="module")
def workdir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A scratch folder the commands run in: the examples copied, read-only inputs linked."""
    work = tmp_path_factory.mktemp("docs")
    shutil.copytree(ROOT / "examples", work / "examples")
    for inputs in ("tests/data", "benchmarks/scenarios", "src"):
        (work / inputs).parent.mkdir(parents=True, exist_ok=True)
        (work / inputs).symlink_to(ROOT / inputs)
    (work / "out").mkdir()
    return work


@pytest.fixture(scope="module")
def demo(workdir: Path) -> subprocess.CompletedProcess[str]:
    """`make demo`, run once: the README shows its output and other documents read its files."""
    return run(demo_recipe(), workdir)


@contextlib.contextmanager
def server_from(command: str) -> Iterator[str]:
    from hriplan.service.launch import running_server

    with running_server(*shlex.split(command)[2:]) as url:
        yield url


@pytest.mark.parametrize("document", DOCUMENTS, ids=lambda p: p.name)
def test_every_command_shown_runs_and_prints_what_is_shown(
    document: Path, workdir: Path, request: pytest.FixtureRequest
) -> None:
    shown = [c.text for b in blocks(document) if b.language == "console" for c in commands(b)]
    if any(text.startswith("curl ") for text in shown) and shutil.which("curl") is None:
        pytest.skip("curl is not installed: this document's requests are curl commands")
    with contextlib.ExitStack() as stack:
        url = None
        for block in blocks(document):
            where = f"{document.relative_to(ROOT)}:{block.line}"
            if block.language == "python":
                script = "\n".join(block.lines)
                if url:
                    script = script.replace(SHOWN_PYTHON_URL, url)
                (workdir / "block.py").write_text(script)
                result = run(f"{shlex.quote(sys.executable)} block.py", workdir)
                assert result.returncode == 0, f"{where}: the python block failed:\n{result.stderr[-3000:]}"
            if block.language != "console":
                continue
            for command in commands(block):
                where = f"{document.relative_to(ROOT)}:{command.line}"
                if command.text in SKIPPED:
                    continue
                if DEMO_OUTPUT in command.text:  # its files are needed: the demo runs first
                    request.getfixturevalue("demo")
                if command.text == "make demo":
                    check(command, request.getfixturevalue("demo"), where)
                elif command.text.startswith(".venv/bin/hriplan serve"):
                    assert not command.shown, f"{where}: a server's output is not checked"
                    url = stack.enter_context(server_from(command.text))
                else:
                    check(command, run(shell_form(command.text, url), workdir), where)


def test_every_skipped_command_is_still_shown() -> None:
    shown = {c.text for d in DOCUMENTS for b in blocks(d) if b.language == "console" for c in commands(b)}
    assert set(SKIPPED) <= shown, f"SKIPPED names commands no document shows: {set(SKIPPED) - shown}"


SHELL_LINE = re.compile(r"^\s*(\$ |\.venv/bin/|curl |hriplan |make |pip |python )")
MAKE_BLOCK = [
    "make demo    # sets everything up in .venv and runs the main job (the handover example)",
    "make test    # sets everything up with the test extra and runs the test suite",
]


@pytest.mark.parametrize("document", DOCUMENTS, ids=lambda p: p.name)
def test_commands_are_in_console_blocks_where_they_are_run(document: Path) -> None:
    for block in blocks(document):
        if block.language != "console" and block.lines != MAKE_BLOCK:
            stray = [line for line in block.lines if SHELL_LINE.match(line)]
            assert not stray, f"{document.name}:{block.line}: commands outside a ```console block: {stray}"


def test_the_readme_opens_with_the_two_commands_and_a_task_that_is_an_example() -> None:
    readme = (ROOT / "README.md").read_text().splitlines()
    assert set(MAKE_BLOCK) <= set(readme[:40])
    shown = next(b for b in blocks(ROOT / "README.md") if b.language == "yaml")
    example = ROOT / "examples" / "handover_full_can.yaml"
    assert yaml.safe_load("\n".join(shown.lines)) == yaml.safe_load(example.read_text())


def test_documents_link_only_to_files_that_exist() -> None:
    for document in DOCUMENTS:
        for target in re.findall(r"\]\(([^)#:]+)\)", document.read_text()):
            assert (document.parent / target).exists(), f"{document.name} links to a missing {target}"
