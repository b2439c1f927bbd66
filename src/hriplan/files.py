"""Reading user files (task, problem, trajectory, query, rule, Kautham files) with one-line errors,
and writing outputs whole or not at all.

Every problem a file can have - missing, a directory, binary, not UTF-8, bad syntax, a key given
twice, the wrong structure - becomes one `HriplanError` naming the file (and line or field).
"""

from __future__ import annotations

import glob
import json
import os
import secrets
import shutil
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any, TypeVar

import yaml
from pydantic import BaseModel, Field, ValidationError

from hriplan import HriplanError

M = TypeVar("M", bound=BaseModel)
# A number a file gives: NaN and the infinities are refused, naming the field.
Finite = Annotated[float, Field(allow_inf_nan=False)]


def read_text(path: str | Path, what: str = "file") -> str:
    """The UTF-8 text of a file; a missing file, a directory or binary content is a user error."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise HriplanError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise HriplanError(f"{path}: is a directory, not a {what}") from None
    except OSError as exc:
        raise HriplanError(f"{path}: cannot read it ({exc.strerror or exc})") from None
    if b"\x00" in data:
        raise HriplanError(f"{path}: not a text file (binary content), expected a {what}")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise HriplanError(f"{path}: line {line}: not valid UTF-8 text (byte {data[exc.start]:#04x})") from None


class _UniqueKeyLoader(yaml.SafeLoader):
    """YAML's safe loader, refusing a key given twice in one mapping (YAML would keep the last)."""

    aliases = True

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict:
        seen: dict[Any, int] = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            line = key_node.start_mark.line + 1
            if isinstance(key, list | dict):
                raise HriplanError(f"line {line}: a key must be a single value, not a {type(key).__name__}")
            if not isinstance(key, str):  # YAML 1.1 reads `on`, `no`, `yes`, `off` as booleans, `1` as a number
                raise HriplanError(
                    f"line {line}: key {key_node.value!r} is read as {key!r}, not a name: quote it ('{key_node.value}')"
                )
            if key in seen:
                raise HriplanError(f"line {line}: key {key!r} is given twice (first at line {seen[key]})")
            seen[key] = line
        return super().construct_mapping(node, deep)

    def compose_node(self, parent, index):
        if not self.aliases and self.check_event(yaml.AliasEvent):
            event = self.peek_event()
            raise yaml.MarkedYAMLError(
                problem="aliases are not accepted in request bodies", problem_mark=event.start_mark
            )
        return super().compose_node(parent, index)


class _UniqueKeyLoaderNoAliases(_UniqueKeyLoader):
    """The same, refusing anchors and aliases: a few bytes of aliases can expand to gigabytes."""

    aliases = False


def _reject_constant(name: str) -> float:
    raise ValueError(f"{name} is not a number JSON allows")


def _unique_pairs(pairs: list[tuple[str, Any]]) -> dict:
    data = dict(pairs)
    if len(data) < len(pairs):
        seen: set[str] = set()
        twice = next(key for key, _ in pairs if key in seen or seen.add(key))
        raise HriplanError(f"key {twice!r} is given twice")
    return data


JSON_TYPES = (dict, list, str, int, float, bool, type(None))


def _not_json(data: Any, path: str = "") -> str | None:
    """Where in `data` a value JSON has no type for lies (a YAML date, binary, set), if anywhere."""
    if isinstance(data, dict):
        return next((w for k, v in data.items() if (w := _not_json(v, f"{path}.{k}" if path else str(k)))), None)
    if isinstance(data, list):
        return next((w for i, v in enumerate(data) if (w := _not_json(v, f"{path}.{i}" if path else str(i)))), None)
    if not isinstance(data, JSON_TYPES):
        return f"{path or 'the top level'}: a {type(data).__name__} value, which JSON has no type for"
    return None


def parse_data(text: str, syntax: str, *, aliases: bool = True) -> Any:
    """The value of a JSON (`syntax` "json") or YAML text, as JSON would hold it. Every problem is an
    HriplanError of one line saying where: bad syntax, a key given twice, a value JSON has no type
    for (a YAML date, binary, set), NaN or Infinity, nesting too deep, or (without `aliases`) a
    YAML alias. Files (`read_data`) and the service's request bodies both read through it."""
    try:
        if syntax == "json":
            data = json.loads(text, parse_constant=_reject_constant, object_pairs_hook=_unique_pairs)
        else:
            data = yaml.load(text, _UniqueKeyLoader if aliases else _UniqueKeyLoaderNoAliases)
    except HriplanError:  # a key given twice
        raise
    except RecursionError:
        raise HriplanError("nested too deeply") from None
    except json.JSONDecodeError as exc:
        raise HriplanError(f"line {exc.lineno}: not valid JSON ({exc.msg})") from None
    except ValueError as exc:  # a NaN or Infinity constant in JSON
        raise HriplanError(f"not valid JSON ({exc})") from None
    except yaml.reader.ReaderError as exc:  # a character YAML does not allow in its text
        line = text[: exc.position].count("\n") + 1
        raise HriplanError(f"line {line}: not valid YAML (character U+{exc.character:04X} is not allowed)") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        raise HriplanError(
            f"line {mark.line + 1 if mark else '?'}: not valid YAML ({getattr(exc, 'problem', exc)})"
        ) from None
    if (where := _not_json(data)) is not None:
        raise HriplanError(where)
    return data


def read_data(path: str | Path) -> Any:
    """The content of a JSON file (`.json`) or a YAML file (anything else), which must be a mapping."""
    path = Path(path)
    syntax = "json" if path.suffix == ".json" else "yaml"
    text = read_text(path, f"{syntax.upper()} file")
    if not text.strip():
        raise HriplanError(f"{path}: the file is empty")
    try:
        data = parse_data(text, syntax)
    except HriplanError as exc:
        raise HriplanError(f"{path}: {exc}") from None
    if not isinstance(data, dict):
        raise HriplanError(f"{path}: expected a mapping of fields at the top level, got {type(data).__name__}")
    return data


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A new empty file beside `path` to write into; when the block ends it is synced and renamed
    onto `path`, and on any failure (Ctrl-C included) removed, so a reader sees the old file or the
    new one, whole. Its name is unique (`.NAME.<random>.tmp`): two writers of the same file at once
    never write into one temporary, the last rename wins."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{secrets.token_hex(8)}.tmp")
    os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))  # as mkstemp, but with the umask's mode
    try:
        yield tmp
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


@contextmanager
def atomic_directory(path: str | Path) -> Iterator[Path]:
    """Where to make a new directory that replaces `path` when the block ends (an old one there
    is moved aside, then removed): the same name in a new temporary folder beside `path`
    (`.NAME.<random>.tmp`, which `temporaries` finds), removed on any failure. A reader sees the
    old directory or the new one, whole (for a moment, between two renames, neither)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    folder = path.with_name(f".{path.name}.{secrets.token_hex(8)}.tmp")
    folder.mkdir()
    try:
        yield folder / path.name
        if path.exists():
            os.replace(path, folder / f"{path.name}.replaced")
        os.replace(folder / path.name, path)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def temporaries(path: Path) -> list[Path]:
    """The temporaries `atomic_path` (files) and `atomic_directory` (folders) have open for `path` (what an interrupted command removes)."""
    return list(path.parent.glob(f".{glob.escape(path.name)}.*.tmp"))


def write_atomically(path: str | Path, data: str | bytes) -> Path:
    """Write `data` (text as UTF-8) to `path` through `atomic_path`: whole or not at all."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data.encode("utf-8") if isinstance(data, str) else data)
    return Path(path)


def load_model(path: str | Path, model: type[M], prepare: Callable[[dict], dict] | None = None) -> M:
    """Parse a file as `model`, its data first through `prepare` (e.g. paths it names resolved);
    any problem is one line: `FILE: FIELD: what is wrong`."""
    data = read_data(path)
    if prepare is not None:
        try:
            data = prepare(data)
        except HriplanError as exc:
            raise HriplanError(f"{path}: {exc}") from None
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise HriplanError(f"{path}: {validation_message(exc)}") from None


def validation_message(exc: ValidationError) -> str:
    """A validation's first error as `FIELD: what is wrong`; an error of the whole model (a check
    across fields, which names its fields itself) is only what is wrong."""
    first = exc.errors()[0]
    where, what = error_location(first["loc"]), first["msg"].removeprefix("Value error, ")
    return f"{where}: {what}" if where else what


def error_location(loc: tuple[int | str, ...]) -> str:
    """`steps.0.goal.joints` for a pydantic error location ("" for the whole model): a goal's union
    tag, which repeats the goal's key (`goal.joints.joints`), is dropped."""

    def is_tag(k: int) -> bool:
        after_goal = loc[k - 1] == "goal" or (k > 1 and loc[k - 2] == "goals")
        return 0 < k < len(loc) - 1 and loc[k + 1] == loc[k] and after_goal

    return ".".join(str(p) for k, p in enumerate(loc) if not is_tag(k))
