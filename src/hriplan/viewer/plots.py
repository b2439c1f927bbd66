"""Figures of a plan (PNG): constraint margins, joint positions, velocities and accelerations,
distance to people, and per person the ISO/TS 15066 separation and speed towards them (from the
trajectory report). Each joint's axes are scaled to its own motion (a limit far outside it is
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

from hriplan.files import atomic_path
from hriplan.planner.constraints.spec import OrientationConstraint
from hriplan.planner.constraints.words import kind
from hriplan.planner.replay import PlannedWorld
from hriplan.planner.trajectory import TrajectoryFile
from hriplan.viewer.describe import describe

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
    if trajectory.report.separation:
        figures["separation"] = _separation(world)
    paths = []
    for name, figure in figures.items():
        path = out / f"{name}.png"
        with atomic_path(path) as tmp:  # a figure is whole or absent, even on Ctrl-C
            figure.savefig(tmp, dpi=DPI, format="png")
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


JOINT_FIELDS = {
    "positions": ("rad", "Joint positions"),
    "velocities": ("rad/s", "Joint velocities"),
    "accelerations": ("rad/s²", "Joint accelerations"),
}


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
    """Distance from the robot to the closest person's body capsules (grown by their margin, as
    the planner checks them)."""
    closest = world.human_distances()
    distance = np.array([d for d, _, _ in closest])
    figure = Figure(figsize=(9, 3.6), layout="constrained")
    ax: Axes = figure.subplots()
    ax.plot(world.times, distance, color="C0", label="closest robot part to a person")
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


def _series(values: list[float | None]) -> np.ndarray:
    return np.array([np.nan if v is None else v for v in values], dtype=float)


def _separation(world: PlannedWorld) -> Figure:
    """Per person: separation of the moving parts against the minimum separation S_0, and the
    speed towards them against the speed ISO/TS 15066 allows there (from the trajectory report)."""
    traces = world.trajectory.report.separation
    figure = Figure(figsize=(9, 0.8 + 4.4 * len(traces)), layout="constrained")
    axes = figure.subplots(2 * len(traces), 1, sharex=True, squeeze=False)[:, 0]
    for k, trace in enumerate(traces):
        top, bottom = axes[2 * k], axes[2 * k + 1]
        top.plot(
            world.times,
            _series(trace.body_separation),
            color="C0",
            label="separation of the moving parts from the body",
        )
        if trace.contact_speed is not None:
            top.plot(
                world.times,
                _series(trace.separation),
                color="C1",
                ls=":",
                label="... from the whole person (hand included)",
            )
        padding = (
            0.0 if world.trajectory.report.safety_margin is None else world.trajectory.report.safety_margin.padding
        )
        top.axhline(
            trace.minimum_separation,
            color=LIMIT,
            ls="--",
            lw=1,
            label=f"minimum separation S_0 = {trace.minimum_separation:.2f} m"
            + (f" (+ padding {padding:g} m: speed 0)" if padding else " (speed 0)"),
        )
        if padding:
            top.axhline(trace.minimum_separation + padding, color=LIMIT, ls=":", lw=1)
        top.set_ylabel("separation (m)")
        top.set_ylim(bottom=0.0)
        top.set_title(f"{trace.person} ({trace.role or 'no role'})", fontsize=9, loc="left")
        top.legend(fontsize=8, loc="upper right")
        allowed, actual = _series(trace.allowed_speed), _series(trace.approach_speed)
        bottom.plot(world.times, allowed, color=LIMIT, lw=1, label="allowed speed towards the person (with the margin)")
        bottom.plot(world.times, actual, color="C0", label="actual speed towards the person")
        bottom.fill_between(world.times, actual, allowed, where=actual <= allowed, color=KEPT, alpha=0.1, lw=0)
        if trace.contact_speed is not None:
            bottom.axhline(
                trace.contact_speed, color="C1", ls=":", lw=1, label=f"contact cap (PFL) {trace.contact_speed:.2f} m/s"
            )
        margin = "" if trace.worst_margin is None else f", worst margin {trace.worst_margin:+.3f} m/s"
        bottom.set_title(f"speed towards {trace.person}{margin}", fontsize=9, loc="left")
        bottom.set_ylabel("speed (m/s)")
        finite = allowed[np.isfinite(allowed)]
        bottom.set_ylim(
            min(0.0, float(np.nanmin(actual))) - 0.05,
            1.2 * max(float(finite.max()) if finite.size else 1.0, float(np.nanmax(actual))),
        )
        bottom.legend(fontsize=8, loc="upper right")
    axes[-1].set_xlabel("time (s)")
    figure.suptitle(_title(world, "Speed and separation (ISO/TS 15066)"), fontsize=11)
    return figure
