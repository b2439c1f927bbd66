"""One self-contained HTML file: meshcat's bundled client, the drawing's commands, the legend.

This is meshcat's own static export (its server's `get_scene`) without the server: the client
script is inlined, and the msgpack commands travel as one gzip-compressed base64 block (40 %
smaller) that the page decodes, unzips with the browser's DecompressionStream and hands to
`viewer.handle_command_bytearray`, so opening the file makes no request at all. The page
reads `#t=SECONDS` from its address (and on every change of it) to pause the animation at that
instant: a link to a moment of the plan, and what the browser test uses.

A task's page holds every step (`write_task_viewer`): a selector at the top picks the step,
`#step=K` in the address says which one is shown (the page reloads with that step's drawing,
legend and animation). Steps count from 1 everywhere a person sees them: the selector's "step
K", `#step=K` and the page's element ids and values.
"""

from __future__ import annotations

import base64
import gzip
import json
import struct
from html import escape
from pathlib import Path

import meshcat

from hriplan import HriplanError
from hriplan.files import write_atomically
from hriplan.planner.replay import PlannedWorld
from hriplan.planner.trajectory import TrajectoryFile
from hriplan.viewer.drawing import Drawing
from hriplan.viewer.legend import LEGEND_CSS, legend_html
from hriplan.viewer.scene import build_drawing

CLIENT = Path(meshcat.__file__).parent / "viewer" / "dist" / "main.min.js"

SCRIPT = """
function hriplanStep(hash, count) {  // the step `#step=K` asks for: 1 to count, else the first
  const asked = /[#&]step=([0-9]+)/.exec(hash);
  return asked ? Math.min(Math.max(parseInt(asked[1]), 1), count) : 1;
}
(async function () {
  const steps = JSON.parse(document.getElementById("hriplan-plan").textContent).steps;
  const step = hriplanStep(location.hash, steps.length);
  const plan = steps[step - 1];
  const selector = document.getElementById("hriplan-step");
  selector.value = String(step);
  selector.addEventListener("change", () => { location.hash = "step=" + selector.value; location.reload(); });
  document.querySelectorAll(".hriplan-step-legend").forEach(
    legend => { legend.hidden = legend.dataset.step !== String(step); });
  const viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
  window.viewer = viewer;
  const text = atob(document.getElementById("hriplan-commands-" + step).textContent.trim());
  const packed = Uint8Array.from(text, c => c.charCodeAt(0));
  const unzipped = new Blob([packed]).stream().pipeThrough(new DecompressionStream("gzip"));
  const bytes = new Uint8Array(await new Response(unzipped).arrayBuffer());
  const sizes = new DataView(bytes.buffer);
  for (let at = 0; at < bytes.length; ) {
    const size = sizes.getUint32(at, true);
    viewer.handle_command_bytearray(bytes.slice(at + 4, at + 4 + size));
    at += 4 + size;
  }
  const split = path => path.split("/").filter(part => part.length > 0);
  for (const [source, copy] of plan.clones) {  // repeated meshes share the first one's geometry
    const original = viewer.scene_tree.find(split(source).concat(["<object>"])).object;
    viewer.set_object(split(copy), original.clone());
  }
  if (plan.camera.eye) {  // orbit about the scene, not the origin
    viewer.camera.fov = plan.camera.fov;
    viewer.camera.position.set(...plan.camera.eye);
    viewer.controls.target.set(...plan.camera.target);
    viewer.controls.update();
  }
  viewer.gui.open();
  if (viewer.gui.__folders.Scene) viewer.gui.__folders.Scene.close();

  function requestedTime() {
    const match = /[#&]t=([0-9.]+)/.exec(location.hash);
    return match ? Math.min(parseFloat(match[1]), plan.duration) : null;
  }
  function show() {
    const time = requestedTime();
    const animator = viewer.animator;
    if (time !== null && animator.actions.length > 0) {
      animator.pause();
      animator.seek(time);
      animator.display_progress(time);
    }
    viewer.set_dirty();
    // Two frames later the scene has been drawn at that time: say so (tests wait for it). Without a
    // time, play from the start now: the first drawing can take longer than the whole motion.
    requestAnimationFrame(() => requestAnimationFrame(() => {
      if (time === null && animator.actions.length > 0) {
        animator.reset();
        animator.play();
      }
      document.body.dataset.shownTime = time === null ? "playing" : String(time);
    }));
  }
  window.addEventListener("hashchange", show);
  show();
})();
"""

PAGE = """<!DOCTYPE html>
<html>
<head>
<meta charset="utf-8">
<title>{title}</title>
<link rel="icon" href="data:,">
<style>
body {{ margin: 0; }}
#meshcat-pane {{ width: 100vw; height: 100vh; overflow: hidden; }}
{css}
</style>
</head>
<body>
<div id="meshcat-pane"></div>
<select id="hriplan-step" title="the step shown"{selector_hidden}>{options}</select>
{legends}
<script type="application/json" id="hriplan-plan">{plan}</script>
{commands}
<script>{client}</script>
<script>{script}</script>
</body>
</html>
"""


def _commands(drawing: Drawing) -> str:
    """The drawing's msgpack commands, length-framed, gzipped and base64-encoded."""
    framed = b"".join(struct.pack("<I", len(b)) + b for b in drawing.packed())
    return base64.b64encode(gzip.compress(framed, mtime=0)).decode("ascii")


def render_page(steps: list[tuple[str, Drawing, float, str]], title: str) -> str:
    """The HTML text of a viewer for (name, drawing, duration in s, legend HTML) per step."""
    plan = json.dumps(
        {
            "steps": [
                {"name": name, "duration": duration, "clones": drawing.clones, "camera": drawing.camera}
                for name, drawing, duration, _ in steps
            ]
        }
    ).replace("</", "<\\/")
    options = "".join(
        f'<option value="{k}">step {k}: {escape(name)}</option>' for k, (name, *_) in enumerate(steps, start=1)
    )
    legends = "".join(
        f'<div class="hriplan-step-legend" data-step="{k}">{legend}</div>'
        for k, (*_, legend) in enumerate(steps, start=1)
    )
    commands = "\n".join(
        f'<script type="application/octet-stream" id="hriplan-commands-{k}">{_commands(drawing)}</script>'
        for k, (_, drawing, *_) in enumerate(steps, start=1)
    )
    return PAGE.format(
        title=escape(title),
        css=LEGEND_CSS,
        options=options,
        selector_hidden="" if len(steps) > 1 else " hidden",
        legends=legends,
        plan=plan,
        commands=commands,
        client=CLIENT.read_text(encoding="utf-8"),
        script=SCRIPT,
    )


def write_task_viewer(trajectories: list[TrajectoryFile], path: str | Path) -> Path:
    """Write one offline 3D viewer for the steps of a task (HTML; opens in any browser, no network)."""
    if not trajectories:
        raise HriplanError("a viewer needs at least one trajectory")
    steps = []
    for k, trajectory in enumerate(trajectories):
        world = PlannedWorld.load(trajectory)
        steps.append((trajectory.step or f"step{k + 1}", build_drawing(world), world.duration, legend_html(trajectory)))
    first = trajectories[0]
    title = f"hriplan: {first.task + ', ' if first.task else ''}{first.robot} plan"
    return write_atomically(path, render_page(steps, title))


def write_viewer(trajectory: TrajectoryFile, path: str | Path) -> Path:
    """Write an offline 3D viewer of one plan to `path`."""
    return write_task_viewer([trajectory], path)
