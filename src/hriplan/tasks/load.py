"""Reading task files (YAML or JSON) with one-line errors: `FILE: FIELD: problem`."""

from __future__ import annotations

from pathlib import Path

from hriplan.files import load_model
from hriplan.tasks.model import TaskFile


def load_task(path: str | Path) -> TaskFile:
    return load_model(path, TaskFile)
