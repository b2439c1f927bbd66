"""Mutation run over the rule files (data, so no mutation tool reads them): drop each rule, drop each
body atom, flip each literal, and run the rules tests on each mutant (in a forked process that reads
its rules from a temporary copy of the rule directory).

A mutant that the tests still pass on survived: `make mutation` prints them for the report
(benchmarks/REPORT-mutation.md says why each one survives or which test kills it).
Usage: python benchmarks/mutate_rules.py [pytest args...]   (default: the rules tests)
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from hriplan.ontology import knowledge_base, ruleset  # noqa: F401 (imported once, before the forks)
from hriplan.rules import infer  # noqa: F401

ROOT = Path(__file__).resolve().parents[1]
RULES = sorted((ROOT / "src/hriplan/rules").glob("*.rules"))
TESTS = ["tests/rules/test_rules_situations.py", "tests/rules/test_rule_files_mutants.py"]
HEADER = re.compile(r"^\[(\w+)\]\s*$")
LITERALS = {'"Full"': '"Partial"', '"Partial"': '"Full"', '"Empty"': '"Full"', "true": "false"}


def _rules(lines: list[str]) -> Iterator[tuple[str, int, int]]:
    """(name, first line, end line) of each rule: its header and the lines up to a blank line."""
    for i, line in enumerate(lines):
        if m := HEADER.match(line):
            end = next((j for j in range(i + 1, len(lines)) if not lines[j].strip()), len(lines))
            yield m.group(1), i, end


def mutants(text: str) -> Iterator[tuple[str, str]]:
    """(description, mutated text) of every mutant of one rule file."""
    lines = text.splitlines(keepends=True)
    for name, start, end in _rules(lines):
        rule = "".join(lines[start + 1 : end])
        yield f"drop rule {name}", "".join(lines[:start] + lines[end:])
        body, head = rule.split("->")
        atoms = [a.strip() for a in body.split("^")]
        for k, atom in enumerate(atoms):
            if len(atoms) > 1:
                kept = " ^ ".join(a for j, a in enumerate(atoms) if j != k)
                yield f"{name}: drop body atom {atom}", _replace(lines, start, end, f"    {kept} -> {head.strip()}\n")
            for old, new in LITERALS.items():
                if old in atom:
                    swapped = " ^ ".join(a.replace(old, new) if j == k else a for j, a in enumerate(atoms))
                    yield (
                        f"{name}: {atom} with {new}",
                        _replace(lines, start, end, f"    {swapped} -> {head.strip()}\n"),
                    )


def _replace(lines: list[str], start: int, end: int, rule: str) -> str:
    return "".join(lines[: start + 1] + [rule] + lines[end:])


def _killed(rules_dir: Path, pytest_args: list[str]) -> bool:
    """Run the tests in a forked child reading its rules from `rules_dir` (the imports stay warm)."""
    pid = os.fork()
    if pid == 0:
        code = 1
        try:
            ruleset.RULES_DIR = rules_dir
            with open(os.devnull, "w") as quiet, contextlib.redirect_stdout(quiet), contextlib.redirect_stderr(quiet):
                code = int(pytest.main(["-x", "-q", "-p", "no:cacheprovider", *pytest_args]))
        finally:
            os._exit(code)
    return os.waitpid(pid, 0)[1] != 0


def main(pytest_args: list[str]) -> int:
    survived = total = 0
    with tempfile.TemporaryDirectory(prefix="hriplan-rule-mutants-") as tmp:
        rules_dir = Path(tmp)
        for path in RULES:
            shutil.copy(path, rules_dir / path.name)
        for path in RULES:
            original = path.read_text(encoding="utf-8")
            for description, text in mutants(original):
                total += 1
                (rules_dir / path.name).write_text(text, encoding="utf-8")
                killed = _killed(rules_dir, pytest_args)
                survived += not killed
                print(f"{'killed  ' if killed else 'SURVIVED'} {path.name}: {description}", flush=True)
            (rules_dir / path.name).write_text(original, encoding="utf-8")
        if _killed(rules_dir, pytest_args):
            raise SystemExit("the tests fail on the unmutated rule files: fix them first")
    print(f"rule files: {total} mutants, {total - survived} killed, {survived} survived")
    return 0


if __name__ == "__main__":
    os.chdir(ROOT)
    sys.exit(main(sys.argv[1:] or TESTS))
