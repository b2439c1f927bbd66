"""Time parameterisation of a planned joint path: time-optimal under joint limits (TOPP-RA).

The planner returns a dense piecewise-linear joint path that was validated against the task
constraints. A robot cannot follow its corners at speed, so we interpolate the waypoints with a
natural cubic spline parameterised by arc length, retime the spline time-optimally with TOPP-RA
under per-joint velocity and acceleration limits (at rest at both ends), and sample it at a fixed
period. The robot follows the spline, not the polyline, so how far the spline strays from the
validated polyline is measured, reported and optionally bounded.
"""

from __future__ import annotations

import importlib
import logging
import sys
import types
from collections.abc import Callable, Sequence

import numpy as np
from pydantic import BaseModel, ConfigDict

from hriplan import HriplanError
from hriplan.files import Finite
from hriplan.planner.natural_spline import NaturalSpline
from hriplan.recent import Recent
from hriplan.robots.kernel_switch import kernels_on
from hriplan.safety.separation import SPEED_LIMIT_SLACK


class _Deferred(types.ModuleType):
    """Stands in for a module while TOPP-RA is imported: a name read from it is a _Later, or the
    real module's once that is loaded."""

    def __getattr__(self, name: str):
        if name.startswith("__"):  # the import system's questions (__path__, __spec__): no such thing
            raise AttributeError(name)
        real = sys.modules.get(self.__name__)
        return _Later(self.__name__, name) if real is None or real is self else getattr(real, name)


class _Later:
    """A module's name, fetched from the real module when first called or read into."""

    def __init__(self, module: str, name: str) -> None:
        self._module, self._name = module, name

    def _real(self):
        return getattr(importlib.import_module(self._module), self._name)

    def __call__(self, *args, **kwargs):
        return self._real()(*args, **kwargs)

    def __getattr__(self, name: str):
        return getattr(self._real(), name)


# What TOPP-RA imports at module level for what hriplan never calls: plots (matplotlib.pyplot, in
# toppra.algorithm.algorithm and toppra.parametrizer), scipy's splines (its own path classes) and
# the ECOS solver's sparse matrices. They cost a `plan` process about 1.1 s CPU
# (benchmarks/REPORT-startup.md); hriplan's path is planner/natural_spline.py.
_DEFERRED = ("matplotlib", "matplotlib.pyplot", "scipy", "scipy.interpolate", "scipy.sparse")


def _import_toppra() -> types.ModuleType:
    """TOPP-RA, with the modules of _DEFERRED that are not loaded yet deferred: while toppra is
    imported, and only then, they are _Deferred stand-ins in sys.modules, so toppra's names from
    them are _Later and load the real module on first use (toppra's plots still work). (Another
    thread importing one of them during those milliseconds would get a stand-in: this module is
    imported with the planning session, before any plot or scipy use.)"""
    stand_ins = {name: _Deferred(name) for name in _DEFERRED if name not in sys.modules}
    for name, stand_in in stand_ins.items():  # `import matplotlib.pyplot as plt` reads the parent's attribute
        parent, _, child = name.rpartition(".")
        if parent in stand_ins:
            setattr(stand_ins[parent], child, stand_in)
    sys.modules.update(stand_ins)
    try:
        import toppra
        import toppra.algorithm
        import toppra.constraint
    finally:
        for name, stand_in in stand_ins.items():
            if sys.modules.get(name) is stand_in:
                del sys.modules[name]
    return toppra


toppra = _import_toppra()

# TOPP-RA logs every solve at INFO and a failure at WARNING; we report failures ourselves.
logging.getLogger("toppra").setLevel(logging.ERROR)

# Consecutive waypoints closer than this (rad, every joint) are one waypoint: a near-zero knot
# interval would make the spline's curvature, and so the retimed motion, blow up there.
_DUPLICATE_TOL = 1e-9
# Segments longer than this (rad) get collinear knots inserted: the spline's ringing around a
# corner scales with the neighbouring knot spacing, and this keeps it at dense input's scale.
_MAX_KNOT_SPACING = 0.05
# Spline samples per knot interval when measuring its deviation from the polyline.
_DEVIATION_SAMPLES = 16
_DEVIATION_FRACTIONS = np.linspace(0.0, 1.0, _DEVIATION_SAMPLES + 1)[1:-1]  # where inside each interval
# TOPP-RA gridpoints: at most this far apart (arc length, rad; durations come out within ~0.5% of
# a 30000-point grid's), at least this many; the cap bounds the runtime (~25-50 us per gridpoint)
# on pathological input, which the final limit check then catches.
_MAX_GRID_SPACING = 0.04
_MIN_GRIDPOINTS = 100
_MAX_GRIDPOINTS = 20_000
# Relative overshoot of the velocity / acceleration limits tolerated between TOPP-RA gridpoints,
# where TOPP-RA does not check them; grid intervals that exceed it are split, at most this often.
_GRID_VELOCITY_TOL = 5e-4
_GRID_ACCELERATION_TOL = 5e-3
_REFINEMENTS = 3
_GRID_TOLERANCES = np.array([_GRID_VELOCITY_TOL, _GRID_ACCELERATION_TOL, _MAX_GRID_SPACING])  # as the kernels take them
_GRID_COUNTS = np.array([_MIN_GRIDPOINTS, _MAX_GRIDPOINTS], dtype=float)
# Relative overshoot of the limits allowed in the returned samples (see `time_parameterize`).
_VELOCITY_SLACK = 1e-3
_ACCELERATION_SLACK = 5e-2
# A path-speed limit (people nearby) is sampled this densely along the path (arc length, rad);
# each gridpoint takes the smallest value within one grid spacing of it. Samples exceeding it
# by more than the slack make the limit tighter by the overshoot, at most this often.
_SPEED_LIMIT_SPACING = 0.02
_SPEED_LIMIT_RETRIES = 3

SpeedScale = Callable[[np.ndarray, np.ndarray], np.ndarray]
"""(positions k x n, joint velocities k x n) -> per row the largest factor on those velocities
that keeps a limit (inf: none); on path derivatives q'(s) that is the largest path speed."""


class TimedPath(BaseModel):
    """A sampled joint trajectory (like trajectory_msgs/JointTrajectory): row i is at times[i].
    Every number finite (validation refuses the others; `time_parameterize` checks its arrays), so
    a file's points are built around these lists as they are (`trajectory.timed_points`)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    times: list[Finite]
    positions: list[list[Finite]]
    velocities: list[list[Finite]]
    accelerations: list[list[Finite]]
    path_deviation: float
    """Max per-joint distance (rad) of the followed spline from the input polyline."""
    rests: int = 0
    """Waypoints inside the motion where it comes to rest (`joined`)."""


def time_parameterize(
    waypoints: np.ndarray,
    velocity_limits: np.ndarray,
    acceleration_limits: np.ndarray,
    *,
    velocity_scale: float = 1.0,
    sample_dt: float = 0.01,
    max_deviation: float | None = None,
    speed_scale: SpeedScale | None = None,
) -> TimedPath:
    """Retime the piecewise-linear path `waypoints` (m x n) time-optimally, at rest at both ends.

    `velocity_scale` in (0, 1] scales both the velocity and the acceleration limits. Samples are
    `sample_dt` apart, plus the exact final time. Raises HriplanError on bad input, when the
    spline strays more than `max_deviation` (rad, any joint) from the polyline, or when TOPP-RA
    fails. TOPP-RA enforces the limits at its gridpoints only, so the grid is refined (at most
    _REFINEMENTS times) until between gridpoints too velocity exceeds the scaled limit by at most
    0.05% and acceleration by at most 0.5%; the returned samples must then stay within the scaled
    limits +0.1% (velocity) and +5% (acceleration), else HriplanError.

    `speed_scale` (speed and separation near people) adds a path-speed limit that varies along
    the path, given to TOPP-RA as varying joint velocity limits; the returned samples keep it
    within 1%, else HriplanError. It may raise HriplanError itself (the path cannot be timed).
    """
    q, vmax, amax = _validated(
        waypoints, velocity_limits, acceleration_limits, velocity_scale, sample_dt, max_deviation
    )
    knots, s = _knots(q)
    path = NaturalSpline(s, knots)

    deviation = _deviation(path, s, knots)
    if max_deviation is not None and deviation > max_deviation:
        raise HriplanError(
            f"the interpolating spline strays {deviation:.4g} rad from the waypoint path (max_deviation "
            f"{max_deviation:.4g}); pass denser or smoother waypoints"
        )

    limit = None if speed_scale is None else _path_speed_limit(path, s, speed_scale)
    factor = 1.0
    for _ in range(_SPEED_LIMIT_RETRIES + 1):
        trajectory = _retimed(path, s, vmax, amax, None if limit is None else (limit, factor))
        duration = float(trajectory.path_interval[1])
        _refuse_not_finite(duration)
        # Samples on the sample_dt grid strictly before the end, then the end itself; a grid time
        # within a millionth of a period of the end counts as the end, so the last step is not ~0.
        count = int(np.ceil(duration / sample_dt - 1e-6))
        times = np.append(sample_dt * np.arange(count), duration)
        positions, velocities, accelerations = trajectory.samples(times)
        _refuse_not_finite(positions, velocities, accelerations)
        if speed_scale is None:
            break
        worst = float(np.min(speed_scale(positions, velocities)))
        if worst >= 1.0 - SPEED_LIMIT_SLACK:
            break
        factor *= 0.99 * worst
    else:
        raise HriplanError(f"the timed motion exceeds the speed allowed near people by {100 * (1 / worst - 1):.1f}%")
    _check_limits(velocities, vmax, 1.0 + _VELOCITY_SLACK, "velocity")
    _check_limits(accelerations, amax, 1.0 + _ACCELERATION_SLACK, "acceleration")
    # Not validated again: `tolist` of finite float64 arrays gives lists (of lists) of finite
    # floats, `deviation` is a float (about 0.2 ms a re-plan's two motions saved;
    # tests/planner/test_timed_built.py).
    return TimedPath.model_construct(
        times=times.tolist(),
        positions=positions.tolist(),
        velocities=velocities.tolist(),
        accelerations=accelerations.tolist(),
        path_deviation=deviation,
    )


def _refuse_not_finite(*values: float | np.ndarray) -> None:
    """A TimedPath is built from these without validation, and no limit check reads a NaN (its
    comparisons are false): refuse one here, in one line, before anything uses it."""
    if not all(np.isfinite(v).all() for v in values):
        raise HriplanError("the timed motion holds a number that is not finite (NaN or infinite)")


def at_rest(position: Sequence[float]) -> TimedPath:
    """The motion that does not move (its start is its goal): one sample at t = 0, at rest."""
    zero = [0.0] * len(position)
    return TimedPath(
        times=[0.0], positions=[list(position)], velocities=[zero], accelerations=[zero], path_deviation=0.0
    )


def joined(parts: Sequence[TimedPath]) -> TimedPath:
    """Motions timed one after the other, each from rest to rest (each starts where the one before
    ends), as one: a motion that stops at the junctions, the junction sampled once. One part is
    itself (its lists not copied)."""
    if len(parts) == 1:
        return parts[0]
    first, *rest = parts
    times, rows = list(first.times), [list(first.positions), list(first.velocities), list(first.accelerations)]
    for part in rest:
        times += [times[-1] + t for t in part.times[1:]]
        for row, values in zip(rows, (part.positions, part.velocities, part.accelerations)):
            row += values[1:]
    # Built from the parts' floats and ints: not validated again (test_timed_built.py).
    return TimedPath.model_construct(
        times=times,
        positions=rows[0],
        velocities=rows[1],
        accelerations=rows[2],
        path_deviation=max(p.path_deviation for p in parts),
        rests=sum(p.rests for p in parts) + len(parts) - 1,
    )


def _path_speed_limit(path: NaturalSpline, s: np.ndarray, speed_scale: SpeedScale) -> tuple[np.ndarray, np.ndarray]:
    """(arc lengths, path-speed limit there), sampled every _SPEED_LIMIT_SPACING along the path."""
    at = np.linspace(s[0], s[-1], int(np.ceil((s[-1] - s[0]) / _SPEED_LIMIT_SPACING)) + 1)
    return at, np.asarray(speed_scale(path(at), path(at, 1)), dtype=float)


def _retimed(
    path: NaturalSpline,
    s: np.ndarray,
    vmax: np.ndarray,
    amax: np.ndarray,
    limit: tuple[tuple[np.ndarray, np.ndarray], float] | None,
):
    """TOPP-RA under the joint limits (and a path-speed limit times a factor), grid refined."""
    if limit is None and kernels_on():
        return _retimed_compiled(path, s, vmax, amax)
    constraints = _joint_limits(vmax, amax)
    if limit is not None:
        (at, sd_max), factor = limit
        constraints.append(_PathSpeedLimit(path, vmax, at, factor * sd_max))
    grid = _gridpoints(path, s, vmax, amax)
    for refinement in range(_REFINEMENTS + 1):
        algorithm = _TOPPRA(
            constraints,
            path,
            gridpoints=grid,
            solver_wrapper="seidel",
        )
        trajectory = algorithm.compute_trajectory(0.0, 0.0)
        if trajectory is None:
            raise _untimed(algorithm.problem_data.return_code)
        overshooting = _overshooting(path, grid, algorithm.problem_data.sd_vec, vmax, amax)
        if not overshooting.any() or refinement == _REFINEMENTS or len(grid) > _MAX_GRIDPOINTS:
            break
        grid = _subdivided(grid, np.where(overshooting, 4, 1))
    return trajectory


def _retimed_compiled(path: NaturalSpline, s: np.ndarray, vmax: np.ndarray, amax: np.ndarray):
    """`_retimed` under the joint limits alone with the kernels on: each try of a grid one
    compiled call for TOPP-RA (its rows from the path, its passes, its verdict) and one for the
    check between gridpoints (`retime_kernels.py`, the same bits as toppra's objects and
    `_overshooting`), without toppra's constraint, solver and algorithm objects (~0.6 ms a UR5
    timing). The grid is checked as toppra checks it (`_TOPPRA.__init__`)."""
    from hriplan.planner import retime_kernels as kernels  # numba: imported with the kernels on

    knots, velocity, acceleration = path.s, path.horner(1), path.horner(2)
    codes = toppra.algorithm.ParameterizationReturnCode
    grid = _gridpoints(path, s, vmax, amax)
    for refinement in range(_REFINEMENTS + 1):
        if grid[0] != knots[0] or grid[-1] != knots[-1]:
            raise ValueError("Invalid manually supplied gridpoints.")
        if np.any(grid[1:] <= grid[:-1]):
            raise ValueError("Bad input gridpoints.")
        xs = np.empty(len(grid))
        verdict = kernels.passes(knots, velocity, acceleration, grid, vmax, amax, xs)
        if verdict != kernels.OK:
            raise _untimed(codes.FailUncontrollable if verdict == kernels.UNCONTROLLABLE else codes.ErrUnknown)
        sd, ts, us = np.empty(len(grid)), np.empty(len(grid)), np.empty(len(grid) - 1)
        kernels.constant_acceleration(grid, xs, sd, ts, us)
        overshooting = np.empty(len(grid) - 1, dtype=np.bool_)
        tolerances = (_GRID_VELOCITY_TOL, _GRID_ACCELERATION_TOL)
        kernels.overshooting(knots, velocity, acceleration, grid, sd, vmax, amax, *tolerances, overshooting)
        if not overshooting.any() or refinement == _REFINEMENTS or len(grid) > _MAX_GRIDPOINTS:
            break
        grid = _subdivided(grid, np.where(overshooting, 4, 1))
    return _ConstantAcceleration.made(path, grid, sd, ts, us)


def _untimed(code) -> HriplanError:
    """The error for TOPP-RA's failure `code` (its ParameterizationReturnCode)."""
    return HriplanError(
        f"TOPP-RA found no time parameterisation within the joint limits ({code.value}); "
        "the path may be too sharply curved"
    )


class _ConstantAcceleration(toppra.parametrizer.ParametrizeConstAccel):
    """toppra's trajectory of constant path acceleration between gridpoints, its set-up and
    its evaluation at many times in numpy passes with the same operations as its per-point
    Python loops (the same bits): they took ~2 ms a timing (three evaluations at every sample)."""

    @classmethod
    def made(
        cls, path: NaturalSpline, grid: np.ndarray, speeds: np.ndarray, ts: np.ndarray, us: np.ndarray
    ) -> _ConstantAcceleration:
        """The trajectory toppra's set-up makes from `grid` and `speeds`, given what it would
        compute (`retime_kernels.constant_acceleration`: the times `ts` at the gridpoints and
        the path accelerations `us` between them) rather than computing it in numpy."""
        made = cls.__new__(cls)
        made._path, made._ss, made._velocities, made._xs = path, grid, speeds, speeds**2
        made._ts, made._us = ts, us
        return made

    def _process_parametrization(self) -> None:
        ds, speeds = np.diff(self._ss), self._velocities
        self._us = 0.5 * np.diff(self._xs) / ds
        self._ts = np.concatenate([[0.0], np.cumsum(2 * ds / (speeds[:-1] + speeds[1:]))])

    def _eval_params(self, ts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        ts = np.asarray(ts, dtype=float)
        index = np.minimum(np.searchsorted(self._ts, ts, side="right") - 1, len(self._us) - 1)
        dt, us, speeds = ts - self._ts[index], self._us[index], self._velocities[index]
        return self._ss[index] + dt * speeds + 0.5 * dt**2 * us, speeds + dt * us, us

    def samples(self, ts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities and accelerations at the times `ts` (an array): `self(ts, 0)`,
        `self(ts, 1)` and `self(ts, 2)` (toppra's products, the same bits) from one evaluation of
        the path parameters, not three; with the kernels on one compiled call on hriplan's
        spline (`retime_kernels.samples`)."""
        if kernels_on() and isinstance(self._path, NaturalSpline):
            from hriplan.planner import retime_kernels  # numba: imported with the kernels on

            times, path = np.ascontiguousarray(ts, dtype=float), self._path
            positions, velocities, accelerations = (np.empty((len(times), path.dof)) for _ in range(3))
            horner = (path.horner(0), path.horner(1), path.horner(2))
            retime_kernels.samples(
                self._ts,
                self._us,
                self._velocities,
                self._ss,
                path.s,
                horner,
                times,
                positions,
                velocities,
                accelerations,
            )
            return positions, velocities, accelerations
        ss, vs, us = self._eval_params(ts)
        d1 = self._path(ss, 1)
        velocities = np.multiply(d1, vs[:, np.newaxis])
        accelerations = np.multiply(self._path(ss, 2), vs[:, np.newaxis] ** 2) + np.multiply(d1, us[:, np.newaxis])
        return self._path(ss), velocities, accelerations


_NOT_FOUND = np.array([np.nan, np.nan])


class _TOPPRA(toppra.algorithm.TOPPRA):
    """TOPP-RA with its two passes (controllable sets backwards, then the greedy forward pass)
    driving its own seidel solver with the same calls, in the same order, on the same numbers as
    toppra 0.6's `compute_parameterization`, so the same bits; without the per-stage arrays,
    NaN scans and logging around each call, which cost about as much as the solver itself
    (~4 us a call, two calls a stage per pass). With the kernels on (`kernels_on()`) the solver
    is toppra's ported to numba and each pass is one compiled call (`toppra_kernels.py`, the same
    bits; a solver put in its place, as tests do, is driven stage by stage as toppra's); the
    timing then takes it under a path-speed limit only (joint limits alone: `_retimed_compiled`). Its
    trajectory is toppra's constant path acceleration between gridpoints, evaluated in numpy
    (`_ConstantAcceleration`)."""

    def __init__(self, constraints: list, path: object, gridpoints: np.ndarray, solver_wrapper: str = "seidel") -> None:
        """toppra's set-up with its seidel solver, made here: toppra's first asks which solvers
        are installed (two searches of sys.path, ~0.3 ms a path) even when told which to use."""
        if solver_wrapper != "seidel":
            raise ValueError(f"hriplan's TOPP-RA passes drive the seidel solver, not {solver_wrapper!r}")
        # toppra's ParameterizationAlgorithm set-up, its check of the gridpoints in one numpy
        # comparison (its loop over them: ~0.1 ms a timing)
        self.constraints, self.path = constraints, path
        self._problem_data = toppra.algorithm.algorithm.ParameterizationData()
        interval = path.path_interval
        if interval[0] != gridpoints[0] or interval[1] != gridpoints[-1]:
            raise ValueError("Invalid manually supplied gridpoints.")
        self.gridpoints, self._problem_data.gridpoints = np.array(gridpoints), np.array(gridpoints)
        self._N = len(gridpoints) - 1  # stages; gridpoints: N + 1
        if np.any(self.gridpoints[1:] <= self.gridpoints[:-1]):
            raise ValueError("Bad input gridpoints.")
        if kernels_on():  # the same solver compiled, each pass one call (planner/toppra_kernels.py)
            from hriplan.planner.toppra_kernels import Stagewise

            self.solver_wrapper = Stagewise(self.constraints, self.path, self.gridpoints, solve_lp1d=True)
        else:
            self.solver_wrapper = toppra.solverwrapper.seidelWrapper(
                self.constraints, self.path, self.gridpoints, solve_lp1d=True
            )
        self.parametrizer = _ConstantAcceleration

    def _compiled(self):
        """The solver if it runs whole passes compiled (`toppra_kernels.Stagewise`), else None."""
        kernels, solver = sys.modules.get("hriplan.planner.toppra_kernels"), self.solver_wrapper
        return solver if kernels is not None and type(solver) is kernels.Stagewise else None

    def compute_parameterization(self, sd_start, sd_end, return_data=False):
        if sd_end < 0 or sd_start < 0:
            raise toppra.exceptions.BadInputVelocities(f"negative path velocities: ({sd_start}, {sd_end})")
        data, solver, stages = self._problem_data, self.solver_wrapper, self._N
        controllable = self._controllable(sd_end**2)
        x, small, controlled = sd_start**2, toppra.constants.SMALL, not np.isnan(controllable).any()
        if controlled:
            data.K = controllable
        if not controlled or x + small < controllable[0, 0] or controllable[0, 1] + small < x:
            data.return_code = toppra.algorithm.ParameterizationReturnCode.FailUncontrollable
            return (None, None, None, controllable) if return_data else (None, None, None)
        tiny, max_tries = toppra.constants.TINY, toppra.constants.MAX_TRIES
        compiled = self._compiled()
        if compiled is not None:
            xs, us = compiled.forward(float(x), controllable, tiny, max_tries)
            return self._parameterized(xs, us, controllable, return_data)
        solve, deltas, bounds = solver.solve_stagewise_optim, solver.get_deltas().tolist(), controllable.tolist()
        xs, us = [float(x)] + [0.0] * stages, [0.0] * stages
        objective = np.zeros(solver.get_no_vars())
        objective[1] = -1.0
        tries, i = 0, 0
        solver.setup_solver()
        while i < stages:
            low, high = bounds[i + 1]
            objective[0] = -2 * deltas[i]
            x = xs[i]
            found = _NOT_FOUND if x != x else solve(i, None, objective, x, x, low, high)
            if found[0] != found[0]:  # NaN: toppra lowers x slightly and tries again
                if tries == max_tries:
                    xs[i + 1 :] = [np.nan] * (stages - i)
                    break
                xs[i], tries = max(x - tiny, 0.999 * x), tries + 1
                continue
            us[i], tries = found[0], 0
            reached = x + 2 * deltas[i] * us[i]
            xs[i + 1] = min(high, max(low, max(reached - tiny, 0.9999 * reached)))
            i += 1
        solver.close_solver()
        return self._parameterized(xs, us, controllable, return_data)

    def _parameterized(self, xs, us, controllable: np.ndarray, return_data: bool):
        """toppra's ending of `compute_parameterization` on the squared speeds `xs` and path
        accelerations `us` (lists or arrays) of the forward pass."""
        data, stages = self._problem_data, self._N
        data.sd_vec, data.sdd_vec = np.sqrt(xs), np.array(us, dtype=float)
        v_vec = np.zeros((stages, self.solver_wrapper.get_no_vars() - 2))  # the seidel solver has no further variables
        codes = toppra.algorithm.ParameterizationReturnCode
        data.return_code = codes.ErrUnknown if np.isnan(data.sd_vec).any() else codes.Ok
        return (data.sdd_vec, data.sd_vec, v_vec, controllable) if return_data else (data.sdd_vec, data.sd_vec, v_vec)

    def _controllable(self, x_end: float) -> np.ndarray:
        """The controllable sets of squared path speed (stages + 1, 2), ending at `x_end`; filled
        from the end back to the first NaN (not controllable, or badly conditioned), as toppra's.
        The bounds pass between the solver's calls as Python floats (numpy's scalars, rows and
        NaN checks cost as much as the solver here)."""
        solver, stages = self.solver_wrapper, self._N
        compiled = self._compiled()
        if compiled is not None:
            return compiled.controllable(x_end)
        solve, nan = solver.solve_stagewise_optim, np.nan
        upward = np.zeros(solver.get_no_vars())
        upward[0], upward[1] = 1e-9, -1.0
        downward = -upward
        low = high = float(x_end)
        sets = [(low, high)]
        solver.setup_solver()
        for i in range(stages - 1, -1, -1):
            upper = solve(i, None, upward, nan, nan, low, high)[1]
            lower = solve(i, None, downward, nan, nan, low, high)[1]
            low, high = 0.0 if lower < 0 else lower, upper
            sets.append((low, high))
            if lower != lower or upper != upper:  # NaN
                break
        else:
            solver.close_solver()
        filled = np.zeros((stages + 1, 2))
        filled[stages + 1 - len(sets) :] = sets[::-1]
        return filled


# The joint-limit constraints made lately, by limits (`_joint_limits`).
_JOINT_LIMITS: Recent[bytes, list] = Recent(8)


def _joint_limits(vmax: np.ndarray, amax: np.ndarray) -> list:
    """TOPP-RA's joint velocity and acceleration constraints for these limits, the ones made last
    for them if any: making them formats every limit into a description string (~0.7 ms a pair,
    twice a re-plan), and TOPP-RA only reads them (its `compute_constraint_params`)."""
    key = vmax.tobytes() + amax.tobytes()
    made = _JOINT_LIMITS.get(key)
    if made is None:
        made = [
            toppra.constraint.JointVelocityConstraint(vmax),
            toppra.constraint.JointAccelerationConstraint(
                amax, discretization_scheme=toppra.constraint.DiscretizationType.Interpolation
            ),
        ]
        _JOINT_LIMITS.put(key, made)
    return list(made)


class _PathSpeedLimit(toppra.constraint.JointVelocityConstraintVarying):
    """TOPP-RA's vlim(s): joint j within |q'_j(s)| times the smallest path-speed limit within a
    grid spacing of s (so the limit holds between gridpoints too), and within vmax_j. The 1e-9
    keeps joints with q'_j ~ 0 feasible; the joint with the largest |q'_j| binds the path speed.

    Computed for all gridpoints in one numpy pass: TOPP-RA's own class calls vlim once per
    gridpoint from Python (about a thousand calls per re-plan). The rest is TOPP-RA's
    `compute_constraint_params`, on its own helper."""

    def __init__(self, path: NaturalSpline, vmax: np.ndarray, at: np.ndarray, sd_max: np.ndarray) -> None:
        """TOPP-RA's set-up of the class without its call of vlim at s = 0 to learn the joint count
        (a path evaluation and a `limits` pass, ~25 us a timing): that is len(vmax)."""
        self._path, self._vmax, self._at, self._sd_max = path, vmax, at, sd_max
        toppra.constraint.LinearConstraint.__init__(self)
        self.dof, self.vlim_func = len(vmax), lambda s: self.limits(np.array([s]))[0]
        self._format_string = "    Varying Velocity limit: \n"

    def limits(self, s: np.ndarray) -> np.ndarray:
        """vlim at arc lengths `s`: (len(s), dof, 2), lower and upper."""
        at, sd_max = self._at, self._sd_max  # `at` ascending
        first = np.searchsorted(at, s - _MAX_GRID_SPACING, side="left")  # the window: at[first:end]
        end = np.searchsorted(at, s + _MAX_GRID_SPACING, side="right")
        rows = first[:, None] + np.arange(max(int(np.max(end - first, initial=0)), 1))  # a few samples each
        cap = np.where(rows < end[:, None], sd_max[np.minimum(rows, len(at) - 1)], np.inf).min(axis=1)
        cap = np.where(end > first, cap, np.interp(s, at, sd_max))
        upper = np.minimum(self._vmax, np.abs(self._path(s, 1)) * np.minimum(cap, 1e6)[:, None] + 1e-9)  # 1e6: inf
        return np.stack([-upper, upper], axis=2)

    def compute_constraint_params(self, path, gridpoints):
        if path.dof != self.get_dof():
            raise ValueError(f"wrong dimension: constraint dof {self.get_dof()} != path dof {path.dof}")
        _, _, bound = toppra._CythonUtils._create_velocity_constraint_varying(
            path(gridpoints, 1), self.limits(np.asarray(gridpoints))
        )
        xbound = np.array(bound)
        xbound[:, 0] = bound[:, 1]
        xbound[:, 1] = -bound[:, 0]
        return None, None, None, None, None, None, xbound


def _validated(
    waypoints: np.ndarray,
    velocity_limits: np.ndarray,
    acceleration_limits: np.ndarray,
    velocity_scale: float,
    sample_dt: float,
    max_deviation: float | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Checked inputs as float arrays: waypoints without duplicates, and the scaled limits."""
    q = np.asarray(waypoints, dtype=float)
    if q.ndim != 2 or q.shape[0] < 2 or q.shape[1] < 1:
        raise HriplanError(f"waypoints must be an (m x n) array with m >= 2, got shape {q.shape}")
    if not np.all(np.isfinite(q)):
        raise HriplanError("waypoints contain NaN or infinite values")
    if not 0.0 < velocity_scale <= 1.0:
        raise HriplanError(f"velocity_scale must be in (0, 1], got {velocity_scale}")
    if not (np.isfinite(sample_dt) and sample_dt > 0.0):
        raise HriplanError(f"sample_dt must be positive, got {sample_dt}")
    if max_deviation is not None and not max_deviation >= 0.0:
        raise HriplanError(f"max_deviation must be non-negative, got {max_deviation}")
    n = q.shape[1]
    limits = []
    for name, values in (("velocity_limits", velocity_limits), ("acceleration_limits", acceleration_limits)):
        limit = np.asarray(values, dtype=float)
        if limit.shape != (n,):
            raise HriplanError(f"{name} must have shape ({n},) to match the waypoints, got {limit.shape}")
        if not np.all(np.isfinite(limit) & (limit > 0.0)):
            raise HriplanError(f"{name} must be finite and positive, got {limit.tolist()}")
        limits.append(limit * velocity_scale)

    distinct = q[np.concatenate([[True], np.max(np.abs(np.diff(q, axis=0)), axis=1) > _DUPLICATE_TOL])]
    if len(distinct) < 2:
        raise HriplanError("waypoints do not move: all are the same configuration")
    distinct[-1] = q[-1]  # if the final waypoint was a dropped near-duplicate, still stop there
    return distinct, limits[0], limits[1]


def _knots(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The spline's knots (`_densified(q)`) and their arc lengths from 0; with the kernels on
    one compiled call (`path_kernels.knots`, the same bits)."""
    if kernels_on():
        from hriplan.planner import path_kernels  # numba: imported with the kernels on

        return path_kernels.knots(q, _MAX_KNOT_SPACING)
    knots = _densified(q)
    return knots, np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(knots, axis=0), axis=1))])


def _densified(q: np.ndarray) -> np.ndarray:
    """The same polyline with collinear knots inserted so no segment exceeds _MAX_KNOT_SPACING."""
    return _subdivided(q, np.ceil(np.linalg.norm(np.diff(q, axis=0), axis=1) / _MAX_KNOT_SPACING))


def _subdivided(points: np.ndarray, pieces: np.ndarray) -> np.ndarray:
    """`points` (k, ...) with segment i split into max(1, pieces[i]) equal parts."""
    pieces = np.maximum(1, pieces).astype(int)
    segment = np.repeat(np.arange(len(pieces)), pieces)
    step = np.arange(len(segment)) - (np.cumsum(pieces) - pieces)[segment]  # 0 .. pieces - 1 in each segment
    fraction = (step / pieces[segment]).reshape((-1,) + (1,) * (points.ndim - 1))
    return np.concatenate([points[segment] + fraction * (points[segment + 1] - points[segment]), points[-1:]])


def _deviation(path: NaturalSpline, s: np.ndarray, knots: np.ndarray) -> float:
    """Max per-joint |spline - polyline| over a fine sampling of every knot interval.

    Both are parameterised by the same arc length, so this compares points at equal parameter:
    an upper bound on the distance from the spline to the polyline. With the kernels on one
    compiled call (`path_kernels.deviation`, the same bits).
    """
    if kernels_on():
        from hriplan.planner import path_kernels  # numba: imported with the kernels on

        return path_kernels.deviation(path.s, knots, path.horner(0), _DEVIATION_FRACTIONS)
    fraction = _DEVIATION_FRACTIONS
    at = s[:-1, None] + np.diff(s)[:, None] * fraction
    linear = knots[:-1, None, :] + fraction[None, :, None] * np.diff(knots, axis=0)[:, None, :]
    linear -= path(at.ravel()).reshape(linear.shape)  # |spline - polyline|: the same bits negated
    return float(np.abs(linear, out=linear).max())


def _gridpoints(path: NaturalSpline, s: np.ndarray, vmax: np.ndarray, amax: np.ndarray) -> np.ndarray:
    """Initial TOPP-RA gridpoints, placed so that `_overshooting` rarely finds anything to refine.

    Between gridpoints TOPP-RA keeps the path acceleration u constant and x = sd^2 linear in s.
    Inside a knot interval (spline q''' constant) joint velocity q' sd then bends by about
    |q'''| sd h^2 / 8 over a grid spacing h, and joint acceleration q' u + q'' x by about
    5 |q'''| |u| h^2 / 8 (taking |u| <= max amax); h keeps both near the grid tolerances. At a
    knot q''' jumps, kinking the acceleration by |jump| x, up to |jump| x h / 4 off the chord: at
    tight corners that is large, so those knots are gridpoints themselves. sd is bounded by the
    velocity limits and, as |q''| x <= |acceleration| on an arc-length path, by the acceleration
    limits. The count follows path length and curvature, not the number of waypoints. With the
    kernels on one compiled call (`path_kernels.gridpoints`, the same bits).
    """
    if kernels_on():
        from hriplan.planner import path_kernels  # numba: imported with the kernels on

        return path_kernels.gridpoints(
            path.s,
            path.horner(1),
            path.horner(2),
            vmax,
            amax,
            float(np.linalg.norm(amax)),
            _GRID_TOLERANCES,
            _GRID_COUNTS,
        )
    h = np.diff(s)
    d1, d2 = path(s, 1), path(s, 2)
    jerk = np.diff(d2, axis=0) / h[:, None]  # q''' per knot interval
    x = np.minimum(
        np.min((vmax / np.maximum(np.abs(d1), 1e-12)) ** 2, axis=1),
        np.linalg.norm(amax) / np.maximum(np.linalg.norm(d2, axis=1), 1e-12),
    )  # bound on x = sd^2 at each knot
    speed = np.sqrt(np.maximum(x[:-1], x[1:]))[:, None]  # per knot interval
    bend = np.abs(jerk) * np.maximum(  # relative bend per h^2, over the grid tolerance
        speed / (8 * vmax * _GRID_VELOCITY_TOL), 5 * amax.max() / (8 * amax * _GRID_ACCELERATION_TOL)
    )
    spacing = np.minimum(_MAX_GRID_SPACING, 1.0 / np.sqrt(np.maximum(np.max(bend, axis=1), 1e-12)))
    cells = np.concatenate([[0.0], np.cumsum(h / spacing)])  # grid cells from the start to each knot
    cells *= np.clip(cells[-1], _MIN_GRIDPOINTS, _MAX_GRIDPOINTS) / cells[-1]
    kink = np.max(np.abs(np.diff(jerk, axis=0)) / amax, axis=1) * x[1:-1] * np.maximum(spacing[:-1], spacing[1:])
    marks = np.concatenate([[0], 1 + np.flatnonzero(kink / 4 > _GRID_ACCELERATION_TOL), [len(s) - 1]])
    return np.interp(_subdivided(cells[marks], np.ceil(np.diff(cells[marks]))), cells, s)


def _overshooting(
    path: NaturalSpline, grid: np.ndarray, sd: np.ndarray, vmax: np.ndarray, amax: np.ndarray
) -> np.ndarray:
    """Grid intervals where the retimed motion exceeds a limit by more than the grid tolerances.

    Evaluates TOPP-RA's solution (constant path acceleration per interval) at 1/4, 1/2 and 3/4 of
    each interval, where the bends described in `_gridpoints` peak.
    """
    x = sd**2
    u = np.diff(x) / (2 * np.diff(grid))
    offset = np.diff(grid)[:, None] * np.array([0.25, 0.5, 0.75])
    xs = np.maximum(x[:-1, None] + 2 * u[:, None] * offset, 0.0)[..., None]
    at = (grid[:-1, None] + offset).ravel()
    d1 = path(at, 1).reshape(xs.shape[:2] + (-1,))
    d2 = path(at, 2).reshape(d1.shape)
    velocity = np.max(np.abs(d1) * np.sqrt(xs) / vmax, axis=(1, 2))
    acceleration = np.max(np.abs(d2 * xs + d1 * u[:, None, None]) / amax, axis=(1, 2))
    return (velocity > 1 + _GRID_VELOCITY_TOL) | (acceleration > 1 + _GRID_ACCELERATION_TOL)


def _check_limits(values: np.ndarray, limits: np.ndarray, slack: float, what: str) -> None:
    """Raise if a sampled |value| exceeds its joint's limit by more than `slack` (relative); with
    the kernels on the largest ratio is found in one compiled call (`retime_kernels.worst`)."""
    if kernels_on():
        from hriplan.planner import retime_kernels  # numba: imported with the kernels on

        largest, sample, joint = retime_kernels.worst(values, limits)
    else:
        ratio = np.abs(values) / limits
        sample, joint = np.unravel_index(np.argmax(ratio), ratio.shape)
        largest = ratio[sample, joint]
    if largest > slack:
        raise HriplanError(
            f"time parameterisation exceeds the {what} limit of joint {joint} by "
            f"{100 * (largest - 1):.2f}% at sample {sample}; the waypoint path may be too jagged (smooth or shortcut it)"
        )
