import numpy as np
import pytest

from hriplan.robots.model import load_robot


@pytest.fixture(scope="session")
def madar():
    return load_robot("madar", {"right": "power"})


@pytest.fixture
def rng():
    return np.random.default_rng(7)
