"""The robots hriplan knows, by name: the built-in ones, read from the robot files shipped in
robots/data/ (madar.yaml, ur5.yaml: a URDF, an SRDF and what hriplan adds to them), and every
robot file a task, a problem or a command names, read the same way (robots/robot_file.py) and
registered under its robot's name. No code asks for a robot by name: a robot is data.
"""

from __future__ import annotations

from pathlib import Path

from hriplan import HriplanError
from hriplan.files import load_model
from hriplan.robots.descriptions.description import RobotDescription
from hriplan.robots.robot_file import RobotFile, robot_description

# The built-in robots' robot files (package data).
DATA = Path(__file__).resolve().parents[1] / "data"
BUILT_IN = ("madar", "ur5")


def _built_in(name: str) -> RobotDescription:
    path = DATA / f"{name}.yaml"
    return robot_description(load_model(path, RobotFile), path, source="")


DESCRIPTIONS: dict[str, RobotDescription] = {name: _built_in(name) for name in BUILT_IN}
# The robot a task, a problem, a situation or a session has when it names none.
DEFAULT_ROBOT = "madar"
# Every robot's named postures (the API's view of the descriptions).
POSTURES = {name: description.postures for name, description in DESCRIPTIONS.items()}


def description_of(name: str) -> RobotDescription:
    if name not in DESCRIPTIONS:
        raise HriplanError(f"unknown robot {name!r}; known robots: {', '.join(DESCRIPTIONS)}")
    return DESCRIPTIONS[name]


def posture(robot: str, name: str) -> dict[str, float]:
    """Joint values of one of a robot's named postures (joints not listed are 0)."""
    postures = description_of(robot).postures
    if name not in postures:
        raise HriplanError(unknown_posture(robot, name))
    return dict(postures[name])


def unknown_posture(robot: str, name: str) -> str:
    """What to say of a posture `robot` does not have: the ones it has, or where they come from."""
    postures = description_of(robot).postures
    known = ", ".join(postures) or "none (a robot file's `postures`, or its SRDF's group states, name them)"
    return f"robot {robot!r} has no posture {name!r}; postures: {known}"


ROBOT_FILE_SUFFIXES = (".yaml", ".yml", ".json")


def is_robot_file(robot: str) -> bool:
    """Whether a `robot` value names a robot file (a path) rather than a robot."""
    return robot.endswith(ROBOT_FILE_SUFFIXES)


def robot_name(robot: str) -> str:
    """The name of a robot given by name or by a robot file (loaded and registered)."""
    return load_robot_file(robot).name if is_robot_file(robot) else robot


def with_robot_name(data: dict, folder: Path) -> dict:
    """A task's or problem's data with a robot file its `robot:` names (a path relative to
    `folder`) loaded: `robot` becomes the robot's name and `robot_file` the file's absolute path
    (so a process that reads the data again, a sweep's worker, loads it too); a name is left as it is."""
    robot = data.get("robot")
    if not isinstance(robot, str) or not is_robot_file(robot):
        return data
    path = (folder / robot).resolve()
    try:
        return data | {"robot": robot_name(str(path)), "robot_file": str(path)}
    except HriplanError as exc:
        raise HriplanError(f"robot: {exc}") from None


def registered_robot_file(data: object) -> object:
    """A model's data before validation, its `robot_file` (if any) loaded and registered; for the
    models whose `robot` may come from a robot file (tasks, problems, trajectories)."""
    robot_file = data.get("robot_file") if isinstance(data, dict) else None
    if isinstance(robot_file, str) and robot_file:
        try:
            name = load_robot_file(robot_file).name
        except HriplanError as exc:
            raise ValueError(f"robot_file: {exc}") from None
        if name != data.get("robot"):
            raise ValueError(f"robot_file: {robot_file} is robot {name!r}, not {data.get('robot')!r}")
    return data


def load_robot_file(path: str | Path) -> RobotDescription:
    """The robot in a robot file, registered under its name (once per process; a name another
    file or a built-in robot has is an error; a built-in robot's own file is that robot)."""
    path = Path(path).resolve()
    spec = load_model(path, RobotFile)
    known = DESCRIPTIONS.get(spec.name)
    if known is not None and known.source == (str(path) if path != DATA / f"{spec.name}.yaml" else ""):
        return known  # this file's robot, loaded before (a built-in robot's file: at import)
    if known is not None:
        raise HriplanError(f"{path}: robot name {spec.name!r} is taken (by {known.source or 'a built-in robot'})")
    description = robot_description(spec, path, source=str(path))
    DESCRIPTIONS[spec.name] = description
    return description
