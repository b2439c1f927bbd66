"""Reading task files (YAML or JSON) with one-line errors: `FILE: FIELD: problem`."""

from __future__ import annotations

from pathlib import Path

from hriplan.files import load_model
from hriplan.robots.descriptions.registry import with_robot_name
from hriplan.tasks.model import TaskFile


def load_task(path: str | Path) -> TaskFile:
    """Read a task file (its `robot:` a name or a robot file relative to it)."""
    return load_model(path, TaskFile, lambda data: with_robot_name(data, Path(path).parent))
