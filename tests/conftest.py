from pathlib import Path

import numpy as np
import pytest

from hriplan.planner.problem import load_problem
from hriplan.robots.model import load_robot


@pytest.fixture(scope="session")
def madar():
    return load_robot("madar", {"right": "power"})


@pytest.fixture
def rng():
    return np.random.default_rng(7)


@pytest.fixture(scope="module")
def problem():
    """The UR5 keeping a box upright (benchmarks/scenarios): the planner tests' shared problem."""
    return load_problem(Path(__file__).parents[1] / "benchmarks" / "scenarios" / "a_ur5_upright_box.json")
