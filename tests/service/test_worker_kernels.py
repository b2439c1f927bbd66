"""A worker's compiled-kernel switch (worker_main.kernels_for_worker): what the server asked, not
the HRIPLAN_KERNELS the worker inherited, and a load that fails leaves a worker that still plans."""

import pytest

from hriplan.planner import kernels as planner_kernels
from hriplan.robots import kernel_switch
from hriplan.service.worker_main import kernels_for_worker


def test_off_when_not_asked_even_if_the_switch_was_on(compiled_route):
    assert kernel_switch.kernels_on()  # as HRIPLAN_KERNELS=1 inherited from the server's environment
    assert kernels_for_worker(False) is False and kernel_switch.kernels_on() is False


def test_on_and_loaded_when_asked(python_route):
    pytest.importorskip("numba")
    assert kernels_for_worker(True) is True and kernel_switch.kernels_on() is True


def test_a_load_that_fails_leaves_them_off_and_says_why_in_the_log(python_route, monkeypatch, capsys):
    def broken() -> bool:
        kernel_switch.use_kernels(True)  # as load_kernels does before it loads anything
        raise RuntimeError("cannot cache function 'place_joints': no locator available")

    monkeypatch.setattr(planner_kernels, "load_kernels", broken)
    assert kernels_for_worker(True) is False and kernel_switch.kernels_on() is False
    assert "no locator available" in capsys.readouterr().err
