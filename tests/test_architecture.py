"""The package dependency order the README's Architecture section documents, asserted on the code.

Every `import` in `src/hriplan` (at module level or inside a function) is read with `ast`; a
module may import only from its own room or a room on a lower floor. Rooms on one floor do not
import each other, so the order has no cycle.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"

# Lowest floor first. A room is a package or a module of `hriplan`; "hriplan" is the root's own
# modules (the error type, the file readers and writers).
FLOORS: list[set[str]] = [
    {"hriplan"},
    {"robots"},
    {"ontology"},
    {"safety"},
    {"planner.options", "planner.outcome"},
    {"planner.constraints"},
    {"planner.search"},
    {"planner"},
    {"rules"},
    {"tasks"},
    {"formats", "viewer"},
    {"sweeps", "service", "api"},
    {"cli"},
]
FLOOR = {room: level for level, rooms in enumerate(FLOORS) for room in rooms}


def room_of(module: str) -> str:
    """The most specific room named in FLOORS that holds `module` (dotted, without 'hriplan.')."""
    parts = module.split(".")
    for n in range(len(parts), 0, -1):
        if ".".join(parts[:n]) in FLOOR:
            return ".".join(parts[:n])
    return "hriplan"


def imports(src: Path = SRC) -> list[tuple[str, str, int]]:
    """(importing module, imported module, line) for every hriplan import, relative ones resolved."""
    found = []
    for path in sorted((src / "hriplan").rglob("*.py")):
        parts = list(path.relative_to(src).with_suffix("").parts)
        package = parts[:-1]
        module = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                base = package[: len(package) - node.level + 1] if node.level else []
                target = ".".join(base + ([node.module] if node.module else []))
                targets = [target] + [f"{target}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            else:
                continue
            for name in targets:
                as_path = src / name.replace(".", "/")
                if name == "hriplan" or (
                    name.startswith("hriplan.") and (as_path.is_dir() or as_path.with_suffix(".py").exists())
                ):
                    found.append((module, name, node.lineno))
    return found


def _short(module: str) -> str:
    return module.removeprefix("hriplan").removeprefix(".") or "hriplan"


def violations(src: Path = SRC) -> list[str]:
    """Every import from a room on the same or a higher floor than the importing module's."""
    wrong = []
    for module, target, line in imports(src):
        own, other = room_of(_short(module)), room_of(_short(target))
        if own != other and FLOOR[other] >= FLOOR[own]:
            wrong.append(f"{module}:{line} imports {target} ({own} on floor {FLOOR[own]}, {other} on {FLOOR[other]})")
    return wrong


def test_every_package_is_on_a_floor():
    packages = {p.name for p in (SRC / "hriplan").iterdir() if p.is_dir() and p.name != "__pycache__"}
    assert packages - set(FLOOR) == set(), "a package the architecture does not place"


def test_no_import_runs_up_or_sideways():
    assert violations() == []


@pytest.mark.parametrize("room", ["planner", "safety", "robots"])
def test_the_planner_and_below_know_nothing_of_tasks_rules_or_formats(room):
    above = {"tasks", "rules", "formats", "viewer", "sweeps", "service", "api", "cli"}
    wrong = [
        (m, t)
        for m, t, _ in imports()
        if room_of(_short(m)).split(".")[0] == room and room_of(_short(t)).split(".")[0] in above
    ]
    assert wrong == []


def test_the_check_finds_upward_relative_and_lazy_imports(tmp_path):
    """Planted in a small tree: a lazy import in a function, a relative one, a sideways one."""
    pkg = tmp_path / "hriplan"
    for room in ("robots", "tasks", "viewer", "formats"):
        (pkg / room).mkdir(parents=True)
        (pkg / room / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("")
    (pkg / "tasks" / "model.py").write_text("X = 1\n")
    (pkg / "robots" / "arm.py").write_text("def f():\n    from hriplan.tasks.model import X\n    return X\n")
    (pkg / "robots" / "hand.py").write_text("from .arm import f\n")
    (pkg / "viewer" / "page.py").write_text("from ..formats import reader\n")
    (pkg / "formats" / "reader.py").write_text("")
    found = violations(tmp_path)
    assert {line.split(" (")[0] for line in found} == {
        "hriplan.robots.arm:2 imports hriplan.tasks.model",
        "hriplan.viewer.page:1 imports hriplan.formats",
        "hriplan.viewer.page:1 imports hriplan.formats.reader",
    }


def pinocchio_imports(src: Path = SRC) -> list[str]:
    """Every module under tasks/ that imports pinocchio (the planning session does the kinematics)."""
    found = []
    for path in sorted((src / "hriplan" / "tasks").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            names = (
                [a.name for a in node.names]
                if isinstance(node, ast.Import)
                else [node.module or ""]
                if isinstance(node, ast.ImportFrom)
                else []
            )
            found += [f"{path.relative_to(src)}:{node.lineno}" for n in names if n.split(".")[0] == "pinocchio"]
    return found


def test_the_tasks_do_no_kinematics():
    assert pinocchio_imports() == []
