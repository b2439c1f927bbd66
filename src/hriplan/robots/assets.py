"""Where example-robot-data keeps the UR5, Allegro hand and human descriptions."""

from __future__ import annotations

import functools
from pathlib import Path


@functools.cache
def robots_dir() -> Path:
    """The `robots/` folder of the installed example-robot-data package (imported here: it loads
    pinocchio, which reading a robot description for the ontology does not need)."""
    import example_robot_data

    return Path(example_robot_data.getModelPath("ur_description/urdf/ur5_robot.urdf")).resolve()


def asset(relative: str) -> Path:
    """Absolute path of a file below example-robot-data's `robots/` folder."""
    path = robots_dir() / relative
    if not path.exists():
        raise FileNotFoundError(f"example-robot-data has no {relative} (looked in {robots_dir()})")
    return path


def resolve_package_uri(uri: str) -> str:
    """Turn `package://example-robot-data/robots/X` into an absolute path."""
    prefix = "package://example-robot-data/robots/"
    return str(asset(uri[len(prefix) :])) if uri.startswith(prefix) else uri
