"""Maps of a sweep: success and closest approach to a person over the varied parameters.

Per variant: success (every step solved) and the smallest separation to any person over its
steps. With two or more numeric varied columns the first two are the map's axes (other
dimensions are pooled: the colour is the success rate of the cell and its worst separation);
with one, curves over it; with none, bars per variant. PNG files and an HTML page that shows them.
"""

from __future__ import annotations

import html
from collections import defaultdict
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from hriplan.sweeps.results import Row, read_results
from hriplan.sweeps.run import succeeded

VARY = "vary."


def _numeric(values: list) -> bool:
    return all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)


def per_variant(rows: list[Row]) -> list[dict]:
    """One record per variant: its varied values, success, and its closest approach to a person."""
    by_key: dict[str, list[Row]] = defaultdict(list)
    for row in rows:
        by_key[row["key"]].append(row)
    records = []
    for key, steps in by_key.items():
        separations = [v for r in steps for c, v in r.items() if c.startswith("min_separation.") and v is not None]
        varied = {c[len(VARY) :]: v for c, v in steps[0].items() if c.startswith(VARY)}
        records.append(
            {
                "key": key,
                "source": Path(steps[0].get("source") or key).name,
                "varied": varied,
                "success": succeeded(steps),
                "separation": min(separations, default=None),
            }
        )
    return records


def _cells(records: list[dict], axes: list[str]) -> dict[tuple, tuple[float, float | None]]:
    """Per combination of the axes' values: success rate and worst separation of its variants."""
    pooled: dict[tuple, list[dict]] = defaultdict(list)
    for r in records:
        pooled[tuple(r["varied"].get(a) for a in axes)].append(r)
    cells = {}
    for point, members in pooled.items():
        separations = [m["separation"] for m in members if m["separation"] is not None]
        cells[point] = (sum(m["success"] for m in members) / len(members), min(separations, default=None))
    return cells


def _panel(figure, ax, cells: dict, axes: list[str], value: int, **style) -> None:
    """One value of the cells over the axes: a grid of cells when the points form one, else dots."""
    points = [p for p in cells if cells[p][value] is not None]
    if not points:
        return
    xs, ys = [p[0] for p in points], [p[1] if len(axes) > 1 else 0.0 for p in points]
    ux, uy = sorted(set(xs)), sorted(set(ys))
    if len(ux) * len(uy) <= 4 * len(points):
        grid = np.full((len(uy), len(ux)), np.nan)
        for x, y, p in zip(xs, ys, points):
            grid[uy.index(y), ux.index(x)] = cells[p][value]
        drawn = ax.pcolormesh(ux, uy, np.ma.masked_invalid(grid), shading="nearest", **style)
    else:
        drawn = ax.scatter(xs, ys, c=[cells[p][value] for p in points], s=60, **style)
    figure.colorbar(drawn, ax=ax, label="success rate" if value == 0 else "closest approach to a person (m)")


def _draw_map(cells: dict, axes: list[str], path: Path) -> None:
    figure, (left, right) = plt.subplots(1, 2, figsize=(11, 4.5), constrained_layout=True)
    _panel(figure, left, cells, axes, 0, cmap="RdYlGn", vmin=0, vmax=1)
    _panel(figure, right, cells, axes, 1, cmap="viridis")
    left.set_title("success")
    right.set_title("separation (solved motions)")
    for ax in (left, right):
        ax.set_xlabel(axes[0])
        ax.set_ylabel(axes[1] if len(axes) > 1 else "")
        if len(axes) > 1 and _same_units(axes):
            ax.set_aspect("equal", adjustable="box")
    figure.savefig(path, dpi=110)
    plt.close(figure)


def _same_units(axes: list[str]) -> bool:
    """Two components of one vector (e.g. a position's x and y): draw them to scale."""
    return axes[0].rsplit(".", 1)[0] == axes[1].rsplit(".", 1)[0]


def _draw_bars(records: list[dict], path: Path) -> None:
    figure, ax = plt.subplots(figsize=(max(6, 0.4 * len(records)), 4), constrained_layout=True)
    labels = [", ".join(f"{k}={v}" for k, v in r["varied"].items()) or r["source"] for r in records]
    ax.bar(
        range(len(records)),
        [r["separation"] or 0.0 for r in records],
        color=["tab:green" if r["success"] else "tab:red" for r in records],
    )
    ax.set_xticks(range(len(records)), labels, rotation=60, ha="right", fontsize=7)
    ax.set_ylabel("closest approach to a person (m); red: failed")
    figure.savefig(path, dpi=110)
    plt.close(figure)


def _metres(value: float | None) -> str:
    return "" if value is None else f"{value:.3f}"


def write_report(directory: Path) -> Path:
    """success_map.png (or variants.png) and report.html in the sweep's directory."""
    directory = Path(directory)
    records = per_variant(read_results(directory))
    names = list(dict.fromkeys(k for r in records for k in r["varied"]))
    axes = [n for n in names if _numeric([r["varied"].get(n) for r in records])][:2]
    image = directory / ("success_map.png" if axes else "variants.png")
    if axes:
        _draw_map(_cells(records, axes), axes, image)
    else:
        _draw_bars(records, image)
    solved = sum(r["success"] for r in records)
    rows = "".join(
        f"<tr><td>{html.escape(', '.join(f'{k}={v}' for k, v in r['varied'].items()))}</td><td>{'yes' if r['success'] else 'no'}</td>"
        f"<td>{_metres(r['separation'])}</td></tr>"
        for r in records
    )
    page = (
        f"<!doctype html><html><head><meta charset='utf-8'><title>sweep {html.escape(directory.name)}</title></head><body>"
        f"<h1>Sweep {html.escape(directory.name)}</h1><p>{len(records)} variants, {solved} succeeded in every step.</p>"
        f"<img src='{image.name}' style='max-width:100%'><table border='1'><tr><th>varied</th><th>success</th>"
        f"<th>closest approach (m)</th></tr>{rows}</table></body></html>"
    )
    (directory / "report.html").write_text(page)
    return directory / "report.html"
