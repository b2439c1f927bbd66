"""Reading pydantic-validated files with errors that name the file and the field."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, TypeVar

import yaml
from pydantic import BaseModel, ValidationError

from hriplan import HriplanError

M = TypeVar("M", bound=BaseModel)


def read_data(path: str | Path) -> Any:
    """The content of a JSON file (`.json`) or a YAML file (anything else)."""
    path = Path(path)
    try:
        text = path.read_text()
    except (FileNotFoundError, IsADirectoryError):
        raise HriplanError(f"{path}: no such file") from None
    try:
        return json.loads(text) if path.suffix == ".json" else yaml.safe_load(text)
    except json.JSONDecodeError as exc:
        raise HriplanError(f"{path}: line {exc.lineno}: not valid JSON ({exc.msg})") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        raise HriplanError(f"{path}: line {mark.line + 1 if mark else '?'}: not valid YAML ({getattr(exc, 'problem', exc)})") from None


def load_model(path: str | Path, model: type[M]) -> M:
    """Parse a file as `model`; any problem is one line: `FILE: FIELD: what is wrong`."""
    data = read_data(path)
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"]) or "(top level)"
        raise HriplanError(f"{path}: {where}: {first['msg']}") from None
