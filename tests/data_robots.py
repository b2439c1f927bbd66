"""Robots of the robot files in tests/data/robots, for tests (a test module registering them
restores the registry after: the `module_robot_registry` fixture)."""

from pathlib import Path

from hriplan.robots.descriptions.registry import load_robot_file
from hriplan.robots.model import Robot, load_robot

DATA = Path(__file__).parent / "data" / "robots"


def data_robot(name: str) -> Robot:
    """The robot of tests/data/robots/NAME.yaml."""
    return load_robot(load_robot_file(DATA / f"{name}.yaml").name)
