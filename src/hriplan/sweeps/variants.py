"""Variants of a task: task-file fields varied over lists, ranges and grids.

`--vary PATH=VALUES`: PATH is a dotted task-file field, list items by name
(`humans.alice.position`, `objects.can.fill_level`, `planning.seed`, `humans.alice.position.1`);
VALUES a list (`a,b,c` or JSON), an inclusive range (`0.5:1.5:0.25`) or, for vector fields, a grid
of components (`[0.4:1.2:0.2, 1.0:2.0:0.5]`, `|` separates a list inside a component). The cross
product of the dimensions gives the variants, or `samples` random draws (ranges drawn uniformly).
Every variant is a validated TaskFile whose key is the hash of its content.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import BaseModel, ValidationError

from hriplan import HriplanError
from hriplan.files import validation_message
from hriplan.tasks.model import TaskFile


class Component(BaseModel):
    """One scalar axis: explicit values, or an inclusive numeric range with a step."""

    values: list[Any] = []
    low: float | None = None
    high: float | None = None
    step: float | None = None
    integer: bool = False

    def grid(self) -> list[Any]:
        if self.step is None:
            return list(self.values)
        count = math.floor((self.high - self.low) / self.step + 1e-9) + 1
        points = [round(self.low + i * self.step, 12) for i in range(count)]
        return [int(p) for p in points] if self.integer else points

    def draw(self, rng: np.random.Generator) -> Any:
        if self.step is None:
            return self.values[int(rng.integers(len(self.values)))]
        if self.integer:
            return int(rng.integers(int(self.low), int(self.high) + 1))
        return float(rng.uniform(self.low, self.high))


class Dimension(BaseModel):
    """A varied field: one component (a scalar) or several (a vector, one value per component)."""

    path: str
    components: list[Component]
    vector: bool = False

    def grid(self) -> list[Any]:
        if not self.vector:
            return self.components[0].grid()
        return [list(v) for v in itertools.product(*(c.grid() for c in self.components))]

    def draw(self, rng: np.random.Generator) -> Any:
        values = [c.draw(rng) for c in self.components]
        return values if self.vector else values[0]


class Variant(BaseModel):
    """One task to plan: where it came from, what was varied, and the task itself. A sweep keys it
    by what its result depends on (`run_key`); `trajectories`: its worker returns them too."""

    key: str
    source: str
    values: dict[str, Any]
    task: TaskFile
    trajectories: bool = False


def _scalar(text: str) -> Any:
    text = text.strip()
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


def _number(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


def _component(text: str, path: str) -> Component:
    parts = text.split(":")
    numbers = [_number(p) for p in parts]
    if len(parts) == 3 and None not in numbers:
        low, high, step = numbers
        if step <= 0 or high < low:
            raise HriplanError(f"--vary {path}: range {text!r} needs LOW:HIGH:STEP with LOW <= HIGH and STEP > 0")
        integer = all(p.strip().lstrip("-").isdigit() for p in parts)
        return Component(low=low, high=high, step=step, integer=integer)
    values = [_scalar(v) for v in text.split("|" if "|" in text else ",")]
    if any(v == "" for v in values):
        raise HriplanError(f"--vary {path}: empty value in {text!r}")
    return Component(values=values)


def parse_vary(text: str) -> Dimension:
    """`PATH=VALUES` as a dimension of the sweep."""
    path, sep, spec = text.partition("=")
    path, spec = path.strip(), spec.strip()
    if not sep or not path or not spec:
        raise HriplanError(f"--vary takes PATH=VALUES (e.g. planning.seed=1,2,3), got {text!r}")
    if spec.startswith("["):
        try:
            data = json.loads(spec)
        except json.JSONDecodeError:
            data = None
        if isinstance(data, list):
            if not data:
                raise HriplanError(f"--vary {path}: no values")
            return Dimension(path=path, components=[Component(values=data)])
        if not spec.endswith("]"):
            raise HriplanError(f"--vary {path}: a grid is [RANGE, RANGE, ...], got {spec!r}")
        return Dimension(
            path=path, components=[_component(p.strip(), path) for p in spec[1:-1].split(",")], vector=True
        )
    return Dimension(path=path, components=[_component(spec, path)])


def _child(node: Any, part: str, path: str) -> Any:
    if isinstance(node, dict):
        if part not in node:
            raise HriplanError(f"--vary {path}: no field {part!r} (fields here: {', '.join(node)})")
        return node[part]
    if isinstance(node, list):
        named = [item for item in node if isinstance(item, dict) and item.get("name") == part]
        if named:
            return named[0]
        if part.isdigit() and int(part) < len(node):
            return node[int(part)]
        names = [str(item["name"]) for item in node if isinstance(item, dict) and item.get("name")]
        raise HriplanError(f"--vary {path}: no item {part!r} in the list (names: {', '.join(names) or 'none'})")
    raise HriplanError(f"--vary {path}: {part!r} is inside a value, not a field")


def set_field(data: dict[str, Any], path: str, value: Any) -> None:
    """Set the dotted field `path` of a task's data (list items by name or index)."""
    *parents, last = path.split(".")
    node: Any = data
    for part in parents:
        node = _child(node, part, path)
    if isinstance(node, dict):
        _child(node, last, path)  # the field must exist: a typo is an error, not a new key
        node[last] = value
    elif isinstance(node, list) and last.isdigit() and int(last) < len(node):
        node[int(last)] = value
    else:
        raise HriplanError(f"--vary {path}: {last!r} is not a field or a component of a value")


def task_key(task: TaskFile) -> str:
    """A variant's identity: the hash of its task's content (resuming skips finished keys)."""
    text = json.dumps(task.model_dump(mode="json", by_alias=True), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _digest(parts: dict[str, Any]) -> str:
    return hashlib.sha256(json.dumps(parts, sort_keys=True, default=str).encode()).hexdigest()[:16]


def run_key(variant: Variant, plan: bool) -> str:
    """What a variant's result depends on, hashed: its task, the mode (planned or derive-only),
    the rule files' contents (the package's and the task's), the robot's description and hriplan's
    version. A rerun skips a key already recorded, so a change of any of these runs it again."""
    from dataclasses import replace

    from hriplan import __version__
    from hriplan.ontology.ruleset import RULES_DIR
    from hriplan.robots.descriptions.registry import description_of

    files = sorted(RULES_DIR.glob("*.rules")) + [Path(f) for f in variant.task.rule_files]
    rules = {str(f): hashlib.sha256(f.read_bytes()).hexdigest() if f.is_file() else None for f in files}
    robot = description_of(variant.task.robot)
    return _digest(
        {
            "task": task_key(variant.task),
            "mode": "plan" if plan else "derive",
            "rules": rules,
            "robot": robot.urdf() + repr(replace(robot, urdf=None)),
            "version": __version__,
        }
    )


def _absolute_rules(task: TaskFile, base_dir: Path) -> TaskFile:
    """Rule files by absolute path, so a variant runs the same from any directory (and row)."""
    return task.model_copy(update={"rule_files": [str((base_dir / f).resolve()) for f in task.rule_files]})


def load_base(path: Path) -> tuple[dict[str, Any], TaskFile]:
    """A task file's data (normalised through the model) and its validated task."""
    from hriplan.tasks.load import load_task

    task = _absolute_rules(load_task(path), path.parent)
    return task.model_dump(mode="json", by_alias=True), task


def _validated(data: dict[str, Any], values: dict[str, Any], source: str) -> Variant:
    try:
        task = TaskFile.model_validate(data)
    except ValidationError as exc:
        shown = ", ".join(f"{p}={json.dumps(v)}" for p, v in values.items())
        raise HriplanError(f"variant {shown}: {validation_message(exc)}") from None
    return Variant(key=task_key(task), source=source, values=values, task=task)


def expand(path: Path, dimensions: list[Dimension], samples: int | None = None, seed: int = 0) -> list[Variant]:
    """The sweep's variants (cross product, or `samples` random draws), each validated; repeats dropped."""
    data, _ = load_base(path)
    for i, d in enumerate(dimensions):
        for other in dimensions[:i]:
            if d.path == other.path:
                raise HriplanError(f"--vary {d.path} is given twice: give all its values in one --vary")
            if f"{d.path}.".startswith(f"{other.path}.") or f"{other.path}.".startswith(f"{d.path}."):
                raise HriplanError(f"--vary {d.path} overlaps --vary {other.path}: vary one of them")
    if samples is not None:
        if samples < 1:
            raise HriplanError("--samples must be at least 1")
        rng = np.random.default_rng(seed)
        combos = [tuple(d.draw(rng) for d in dimensions) for _ in range(samples)]
    else:
        combos = list(itertools.product(*(d.grid() for d in dimensions)))
    variants: dict[str, Variant] = {}
    for combo in combos:
        values = {d.path: v for d, v in zip(dimensions, combo)}
        variant_data = copy.deepcopy(data)
        for p, v in values.items():
            set_field(variant_data, p, v)
        variant = _validated(variant_data, values, str(path))
        variants.setdefault(variant.key, variant)
    return list(variants.values())


def batch(paths: list[Path]) -> list[Variant]:
    """One variant per task file (`hriplan batch`)."""
    variants: dict[str, Variant] = {}
    for path in paths:
        _, task = load_base(path)
        variants.setdefault(task_key(task), Variant(key=task_key(task), source=str(path), values={}, task=task))
    return list(variants.values())
