"""`hriplan robot urdf`: the assembled URDF with mesh paths that work on another machine, and an
inertia on every link (robots/inertia.py: simulators and ROS tooling want one).

Inside hriplan the meshes are absolute paths into the installed example-robot-data. The exported
file names them `package://example-robot-data/robots/...` instead: the package root is the
folder holding `example-robot-data/` (`hriplan robot urdf --help` prints it; pass it to ROS as
ROS_PACKAGE_PATH or to pinocchio as `package_dirs`). `--mesh-dir DIR` writes plain paths into
DIR instead, for a copy of example-robot-data's `robots/` folder.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from hriplan import HriplanError

PACKAGE_PREFIX = "package://example-robot-data/robots/"


def package_root() -> Path:
    """The folder a ROS package path (or pinocchio's package_dirs) must contain."""
    from hriplan.robots.assets import robots_dir

    return robots_dir().parent.parent


def portable_urdf(urdf: str, mesh_dir: Path | None = None) -> str:
    """`urdf` with an inertia on every link and every mesh below example-robot-data as a
    package:// URI (or a path in `mesh_dir`)."""
    from hriplan.robots.assets import robots_dir
    from hriplan.robots.inertia import with_inertias

    if mesh_dir is not None and not mesh_dir.is_dir():
        raise HriplanError(f"--mesh-dir {mesh_dir}: no such directory")
    root, installed = ET.fromstring(with_inertias(urdf)), str(robots_dir()) + "/"
    for mesh in root.iter("mesh"):
        filename = mesh.get("filename", "")
        if filename.startswith(installed):
            relative = filename[len(installed) :]
            mesh.set(
                "filename", str(mesh_dir.resolve() / relative) if mesh_dir is not None else PACKAGE_PREFIX + relative
            )
    return ET.tostring(root, encoding="unicode")
