"""Figures of a plan (PNG): constraint margins, joint positions, velocities and accelerations,
distance to people. Each joint's axes are scaled to its own motion (a limit far outside it is
named in the panel's title instead of squashing the curve).

Margins are the validator's own (`ConstraintEvaluator.margins`), so a curve touching 0 is a
constraint on its boundary, exactly as the planner judged it. Figures are drawn on matplotlib
`Figure` objects (Agg canvas), never through pyplot's global state, so that a library call
leaves nothing open behind it.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from hriplan.files import temporary_path
from hriplan.planner.spec import OrientationConstraint
from hriplan.planner.trajectory import TrajectoryFile

from .describe import describe, kind
from hriplan.planner.replay import PlannedWorld

DPI = 110
KEPT = "#2ca02c"
LIMIT = "#d62728"


def write_plots(trajectory: TrajectoryFile, out_dir: str | Path) -> list[Path]:
    """Write the plan's figures into `out_dir`; returns their paths (people: only with people)."""
    world = PlannedWorld.load(trajectory)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figures = {f"joint_{field}": _joints(world, field) for field in JOINT_FIELDS}
    if world.constraints:
        figures["margins"] = _margins(world)
    if trajectory.scene.humans:
        figures["human_distance"] = _human_distance(world)
    paths = []
    for name, figure in figures.items():
        path = out / f"{name}.png"
        tmp = temporary_path(path)  # a figure is whole or absent, even on Ctrl-C
        figure.savefig(tmp, dpi=DPI, format="png")
        tmp.replace(path)
        paths.append(path)
    return paths


def _title(world: PlannedWorld, what: str) -> str:
    return f"{what} — {world.trajectory.robot}, {world.duration:.2f} s"


def _margins(world: PlannedWorld) -> Figure:
    margins = world.margins()
    resolved = {c.spec.id: c for c in world.trajectory.constraints}
    figure = Figure(figsize=(9, 1.0 + 2.1 * len(world.constraints)), layout="constrained")
    axes = figure.subplots(len(world.constraints), 1, sharex=True, squeeze=False)[:, 0]
    for ax, bound, column in zip(axes, world.constraints, margins.T):
        constraint = resolved[bound.id]
        unit = "rad" if isinstance(constraint.spec, OrientationConstraint) else "m"
        ax.plot(world.times, column, color="C0")
        ax.axhline(0.0, color=LIMIT, lw=1)
        low = min(float(column.min()), 0.0)
        ax.axhspan(low - 0.1 * (abs(low) + 1e-3), 0.0, color=KEPT, alpha=0.08, lw=0)
        ax.set_ylabel(f"margin ({unit})")
        ax.set_title(f"{bound.id} ({kind(constraint.spec)}): {describe(constraint)}", fontsize=9, loc="left", wrap=True)
    axes[-1].set_xlabel("time (s)")
    figure.suptitle(_title(world, "Constraint margins: 0 on the boundary, below 0 kept (shaded)"), fontsize=11)
    return figure


JOINT_FIELDS = {"positions": ("rad", "Joint positions"), "velocities": ("rad/s", "Joint velocities"),
                "accelerations": ("rad/s²", "Joint accelerations")}  # fmt: skip


def _joint_bounds(world: PlannedWorld, name: str, field: str) -> tuple[float, float] | None:
    """A joint's limits for a field (the robot model has no acceleration limits)."""
    model = world.robot.model
    joint = model.joints[model.getJointId(name)]
    if field == "positions":
        return model.lowerPositionLimit[joint.idx_q], model.upperPositionLimit[joint.idx_q]
    if field == "velocities":
        return -model.velocityLimit[joint.idx_v], model.velocityLimit[joint.idx_v]
    return None


def _joints(world: PlannedWorld, field: str) -> Figure:
    names = world.trajectory.joint_names
    unit, what = JOINT_FIELDS[field]
    values = np.array([getattr(p, field) for p in world.trajectory.points])
    columns = 3 if len(names) > 4 else len(names)
    rows = math.ceil(len(names) / columns)
    figure = Figure(figsize=(3.6 * columns, 0.8 + 2.2 * rows), layout="constrained")
    axes = figure.subplots(rows, columns, sharex=True, squeeze=False).ravel()
    for ax, name, column in zip(axes, names, values.T):
        ax.plot(world.times, column, color="C0")
        low, high = float(column.min()), float(column.max())
        pad = max(0.1 * (high - low), 0.02)
        view = (low - pad, high + pad)
        title = name
        bounds = _joint_bounds(world, name, field)
        for bound in bounds or ():
            if view[0] - 2 * pad <= bound <= view[1] + 2 * pad:  # near the motion: draw it
                ax.axhline(bound, color=LIMIT, ls="--", lw=1)
                view = (min(view[0], bound - pad), max(view[1], bound + pad))
        if bounds is not None and not all(view[0] <= b <= view[1] for b in bounds):
            title += f" (limits {bounds[0]:.2f} … {bounds[1]:.2f})"
        ax.set_ylim(*view)
        ax.set_title(title, fontsize=9)
        ax.set_ylabel(unit)
    for ax in axes[len(names) :]:
        ax.set_visible(False)
    for ax in axes[-columns:]:
        ax.set_xlabel("time (s)")
    suffix = " (limits dashed where the motion comes near them)" if field != "accelerations" else ""
    figure.suptitle(_title(world, what + suffix), fontsize=11)
    return figure


def _human_distance(world: PlannedWorld) -> Figure:
    """Distance from the robot to the closest person's body capsules, against each person's
    configured separation (the margin their capsules are grown by when the planner checks)."""
    margins = {h.name: h.margin for h in world.trajectory.scene.humans}
    closest = world.human_distances()
    distance = np.array([d + margins[person.split("/")[0]] for d, _, person in closest])
    figure = Figure(figsize=(9, 3.6), layout="constrained")
    ax: Axes = figure.subplots()
    ax.plot(world.times, distance, color="C0", label="closest robot part to a person")
    for name, margin in margins.items():
        if margin > 0.0:  # a person without a separation margin has no line to keep above
            ax.axhline(margin, color=LIMIT, ls="--", lw=1, label=f"required separation from {name}: {margin:.2f} m")
    worst = int(np.argmin(distance))
    _, part, person = closest[worst]
    ax.plot(world.times[worst], distance[worst], "o", color="C0")
    late = world.times[worst] > world.duration / 2  # keep the label inside the axes
    label = f"closest: {distance[worst]:.3f} m, {part} – {person}"
    where = (world.times[worst], distance[worst])
    offset, align = ((-8, 10), "right") if late else ((8, 10), "left")
    ax.annotate(label, where, textcoords="offset points", xytext=offset, ha=align, fontsize=9)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("distance (m)")
    ax.set_ylim(bottom=min(0.0, float(distance.min())))
    ax.legend(fontsize=9, loc="upper right")
    figure.suptitle(_title(world, "Distance to the people"), fontsize=11)
    return figure
