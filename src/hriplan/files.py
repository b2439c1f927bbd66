"""Reading pydantic-validated files with errors that name the file and the field."""

from __future__ import annotations

from pathlib import Path
from typing import TypeVar

from pydantic import BaseModel, ValidationError

from hriplan import HriplanError

M = TypeVar("M", bound=BaseModel)


def load_model(path: str | Path, model: type[M]) -> M:
    """Parse a JSON file as `model`; any problem is one line: `FILE: FIELD: what is wrong`."""
    path = Path(path)
    try:
        return model.model_validate_json(path.read_text())
    except (FileNotFoundError, IsADirectoryError):
        raise HriplanError(f"{path}: no such file") from None
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"]) or "(top level)"
        raise HriplanError(f"{path}: {where}: {first['msg']}") from None
