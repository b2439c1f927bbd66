"""Outputs are checked before the work starts, and never left half written.

A command names its outputs first (`file_output`, `directory_output`): a path under a file, a
directory where a file goes (or the reverse) or an unwritable folder is a one-line error before
any reasoning or planning. Files are written through a temporary `.NAME.<random>.tmp` and renamed
(files.atomic_path); an interrupted command removes the temporary files of the outputs it named.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

from hriplan import HriplanError

_NAMED: list[Path] = []  # outputs of the running command, whose temporaries an interrupt removes


def _writable_folder(path: Path, option: str) -> None:
    """The nearest existing folder of `path` is a folder we may write into."""
    for parent in path.parents:
        if parent.exists():
            if not parent.is_dir():
                raise HriplanError(f"{option} {path}: {parent} is a file, not a directory")
            try:  # permissions alone do not tell (a read-only mount, /proc): try it
                with tempfile.TemporaryFile(dir=parent):
                    pass
            except OSError as exc:
                raise HriplanError(f"cannot write {path}: {exc.strerror or exc} ({parent})") from None
            return


def _not_an_option(path: Path, option: str) -> None:
    """`--html --plots out/p` gives --html the value --plots: refuse a name an option would have."""
    if path.name.startswith("-"):
        raise HriplanError(f"{option} {path}: looks like an option, not a name (is the value before it missing?)")


def file_output(path: Path, option: str = "--output") -> Path:
    """A file the command will write (its folders are made when it is written)."""
    _not_an_option(path, option)
    if path.is_dir():
        raise HriplanError(f"{option} {path}: is a directory; give a file name")
    _writable_folder(path, option)
    _NAMED.append(path)
    return path


def directory_output(path: Path, option: str = "--output") -> Path:
    """A directory the command will write files into."""
    _not_an_option(path, option)
    if path.exists() and not path.is_dir():
        raise HriplanError(f"{option} {path}: is a file; give a directory")
    _writable_folder(path / "-", option)
    _NAMED.append(path)
    return path


def remove_partial_outputs() -> None:
    """Remove the temporary files of the named outputs (and those anywhere in their directories:
    `plot` writes one folder per step)."""
    from hriplan.files import temporaries  # (loads pydantic and yaml: not for `--help`)

    for path in _NAMED:
        candidates = temporaries(path) + (list(path.rglob(".*.tmp")) if path.is_dir() else [])
        for tmp in candidates:
            if tmp.is_dir():  # a directory being made (files.atomic_directory: a bag)
                shutil.rmtree(tmp, ignore_errors=True)
            else:
                tmp.unlink(missing_ok=True)
