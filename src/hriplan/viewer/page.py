"""One self-contained HTML file: meshcat's bundled client, the drawing's commands, the legend.

This is meshcat's own static export (its server's `get_scene`) without the server: the client
script is inlined, and the msgpack commands travel as one gzip-compressed base64 block (40 %
smaller) that the page decodes, unzips with the browser's DecompressionStream and hands to
`viewer.handle_command_bytearray`, so opening the file makes no request at all. The page
reads `#t=SECONDS` from its address (and on every change of it) to pause the animation at that
instant: a link to a moment of the plan, and what the browser test uses.
"""

from __future__ import annotations

import base64
import gzip
import json
import struct
from html import escape
from pathlib import Path

import meshcat

from hriplan.planner.trajectory import TrajectoryFile

from .drawing import Drawing
from .legend import LEGEND_CSS, legend_html
from .scene import build_drawing
from hriplan.planner.replay import PlannedWorld

CLIENT = Path(meshcat.__file__).parent / "viewer" / "dist" / "main.min.js"

SCRIPT = """
(async function () {
  const plan = JSON.parse(document.getElementById("hriplan-plan").textContent);
  const viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
  window.viewer = viewer;
  const text = atob(document.getElementById("hriplan-commands").textContent.trim());
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
{legend}
<script type="application/json" id="hriplan-plan">{plan}</script>
<script type="application/octet-stream" id="hriplan-commands">{commands}</script>
<script>{client}</script>
<script>{script}</script>
</body>
</html>
"""


def render_page(drawing: Drawing, duration: float, title: str, legend: str) -> str:
    """The HTML text of a viewer for `drawing` (an animation of `duration` seconds)."""
    blobs = drawing.packed()
    framed = b"".join(struct.pack("<I", len(b)) + b for b in blobs)
    commands = base64.b64encode(gzip.compress(framed, mtime=0)).decode("ascii")
    plan = json.dumps({"duration": duration, "clones": drawing.clones, "camera": drawing.camera}).replace("</", "<\\/")
    return PAGE.format(title=escape(title), css=LEGEND_CSS, legend=legend, plan=plan, commands=commands,
                       client=CLIENT.read_text(encoding="utf-8"), script=SCRIPT)  # fmt: skip


def write_task_viewer(trajectories: list[TrajectoryFile], path: str | Path) -> Path:
    """PLACEHOLDER"""
    return write_viewer(trajectories[0], path)


def write_viewer(trajectory: TrajectoryFile, path: str | Path) -> Path:
    """Write an offline 3D viewer of the plan to `path` (HTML; opens in any browser, no network)."""
    world = PlannedWorld.load(trajectory)
    page = render_page(
        build_drawing(world), world.duration, f"hriplan: {trajectory.robot} plan", legend_html(trajectory)
    )
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(page, encoding="utf-8")
    tmp.replace(path)
    return path
