"""Maps of a sweep: success, the kind of failure and the closest approach to a person over the
varied parameters.

Per variant: success (every step solved), its outcome (`success`, or the status of its first step
that did not succeed: `timeout`, `error`, `worker_died`, ...) and the smallest separation to any
person over its steps. The first two varied columns are the map's axes, numeric ones first; a
column of words (a fill level, a role) is an axis of its values in order. Other dimensions are
pooled: a cell's colour is its success rate, its most common outcome and its worst separation.
With no varied column (a batch), bars per variant. PNG files and an HTML page that shows them.
"""

from __future__ import annotations

import html
from collections import Counter, defaultdict
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.patches import Patch

from hriplan.planner.outcome import SUCCEEDED, Status
from hriplan.sweeps.results import Row, read_results
from hriplan.sweeps.run import succeeded

VARY = "vary."
SUCCESS = "success"
# One colour per outcome, the same in every report (a failure kind is recognised at a glance).
OUTCOME_COLOURS = {
    SUCCESS: "tab:green",
    Status.TIMEOUT.value: "tab:orange",
    Status.ERROR.value: "tab:gray",
    Status.WORKER_DIED.value: "black",
    Status.INVALID_START.value: "tab:purple",
    Status.INVALID_GOAL.value: "tab:pink",
    Status.UNREACHABLE_GOAL.value: "tab:brown",
    Status.INVALID_PATH.value: "tab:red",
    Status.PLANNER_ERROR.value: "tab:olive",
    Status.TIMING_FAILED.value: "tab:cyan",
}
OTHER_COLOUR = "tab:blue"  # a status this table does not know yet


def _numeric(values: list) -> bool:
    return all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)


def _outcome(steps: list[Row]) -> tuple[str, str]:
    """`success`, or the status and reason of the variant's first step that did not succeed."""
    for row in sorted(steps, key=lambda r: r.get("step_index", -1)):
        if row["status"] not in SUCCEEDED:
            return row["status"], row.get("reason") or ""
    return SUCCESS, ""


def per_variant(rows: list[Row]) -> list[dict]:
    """One record per variant: its varied values, success, outcome, and its closest approach to a person."""
    by_key: dict[str, list[Row]] = defaultdict(list)
    for row in rows:
        by_key[row["key"]].append(row)
    records = []
    for key, steps in by_key.items():
        separations = [v for r in steps for c, v in r.items() if c.startswith("min_separation.") and v is not None]
        varied = {c[len(VARY) :]: v for c, v in steps[0].items() if c.startswith(VARY)}
        outcome, reason = _outcome(steps)
        records.append(
            {
                "key": key,
                "source": Path(steps[0].get("source") or key).name,
                "varied": varied,
                "success": succeeded(steps),
                "outcome": outcome,
                "reason": reason,
                "separation": min(separations, default=None),
            }
        )
    return records


def map_axes(records: list[dict]) -> list[str]:
    """The map's axes: the first two varied columns, numeric ones before columns of words."""
    names = list(dict.fromkeys(k for r in records for k in r["varied"]))
    numeric = [n for n in names if _numeric([r["varied"].get(n) for r in records])]
    return (numeric + [n for n in names if n not in numeric])[:2]


def _cells(records: list[dict], axes: list[str]) -> dict[tuple, tuple[float, str, float | None]]:
    """Per combination of the axes' values: success rate, most common outcome, worst separation."""
    pooled: dict[tuple, list[dict]] = defaultdict(list)
    for r in records:
        pooled[tuple(r["varied"].get(a) for a in axes)].append(r)
    cells = {}
    for point, members in pooled.items():
        separations = [m["separation"] for m in members if m["separation"] is not None]
        cells[point] = (
            sum(m["success"] for m in members) / len(members),
            Counter(m["outcome"] for m in members).most_common(1)[0][0],
            min(separations, default=None),
        )
    return cells


class _Axis:
    """Where an axis's values are drawn: numbers at their value, words at 0, 1, 2 ... (sorted)."""

    def __init__(self, values: list) -> None:
        self.numeric = _numeric(values)
        self.labels = sorted(set(values)) if self.numeric else sorted({str(v) for v in values})
        self.positions = (
            [float(v) for v in self.labels] if self.numeric else [float(i) for i in range(len(self.labels))]
        )

    def position(self, value) -> float:
        return float(value) if self.numeric else float(self.labels.index(str(value)))

    def edges(self) -> np.ndarray:
        """Cell boundaries: halfway between neighbours, half a gap (or 0.5) beyond the ends."""
        p = np.array(self.positions)
        if len(p) == 1:
            return np.array([p[0] - 0.5, p[0] + 0.5])
        mid = (p[1:] + p[:-1]) / 2
        return np.concatenate([[p[0] - (mid[0] - p[0])], mid, [p[-1] + (p[-1] - mid[-1])]])


def _outcome_index(outcome: str) -> int:
    """An outcome's place in OUTCOME_COLOURS (one past the end: another status)."""
    return list(OUTCOME_COLOURS).index(outcome) if outcome in OUTCOME_COLOURS else len(OUTCOME_COLOURS)


def _panel(figure, ax, cells: dict, axes: list[_Axis], value: int, **style) -> None:
    """One value of the cells over the axes: a grid of cells when the points form one, else dots."""
    points = [p for p in cells if cells[p][value] is not None]
    if not points:
        ax.text(0.5, 0.5, "none (no motion was planned)", transform=ax.transAxes, ha="center", va="center")
        return
    colour = _outcome_index if value == 1 else (lambda v: v)
    xs = [axes[0].position(p[0]) for p in points]
    ys = [axes[1].position(p[1]) if len(axes) > 1 else 0.0 for p in points]
    ux, uy = axes[0].positions, axes[1].positions if len(axes) > 1 else [0.0]
    if len(ux) * len(uy) <= 4 * len(points):
        grid = np.full((len(uy), len(ux)), np.nan)
        for x, y, p in zip(xs, ys, points):
            grid[uy.index(y), ux.index(x)] = colour(cells[p][value])
        edges_y = axes[1].edges() if len(axes) > 1 else np.array([-0.5, 0.5])
        drawn = ax.pcolormesh(axes[0].edges(), edges_y, np.ma.masked_invalid(grid), **style)
    else:
        drawn = ax.scatter(xs, ys, c=[colour(cells[p][value]) for p in points], s=60, **style)
    if value == 1:
        shown = sorted({cells[p][1] for p in points}, key=_outcome_index)
        handles = [Patch(color=OUTCOME_COLOURS.get(o, OTHER_COLOUR), label=o) for o in shown]
        ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=8)
    else:
        figure.colorbar(drawn, ax=ax, label="success rate" if value == 0 else "closest approach to a person (m)")


def _draw_map(cells: dict, names: list[str], path: Path) -> None:
    axes = [_Axis([p[i] for p in cells]) for i in range(len(names))]
    figure, panels = plt.subplots(1, 3, figsize=(16, 4.5), constrained_layout=True)
    colours = [*OUTCOME_COLOURS.values(), OTHER_COLOUR]
    outcomes = ListedColormap(colours)
    _panel(figure, panels[0], cells, axes, 0, cmap="RdYlGn", vmin=0, vmax=1)
    _panel(
        figure,
        panels[1],
        cells,
        axes,
        1,
        cmap=outcomes,
        norm=BoundaryNorm(np.arange(-0.5, len(colours)), outcomes.N),
    )
    _panel(figure, panels[2], cells, axes, 2, cmap="viridis")
    for ax, title in zip(panels, ("success", "outcome (most common in a cell)", "separation (solved motions)")):
        ax.set_title(title)
        ax.set_xlabel(names[0])
        if not axes[0].numeric:
            ax.set_xticks(axes[0].positions, axes[0].labels)
        if len(names) > 1:
            ax.set_ylabel(names[1])
            if not axes[1].numeric:
                ax.set_yticks(axes[1].positions, axes[1].labels)
            elif axes[0].numeric and _same_units(names):
                ax.set_aspect("equal", adjustable="box")
        else:
            ax.set_yticks([])
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
        color=[OUTCOME_COLOURS.get(r["outcome"], OTHER_COLOUR) for r in records],
    )
    ax.set_xticks(range(len(records)), labels, rotation=60, ha="right", fontsize=7)
    ax.set_ylabel("closest approach to a person (m)")
    shown = list(dict.fromkeys(r["outcome"] for r in records))
    ax.legend(handles=[Patch(color=OUTCOME_COLOURS.get(o, OTHER_COLOUR), label=o) for o in shown], fontsize=8)
    figure.savefig(path, dpi=110)
    plt.close(figure)


def _metres(value: float | None) -> str:
    return "" if value is None else f"{value:.3f}"


def write_report(directory: Path) -> Path:
    """success_map.png (or variants.png) and report.html in the sweep's directory."""
    directory = Path(directory)
    records = per_variant(read_results(directory))
    axes = map_axes(records)
    image = directory / ("success_map.png" if axes else "variants.png")
    if axes:
        _draw_map(_cells(records, axes), axes, image)
    else:
        _draw_bars(records, image)
    solved = sum(r["success"] for r in records)
    failures = Counter(r["outcome"] for r in records if r["outcome"] != SUCCESS)
    failed = "; failed: " + ", ".join(f"{n} {kind}" for kind, n in failures.most_common()) if failures else ""
    rows = "".join(
        f"<tr><td>{html.escape(', '.join(f'{k}={v}' for k, v in r['varied'].items()) or r['source'])}</td>"
        f"<td>{html.escape(r['outcome'])}</td><td>{html.escape(r['reason'])}</td><td>{_metres(r['separation'])}</td></tr>"
        for r in records
    )
    page = (
        f"<!doctype html><html><head><meta charset='utf-8'><title>sweep {html.escape(directory.name)}</title></head><body>"
        f"<h1>Sweep {html.escape(directory.name)}</h1><p>{len(records)} variants, {solved} succeeded in every step"
        f"{html.escape(failed)}.</p><img src='{image.name}' style='max-width:100%'><table border='1'><tr><th>varied</th>"
        f"<th>outcome</th><th>reason</th><th>closest approach (m)</th></tr>{rows}</table></body></html>"
    )
    (directory / "report.html").write_text(page)
    return directory / "report.html"
