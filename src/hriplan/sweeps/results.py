"""Sweep results on disk: append-safe Parquet parts, compacted into one table, resumable by key.

Rows arrive as variants finish and are written in small batches, each batch one Parquet part
file written to a temporary name and renamed (a crash never leaves a torn file). Compaction
merges the parts into `results.parquet` (and `results.csv` on request) the same way, keeping only
the latest run of a variant (all its rows come in one part), then removes the parts. Finished
variants are the keys found in the table and the parts, so a rerun skips them. Nothing is
created until rows are written (a sweep that cannot start leaves no folder).
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq

from hriplan import HriplanError
from hriplan.files import atomic_path

Row = dict[str, Any]

RESULTS = "results.parquet"


def _column(values: list[Any]) -> pa.Array:
    """A column as its natural Arrow type; mixed types (e.g. a varied role and a number) as text."""
    try:
        return pa.array(values)
    except (pa.ArrowInvalid, pa.ArrowTypeError):
        return pa.array([None if v is None else str(v) for v in values], pa.string())


def to_table(rows: list[Row]) -> pa.Table:
    names = list(dict.fromkeys(name for row in rows for name in row))
    return pa.table({name: _column([row.get(name) for row in rows]) for name in names})


def _write_table(table: pa.Table, path: Path, csv: bool = False) -> None:
    with atomic_path(path) as tmp:
        if csv:
            pacsv.write_csv(table, tmp)
        else:
            pq.write_table(table, tmp)


class ResultStore:
    """One sweep's directory of results."""

    def __init__(self, directory: Path, flush_rows: int = 64, flush_seconds: float = 5.0) -> None:
        self.directory = Path(directory)
        self.parts = self.directory / "parts"
        self.flush_rows, self.flush_seconds = flush_rows, flush_seconds
        self._buffer: list[Row] = []
        self._last_flush = time.monotonic()

    def create(self) -> None:
        """The folder and its parts folder; one line if they cannot be made."""
        try:
            self.parts.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise HriplanError(f"{self.directory}: cannot write results here ({exc.strerror})") from None

    @property
    def path(self) -> Path:
        return self.directory / RESULTS

    def add(self, rows: list[Row]) -> None:
        """Keep rows; write them as a part once enough have gathered or enough time has passed."""
        self._buffer += rows
        if len(self._buffer) >= self.flush_rows or time.monotonic() - self._last_flush >= self.flush_seconds:
            self.flush()

    def flush(self) -> None:
        if self._buffer:
            self.create()
            _write_table(to_table(self._buffer), self.parts / f"part-{time.time_ns()}-{os.getpid()}.parquet")
            self._buffer = []
        self._last_flush = time.monotonic()

    def _files(self) -> list[Path]:
        return ([self.path] if self.path.exists() else []) + sorted(self.parts.glob("part-*.parquet"))

    def finished_keys(self) -> set[str]:
        """Variants with a recorded outcome (in the table or a part not yet compacted)."""
        return {key for f in self._files() for key in pq.read_table(f, columns=["key"]).column("key").to_pylist()}

    def rows(self) -> list[Row]:
        """Every recorded row; a variant run again (--retry-failed) keeps only its latest rows."""
        latest: dict[str, list[Row]] = {}
        for f in self._files():
            found: dict[str, list[Row]] = {}
            for row in pq.read_table(f).to_pylist():
                found.setdefault(row["key"], []).append(row)
            latest |= found
        return [row for rows in latest.values() for row in rows]

    def compact(self, csv: bool = False) -> Path:
        """Merge the parts into the results table (and a CSV copy on request); remove the parts."""
        self.flush()
        parts = sorted(self.parts.glob("part-*.parquet"))
        rows = self.rows()
        if rows and (parts or not self.path.exists()):
            _write_table(to_table(rows), self.path)
        for part in parts:
            part.unlink()
        if csv and rows:
            _write_table(to_table(rows), self.directory / "results.csv", csv=True)
        return self.directory / "results.csv" if csv else self.path


def read_results(directory: Path) -> list[Row]:
    """A sweep directory's rows (for reports); a directory without results is an error."""
    directory = Path(directory)
    if not (directory / RESULTS).exists() and not any((directory / "parts").glob("part-*.parquet")):
        raise HriplanError(f"{directory}: no sweep results here (expected {RESULTS})")
    return ResultStore(directory).rows()
