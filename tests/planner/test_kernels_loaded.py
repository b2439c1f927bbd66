"""planner/kernels.py: a long-running process loads every compiled kernel at start, so that no
request pays numba's load (or compile): after `load_kernels` (on the UR5 and MADAR), whole tasks of other
robots (MADAR's handover and peg-in-hole, the UR10 carry: people, carried objects, dynamic
tolerances) make numba load or compile nothing more. Without numba it leaves the kernels off."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from hriplan.planner.kernels import load_kernels
from hriplan.robots import kernel_switch

ROOT = Path(__file__).resolve().parents[2]
TASKS = ["handover_full_can.yaml", "peg_in_hole_supervised.yaml", "ur10_carry_upright_supervisor.yaml"]

# In a fresh process: the signatures numba holds after loading, and after planning the tasks.
PROBE = """
import json, sys
from pathlib import Path
from numba.core.registry import CPUDispatcher
from hriplan.planner.kernels import load_kernels
from numba.core.dispatcher import ObjModeLiftedWith
from hriplan.robots import certifier_kernels, mesh_pair_kernels, mesh_tree_kernels
from hriplan.planner.constraints import compiled
from hriplan.planner.search import band_kernels, loop_kernels
from hriplan.planner import path_kernels, retime_kernels, spline_kernels, timing, toppra_kernels
from hriplan.safety import approach_kernels
from hriplan.safety.approach import ApproachMonitor
from hriplan.api import PlanningSession, load_task, run_task
from hriplan.robots.free_certifier import FreeCertifier

calls = {}
def counted(owner, name):
    method = getattr(owner, name)
    def wrapper(*args, **kwargs):
        calls[name] = calls.get(name, 0) + 1
        return method(*args, **kwargs)
    setattr(owner, name, wrapper)
for owner, name in [(compiled.CompiledTerms, n) for n in ("margins", "gradients", "margins_many")] + [
    (FreeCertifier, n) for n in ("verdict", "left_over")
] + [(ApproachMonitor, "_compiled"), (loop_kernels, "searched"), (timing, "_retimed_compiled")] + [
    (toppra_kernels.Stagewise, n) for n in ("controllable", "forward")
]:
    counted(owner, name)
compile_objmode = ObjModeLiftedWith.compile
def compiled_objmode(self, *args, **kwargs):  # a block where compiled code asks Python, made anew
    known = len(self.overloads)
    entry = compile_objmode(self, *args, **kwargs)
    if len(self.overloads) > known:
        calls["objmode compiled"] = calls.get("objmode compiled", 0) + 1
    return entry
ObjModeLiftedWith.compile = compiled_objmode

def signatures():
    kernels = {**vars(certifier_kernels), **compiled._KERNELS, **vars(compiled), **vars(approach_kernels), **vars(band_kernels), **vars(loop_kernels),
               **vars(toppra_kernels), **vars(spline_kernels), **vars(retime_kernels), **vars(path_kernels),
               **vars(mesh_pair_kernels), **vars(mesh_tree_kernels)}
    return {name: len(f.signatures) for name, f in kernels.items() if isinstance(f, CPUDispatcher)}

loaded = load_kernels()
before = signatures()
calls.clear()
solved = []
for path in sys.argv[1:]:
    task = load_task(Path(path))
    solved.append(run_task(task, PlanningSession(task.robot, hands=task.hands), advance=False).solved)
print(json.dumps({"loaded": loaded, "before": before, "after": signatures(), "solved": solved, "calls": calls}))
"""


def test_after_loading_no_task_of_another_robot_makes_numba_load_anything():
    pytest.importorskip("numba")
    tasks = [str(ROOT / "examples" / name) for name in TASKS]
    run = subprocess.run([sys.executable, "-c", PROBE, *tasks], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    found = json.loads(run.stdout.splitlines()[-1])
    assert found["loaded"] is True and found["solved"] == [True, True, True]
    entries = ("verdict_one", "verdicts", "place_joints", "term_gradients", "capsule_rows")
    entries += ("fold_rows", "nearest_rows", "walk_frames", "project", "walk", "nearest", "states_margins", "search")
    entries += ("controllable", "forward")  # TOPP-RA's passes (toppra_kernels.py)
    entries += ("horner", "evaluate")  # the path it retimes (spline_kernels.py)
    entries += ("passes", "constant_acceleration", "overshooting", "samples", "worst")  # retime_kernels.py
    entries += ("knots", "deviation", "gridpoints")  # the path's preparation (path_kernels.py)
    entries += ("decide", "split", "capsule_tree")  # mesh pairs, their trees (mesh_tree_kernels.py)
    assert [name for name in entries if found["before"].get(name)] == list(entries), found["before"]
    # the tasks took the compiled routes (planning, validation, collision, TOPP-RA), and numba loaded
    # nothing for them, nor compiled a block where compiled code asks Python
    called = [
        "_compiled",
        "controllable",
        "forward",
        "left_over",
        "margins",
        "margins_many",
        "searched",
        "verdict",
    ]
    assert sorted(found["calls"]) == called, found["calls"]
    assert found["after"] == found["before"]


def test_without_numba_the_kernels_stay_off(monkeypatch):
    before = kernel_switch.kernels_on()
    try:
        with monkeypatch.context() as patched:
            patched.setitem(sys.modules, "numba", None)  # find_spec answers None: not installed
            assert load_kernels() is False and kernel_switch.kernels_on() is False
    finally:
        kernel_switch.use_kernels(before)  # numba back first: else the switch could not go on again


def test_the_module_loads_them_for_an_installation_and_says_so():
    """`python -m hriplan.planner.kernels` (the Makefile runs it after installing): exit 0, one line."""
    pytest.importorskip("numba")
    run = subprocess.run([sys.executable, "-m", "hriplan.planner.kernels"], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.startswith("hriplan: compiled kernels loaded") and len(run.stdout.splitlines()) == 1
