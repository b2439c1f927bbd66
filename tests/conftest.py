import contextlib
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from hriplan.planner.problem import load_problem
from hriplan.robots import kernel_switch
from hriplan.robots.descriptions import description, registry
from hriplan.robots.model import load_robot


@pytest.fixture(scope="session")
def madar():
    return load_robot("madar", {"right": "power"})


@pytest.fixture
def rng():
    return np.random.default_rng(7)


@pytest.fixture
def kernels():
    """The compiled kernels on for the test, as they were after it."""
    before = kernel_switch.kernels_on()
    kernel_switch.use_kernels(True)
    yield
    kernel_switch.use_kernels(before)


@pytest.fixture(scope="module")
def problem():
    """The UR5 keeping a box upright (benchmarks/scenarios): the planner tests' shared problem."""
    return load_problem(Path(__file__).parents[1] / "benchmarks" / "scenarios" / "a_ur5_upright_box.json")


@contextlib.contextmanager
def _restored_robot_registry() -> Iterator[None]:
    """Robot files register their robots and hand models: undo it when the block ends."""
    descriptions, hands = dict(registry.DESCRIPTIONS), dict(description.HAND_MODELS)
    yield
    for table, saved in ((registry.DESCRIPTIONS, descriptions), (description.HAND_MODELS, hands)):
        table.clear()
        table.update(saved)


@pytest.fixture
def robot_registry():
    """The robots robot files register in a test, for that test only."""
    with _restored_robot_registry():
        yield


@pytest.fixture
def arms_named_apart(tmp_path, robot_registry):
    """The bare MADAR (examples/robots) with its arms named `a` and `b`: no link or joint name
    starts with an arm's, as with TALOS (arm `right`, links `arm_right_7_link`), so whatever
    reads an arm's parts by name instead of by its kinematics fails on it."""
    examples = Path(__file__).parents[1] / "examples" / "robots"
    text = (examples / "madar_bare.yaml").read_text().replace("name: madar_bare", "name: madar_ab")
    text = text.replace("  right: {", "  a: {").replace("  left: {", "  b: {").replace("urdf: ", f"urdf: {examples}/")
    (tmp_path / "madar_ab.yaml").write_text(text)
    return load_robot(registry.load_robot_file(tmp_path / "madar_ab.yaml").name)


@pytest.fixture(scope="module")
def module_robot_registry():
    """The robots robot files register in a test module, for that module only."""
    with _restored_robot_registry():
        yield


@contextlib.contextmanager
def _kernels(on: bool) -> Iterator[bool]:
    before = kernel_switch.kernels_on()
    kernel_switch.use_kernels(on)
    try:
        yield on
    finally:
        kernel_switch.use_kernels(before)


@pytest.fixture(params=[False, True], ids=["python", "kernels"])
def either_route(request) -> Iterator[bool]:
    """The test twice: the compiled kernels (numba) off, then on; the switch as it was after."""
    with _kernels(request.param) as on:
        yield on


@pytest.fixture
def python_route() -> Iterator[None]:
    """The kernels off for a test of the Python route (HRIPLAN_KERNELS=1 may have turned them on)."""
    with _kernels(False):
        yield


@pytest.fixture
def compiled_route() -> Iterator[None]:
    """The kernels on for a test (a service's planning workers plan with them); skipped without numba."""
    pytest.importorskip("numba")
    with _kernels(True):
        yield
