"""See a plan: an offline 3D viewer (`write_viewer`) and figures (`write_plots`).

Why meshcat for the viewer: it ships its three.js client inside the Python package
(`meshcat/viewer/dist/main.min.js`), so one HTML file can carry the client and the scene and open
offline with no CDN and no server; its command protocol (objects, transforms, properties,
animations) is small enough to produce directly from pinocchio's geometry; and its client already
has what a plan viewer needs: orbit camera, a scene tree to show or hide parts, and animation
controls (play, pause, time slider, speed). viser records scenes too, but its client is served
from a process; a hand-written three.js page would re-do what meshcat's client does.
"""

from hriplan.viewer.page import write_task_viewer, write_viewer
from hriplan.viewer.plots import write_plots

__all__ = ["write_plots", "write_task_viewer", "write_viewer"]
