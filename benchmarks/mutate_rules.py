"""Mutation run over the rule files (data, so no mutation tool reads them): drop each rule, drop each
body atom, flip each literal, and run the rules tests on each mutant in a copy of the source tree.

A mutant that the tests still pass on survived: `make mutation` prints them for the report
(benchmarks/REPORT-mutation.md says why each one survives or which test kills it).
Usage: python benchmarks/mutate_rules.py [pytest args...]   (default: the rules tests)
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

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


def main(pytest_args: list[str]) -> int:
    survived = total = 0
    with tempfile.TemporaryDirectory(prefix="hriplan-rule-mutants-") as tmp:
        shutil.copytree(ROOT / "src", Path(tmp) / "src")
        env = {**os.environ, "PYTHONPATH": str(Path(tmp) / "src")}
        for path in RULES:
            target = Path(tmp) / "src/hriplan/rules" / path.name
            original = path.read_text(encoding="utf-8")
            for description, text in mutants(original):
                total += 1
                target.write_text(text, encoding="utf-8")
                run = subprocess.run(
                    [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", *pytest_args],
                    cwd=ROOT,
                    env=env,
                    capture_output=True,
                )
                killed = run.returncode != 0
                survived += not killed
                print(f"{'killed  ' if killed else 'SURVIVED'} {path.name}: {description}", flush=True)
            target.write_text(original, encoding="utf-8")
    print(f"rule files: {total} mutants, {total - survived} killed, {survived} survived")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:] or TESTS))
