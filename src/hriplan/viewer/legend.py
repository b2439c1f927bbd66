"""The viewer's legend: what the plan is, what each colour means, and why each constraint is there."""

from __future__ import annotations

from html import escape

from hriplan.planner.constraints.spec import OrientationConstraint
from hriplan.planner.constraints.words import kind
from hriplan.planner.trajectory import TrajectoryFile
from hriplan.viewer.describe import describe
from hriplan.viewer.scene import PERSON, SLOWED, TOOL_PATH
from hriplan.viewer.volumes import INSIDE, KEEP_OUT, LINK_AXIS, ORIENTATION, OUTSIDE, colors

KEY = (
    (INSIDE[0], "allowed region (stay inside): green, teal"),
    (OUTSIDE[0], "forbidden to the link (stay out): orange"),
    (KEEP_OUT[0], "keep-out zone (every robot link): red"),
    (ORIENTATION, "target axis and tolerance cone"),
    (LINK_AXIS, "the link's axis"),
    (TOOL_PATH, "tool path (beads at equal time steps)"),
    (SLOWED, "tool path held to a speed limit near a person (ISO/TS 15066)"),
    (PERSON, "person"),
)


def _swatch(rgb: int) -> str:
    return f'<span class="swatch" style="background:#{rgb:06x}"></span>'


def legend_html(trajectory: TrajectoryFile) -> str:
    report = trajectory.report
    summary = f"{trajectory.robot}, {report.status}, {report.duration:.2f} s, path {report.path_length:.2f} rad"
    if report.min_human_distance is not None:
        summary += f", closest to a person {report.min_human_distance:.3f} m"
    rows = []
    shades = colors(trajectory.constraints)
    for c in trajectory.constraints:
        worst = report.max_violation.get(c.spec.id)
        unit = "rad" if isinstance(c.spec, OrientationConstraint) else "m"
        margin = "" if worst is None else f' <span class="margin">worst margin {worst:+.3f} {unit}</span>'
        rows.append(
            f"<li>{_swatch(shades[c.spec.id])}<b>{escape(c.spec.id)}</b> <i>{escape(kind(c.spec))}</i>{margin}"
            f'<br><span class="reason">{escape(describe(c))}</span></li>'
        )
    key = "".join(f'<span class="key">{_swatch(rgb)}{escape(text)}</span>' for rgb, text in KEY)
    return (
        f'<details id="hriplan-legend" open><summary>{escape(summary)}</summary>'
        f"<ul>{''.join(rows) or '<li>no constraints</li>'}</ul>"
        '<div class="hint">worst margin: the largest signed distance past the constraint\'s boundary over the motion, '
        "in m (volumes) or rad (orientations); 0 or below (negative) means kept, above 0 violated by that much.</div>"
        f'<div class="keys">{key}</div>'
        '<div class="hint">Controls (top right): Animations to play, pause and pick a time; Scene to show or hide '
        "parts (people/…/checked_capsules: what the planner checks). Add #t=SECONDS to the address to show one instant."
        "</div></details>"
    )


LEGEND_CSS = """
#hriplan-step { position: absolute; left: 8px; top: 8px; font: 14px system-ui, sans-serif; padding: 2px 4px; }
#hriplan-legend { position: absolute; left: 8px; bottom: 8px; max-width: min(420px, 38vw); max-height: 32vh;
  overflow: auto; background: rgba(255, 255, 255, 0.88); border-radius: 6px; padding: 8px 10px;
  font: 13px/1.35 system-ui, sans-serif; color: #222; }
#hriplan-legend summary { font-weight: 600; margin-bottom: 4px; cursor: pointer; }
#hriplan-legend ul { margin: 0; padding: 0; list-style: none; }
#hriplan-legend li { margin: 3px 0; }
#hriplan-legend .swatch { display: inline-block; width: 11px; height: 11px; margin-right: 5px; border-radius: 2px;
  vertical-align: -1px; }
#hriplan-legend .reason { color: #444; margin-left: 16px; }
#hriplan-legend .margin { color: #666; font-size: 12px; }
#hriplan-legend .keys { margin-top: 6px; font-size: 12px; }
#hriplan-legend .key { margin-right: 10px; white-space: nowrap; }
#hriplan-legend .hint { margin-top: 4px; font-size: 11px; color: #666; }
"""
