"""The planner tests' shared fixtures: a scenario's CBiRRT searches, with and without the
compiled walk (tests/planner/test_band_walk.py, test_loop_kernels.py)."""

import dataclasses
from pathlib import Path

import pytest

from hriplan.planner.constraints.binding import bind
from hriplan.planner.motion import _band_problem, _Problem
from hriplan.planner.problem import load_problem
from hriplan.planner.search.cbirrt import _Search
from hriplan.planner.search.result import Counters
from hriplan.planner.session import PlanningSession

SCENARIOS = Path(__file__).parents[2] / "benchmarks" / "scenarios"


@pytest.fixture(scope="module", params=["a_ur5_upright_box", "b_madar_handover", "a_unconstrained"])
def searches(request):
    """(the Python loop's search, the compiled walk's, a start, the joint bounds, the collision
    checker, the scenario's goal) on one scenario, inside its motion (`moving`)."""
    from hriplan.robots import kernel_switch

    before = kernel_switch.kernels_on()
    kernel_switch.use_kernels(True)
    name = request.param.replace("a_unconstrained", "a_ur5_upright_box")
    problem = load_problem(SCENARIOS / f"{name}.json")
    session = PlanningSession(problem.robot, problem.scene, problem.hands or None)
    robot, checker, group = session.robot, session.checker, problem.group or session.robot.default_group
    session.set_constraints([] if request.param == "a_unconstrained" else problem.constraints)
    specs = list(session.constraints.values())
    q0 = robot.configuration(problem.start)
    planning = _Problem(robot, checker, bind(specs, robot, checker), group, q0)
    with checker.moving(group, q0):
        compiled = _band_problem(planning, problem.options)  # the planner's own, with its walker
        assert compiled.walker is not None
        python = dataclasses.replace(compiled, walker=None)
        yield (
            _Search(python, Counters()),
            _Search(compiled, Counters()),
            q0[planning.evaluator.idx],
            python.bounds,
            checker,
            robot.configuration({**problem.start, **problem.goal.values})[planning.evaluator.idx],
        )
    kernel_switch.use_kernels(before)
