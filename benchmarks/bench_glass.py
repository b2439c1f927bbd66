"""Carry a glass upright, free to spin about vertical: the 20 problems of benchmarks/glass/ planned
by hriplan (CBiRRT, its default; with --ompl also OMPL's RRTConnect on the projected space) and by mplib
0.2.1's constrained mode, every path re-checked by the tests' own geometry.

Run: PYTHONPATH=src .venv/bin/python benchmarks/bench_glass.py [--seeds N] [--time-limit S] [--ompl]
     [--only PROBLEM ...] [--no-mplib] [--mplib-python PATH] [--report PATH]

Per problem, planner and seed: hriplan plans, validates and times the motion (ISO/TS 15066 speed
limits near the people, as `hriplan solve` does); mplib plans with its OMPL projection planner
and the constraint written as its example writes one (benchmarks/glass/mplib_worker.py, in its
own environment: mplib 0.2.1 needs numpy < 2, hriplan numpy >= 2). Every solution is then
re-checked at states <= 0.01 rad apart by tests/independent.py (pinocchio on the URDF, coal on
its meshes, the orientation error by its own formula): the worst tilt of the glass, the least
clearance of the moving links and the glass from the obstacles, the least distance of any link
from a person's keep-out cylinder; for hriplan's timed motions near a person also the speed
towards them against ISO/TS 15066's limits, by the formulas written there. mplib's paths are
timed by hriplan's ISO/TS 15066 timing too, so their cycle times compare.
Writes benchmarks/REPORT-glass.md (the tables and the command) unless --report says elsewhere.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hriplan.files import load_model
from hriplan.planner.motion import MotionResult
from hriplan.planner.outcome import Status
from hriplan.planner.problem import PlanningProblem, load_problem
from hriplan.planner.session import PlanningSession
from hriplan.robots.descriptions.registry import DATA, description_of
from hriplan.robots.robot_file import RobotFile, resolve_file
from hriplan.safety.policy import default_policy

ROOT = Path(__file__).resolve().parents[1]
GLASS = ROOT / "benchmarks" / "glass"
sys.path.insert(0, str(ROOT / "tests"))
from independent import check_path, trajectory_speed_margins  # noqa: E402  (the tests' geometry)

# hriplan's planners: name -> the options that select it (planner/options.py).
PLANNERS = {
    "hriplan CBiRRT": {"planner": "CBiRRT", "space": "projected", "formulation": "deadzone"},
    "hriplan RRTConnect (OMPL, projected)": {"planner": "RRTConnect", "space": "projected", "formulation": "deadzone"},
}
MPLIB = "mplib 0.2.1 (OMPL projected)"
MPLIB_VENV = ROOT / ".venv-mplib"
MPLIB_SETUP = f"python3 -m venv {MPLIB_VENV.name} && {MPLIB_VENV.name}/bin/pip install 'numpy<2' mplib==0.2.1"


@dataclass
class Run:
    """One plan of one problem and what the independent re-check found."""

    problem: str
    planner: str
    status: str
    seconds: float = float("nan")
    solved: bool = False
    valid: bool = False
    tilt: float = float("nan")  # worst angle of the glass from vertical (rad)
    clearance: float = float("nan")  # m, least over the path; <= 0 a collision
    keep_out: float = float("nan")  # m, least distance of a link from a keep-out volume
    speed: float | None = None  # m/s, worst ISO/TS 15066 margin towards a person (hriplan only)
    length: float = float("nan")  # rad, joint-space length of the path
    cycle: float = float("nan")  # s, the motion timed by hriplan's ISO/TS 15066 timing
    breaches: list[str] = field(default_factory=list)
    note: str = ""


def path_length(positions: np.ndarray) -> float:
    return float(np.sum(np.linalg.norm(np.diff(positions, axis=0), axis=1)))


def tolerance_of(problem: PlanningProblem) -> float:
    return next(c.tolerance for c in problem.constraints.constraints if c.type == "orientation")


def recheck(run: Run, problem: PlanningProblem, joints: list[str], positions: np.ndarray) -> None:
    """Fill in what the tests' geometry finds along the path."""
    check = check_path(problem, joints, positions)
    run.tilt = max(check.orientation.values())
    run.clearance, run.keep_out = check.clearance[0], check.keep_out[0]
    run.breaches = check.breaches(
        {c.id: c.tolerance for c in problem.constraints.constraints if c.type == "orientation"}
    )
    run.valid = not run.breaches
    run.length = path_length(positions)


def hriplan_runs(problem: PlanningProblem, planners: list[str], seeds: int, time_limit: float) -> list[Run]:
    session = PlanningSession(problem.robot, problem.scene, problem.hands or None)
    session.set_constraints(problem.constraints)
    policy = default_policy(problem.robot, problem.scene.humans, problem.roles)
    runs = []
    for planner in planners:
        for seed in range(1, seeds + 1):
            options = problem.options.model_copy(update={**PLANNERS[planner], "seed": seed, "time_limit": time_limit})
            began = time.perf_counter()
            result = session.plan(problem.start, problem.goal, options, problem.group, safety=policy)
            run = Run(problem.name, planner, str(result.status), time.perf_counter() - began)
            if result.solved:
                trajectory = result.trajectory
                run.solved, run.cycle = True, trajectory.report.duration
                recheck(run, problem, trajectory.joint_names, np.array([p.positions for p in trajectory.points]))
                if problem.scene.humans:
                    run.speed, _gap = trajectory_speed_margins(trajectory, policy, padding=0.05, factor=0.95)
                    if run.speed < -1e-3:
                        run.valid = False
                        run.breaches.append(f"faster towards a person than ISO/TS 15066 allows by {-run.speed:.3f} m/s")
            runs.append(run)
    return runs


def srdf_of(robot: str) -> Path | None:
    """The SRDF file the robot's robot file names (mplib needs one), or None."""
    source = description_of(robot).source or DATA / f"{robot}.yaml"
    spec = load_model(source, RobotFile)
    if spec.srdf is None:
        return None
    folder = Path(source).parent
    packages = {name: (folder / path).resolve() for name, path in spec.packages.items()}
    return resolve_file(spec.srdf, packages, folder, "SRDF file")


def mplib_urdf(robot: str, folder: Path) -> Path:
    """The robot's URDF for mplib: its mesh paths relative to the file (mplib reads an absolute
    path as one under the URDF's folder)."""
    text = description_of(robot).urdf()
    for mesh in sorted(set(part.split('"')[0] for part in text.split('filename="')[1:])):
        text = text.replace(f'filename="{mesh}"', f'filename="{os.path.relpath(mesh, folder)}"')
    path = folder / f"{robot}.urdf"
    path.write_text(text)
    return path


def mplib_job(problem: PlanningProblem, folder: Path, runs: int, time_limit: float) -> dict | None:
    """The problem as plain data for mplib_worker.py, or None if the robot has no SRDF."""
    srdf = srdf_of(problem.robot)
    if srdf is None:
        return None
    description = description_of(problem.robot)
    upright = next(c for c in problem.constraints.constraints if c.type == "orientation")
    arm = next(a for a in description.arms.values() if a.tool_frame == upright.target_link)
    axis = "xyz".index(upright.free_axes[0])
    (xyz, rpy), base = description.base_pose, np.eye(4)
    assert rpy == (0.0, 0.0, 0.0), "mplib_worker.py takes the tool axis in the base frame: an unturned base"
    base[:3, 3] = xyz
    obstacles = [o.shape.model_dump() | {"pose": o.pose.matrix().tolist()} for o in problem.scene.obstacles]
    for c in problem.constraints.constraints:  # each keep-out cylinder, an obstacle to mplib
        if c.type == "cylinder" and c.keep_out_all_links:
            person = next(h for h in problem.scene.humans if h.name == c.frame.entity.split("/")[0])
            at = np.eye(4)
            at[:3, 3] = (*person.position, c.height / 2)
            obstacles.append({"type": "cylinder", "radius": c.radius, "height": c.height, "pose": at.tolist()})
    glass = problem.scene.attached[0]
    return {
        "name": problem.name,
        "urdf": str(mplib_urdf(problem.robot, folder)),
        "srdf": str(srdf),
        "move_group": arm.tool_frame,
        "base": base.tolist(),
        "obstacles": obstacles,
        "glass": {"radius": glass.shape.radius, "height": glass.shape.height, "grasp": glass.grasp.matrix().tolist()},
        "start": problem.start,
        "goal": problem.goal.values,
        "axis": axis,
        "target": upright.target.rotation()[:, axis].tolist(),
        "tolerance": upright.tolerance,
        "runs": runs,
        "time_limit": time_limit,
    }


def mplib_runs(problems: list[PlanningProblem], python: Path, runs: int, time_limit: float) -> tuple[list[Run], str]:
    """mplib's runs on every problem whose robot has an SRDF, each re-checked as hriplan's; and
    a note on what could not run."""
    if not python.exists():
        return [], f"mplib not run: no {python} (set it up with `{MPLIB_SETUP}`)"
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        jobs = [j for p in problems if (j := mplib_job(p, folder, runs, time_limit)) is not None]
        (folder / "jobs.json").write_text(json.dumps(jobs))
        worker = [str(python), str(GLASS / "mplib_worker.py"), str(folder / "jobs.json"), str(folder / "out.jsonl")]
        done = subprocess.run(worker, capture_output=True, text=True)
        lines = (folder / "out.jsonl").read_text().splitlines() if (folder / "out.jsonl").exists() else []
    answered = [json.loads(line) for line in lines]
    note = "" if done.returncode == 0 else f"mplib's worker exited {done.returncode} after {len(answered)} problem(s)"
    by_name = {p.name: p for p in problems}
    out = []
    for answer in answered:
        problem = by_name[answer["name"]]
        for raw in answer["runs"]:
            run = Run(problem.name, MPLIB, raw["status"], raw.get("seconds", float("nan")))
            if raw["status"] == "Success":
                run.solved = True
                positions = np.array(raw["positions"])
                recheck(run, problem, raw["joints"], positions)
                pairs = ", ".join(raw["pairs"][:4]) + (", ..." if len(raw["pairs"]) > 4 else "")
                run.note = f"{problem.name}: {raw['flagged']} of {len(positions)} states" + (
                    f" ({pairs})" if pairs else ""
                )
                run.cycle = iso_cycle(problem, raw["joints"], positions)
            out.append(run)
    return out, note


def iso_cycle(problem: PlanningProblem, joints: list[str], positions: np.ndarray) -> float:
    """A path timed by hriplan's ISO/TS 15066 timing (NaN where hriplan's own validation of the
    timed path refuses it)."""
    session = PlanningSession(problem.robot, problem.scene, problem.hands or None)
    session.set_constraints(problem.constraints)
    group = problem.group or session.robot.default_group
    motion = MotionResult(
        status=Status.SOLVED, group=group, joint_names=joints, start=problem.start, path=positions.tolist()
    )
    policy = default_policy(problem.robot, problem.scene.humans, problem.roles)
    result = session.time(motion, problem.options, safety=policy)
    return result.trajectory.report.duration if result.solved else float("nan")


def _f(value: float | None, digits: int = 3) -> str:
    return "-" if value is None or not np.isfinite(value) else f"{value:.{digits}f}"


def _median(values: list[float]) -> float | None:
    """The median of the finite values, None without one."""
    finite = [v for v in values if np.isfinite(v)]
    return float(np.median(finite)) if finite else None


def summary_rows(runs: list[Run], planners: list[str]) -> list[str]:
    rows = []
    for planner in planners:
        mine = [r for r in runs if r.planner == planner]
        if not mine:
            continue
        solved = [r for r in mine if r.solved]
        times = np.array([r.seconds for r in solved]) if solved else np.array([np.nan])
        collided = sum(any(b.startswith("collision") for b in r.breaches) for r in solved)
        tilted = sum(any(b.startswith("glass_upright") for b in r.breaches) for r in solved)
        rows.append(
            f"| {planner} | {len(mine)} | {len(solved)} | {sum(r.valid for r in mine)} | {collided} | {tilted} | "
            f"{_f(float(np.median(times)), 2)} | {_f(float(np.percentile(times, 90)), 2)} | "
            f"{_f(max((r.tilt for r in solved), default=None), 4)} | "
            f"{_f(min((r.clearance for r in solved), default=None), 4)} | "
            f"{_f(_median([r.length for r in solved]), 2)} | "
            f"{_f(_median([r.cycle for r in solved]), 2)} |"
        )
    return rows


def problem_rows(runs: list[Run], problems: list[PlanningProblem]) -> list[str]:
    rows = []
    for p in problems:
        for planner in dict.fromkeys(r.planner for r in runs):
            mine = [r for r in runs if r.problem == p.name and r.planner == planner]
            if not mine:
                continue
            solved = [r for r in mine if r.solved]
            speeds = [r.speed for r in solved if r.speed is not None]
            rows.append(
                f"| {p.name} | {tolerance_of(p)} | {planner} | {len(solved)}/{len(mine)} | "
                f"{sum(r.valid for r in mine)}/{len(mine)} | "
                f"{_f(_median([r.seconds for r in solved]), 2)} | "
                f"{_f(max((r.tilt for r in solved), default=None), 4)} | "
                f"{_f(min((r.clearance for r in solved), default=None), 4)} | "
                f"{_f(min((r.keep_out for r in solved), default=None))} | "
                f"{_f(min(speeds, default=None))} | "
                f"{_f(_median([r.length for r in solved]), 2)} | "
                f"{_f(_median([r.cycle for r in solved]), 2)} |"
            )
    return rows


def report(runs: list[Run], problems: list[PlanningProblem], command: str, note: str, seconds: float) -> str:
    planners = [*PLANNERS, MPLIB]
    failures = sorted({f"{r.planner} on {r.problem}: {r.status}" for r in runs if not r.solved})
    broken = [f"{r.planner} on {r.problem}: {'; '.join(r.breaches)}" for r in runs if r.solved and not r.valid]
    flagged = sorted(r.note for r in runs if r.note)
    lines = [
        "# Carry a glass upright, free to spin about vertical",
        "",
        f"`{command}` ({seconds:.0f} s, load average {os.getloadavg()[0]:.1f} at the end).",
        "",
        "The 20 problems of `benchmarks/glass/` (`make_glass.py` writes them): UR5, Panda and MADAR, in open",
        "space, between shelf levels, in clutter and beside a person (keep-out cylinder, ISO/TS 15066 speed",
        "limits); the glass within 0.05 rad of vertical (0.01 rad for the `_tight` ones), free about vertical.",
        "`valid` is the verdict of the tests' own geometry (`tests/independent.py`: pinocchio on the URDF, coal",
        "on its meshes) at states <= 0.01 rad apart: tilt within the tolerance, no moving link or the glass",
        "touching an obstacle, no link in a keep-out volume, and for hriplan's timed motions near a person",
        "no speed towards them beyond ISO/TS 15066's (padding 0.05 m, factor 0.95).",
        "Collide, tilt > tol: solved runs the re-check finds colliding, tilted beyond the tolerance.",
        "Time: wall seconds of a solved run (hriplan: plan, validate, time; mplib: `plan_qpos`, with its",
        "TOPP). Tilt: the worst angle of the glass from vertical over all solved runs (rad). Clearance: the",
        "least (m; <= 0 a collision). Path: joint-space length (rad). Cycle: the motion timed by hriplan's",
        "ISO/TS 15066 timing (mplib's paths too, so the times compare; `-` where hriplan refuses to time one).",
        'What the numbers mean: docs/benchmarks.md, section "Carry a glass upright, free to spin about vertical".',
        "",
        "| planner | runs | solved | valid | collide | tilt > tol | median s | p90 s | worst tilt | least clearance | median path | median cycle s |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
        *summary_rows(runs, planners),
        "",
        "Per problem (tol: the tolerance in rad; keep-out and speed margin in m and m/s, `-` without a person):",
        "",
        "| problem | tol | planner | solved | valid | median s | worst tilt | least clearance | keep-out | speed margin | path | cycle s |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
        *problem_rows(runs, problems),
        "",
    ]
    if note:
        lines += [note, ""]
    if failures:
        lines += ["Unsolved runs:", "", *[f"- {f}" for f in failures], ""]
    if broken:
        lines += ["Solved runs the re-check refuses:", "", *[f"- {b}" for b in broken], ""]
    if flagged:
        lines += [
            "States of mplib's returned paths that mplib's own collision check (`check_collision`) flags, and the pairs:",
            "",
            *[f"- {f}" for f in flagged],
            "",
        ]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=1, help="runs per problem and planner (default 1)")
    parser.add_argument("--time-limit", type=float, default=5.0, help="seconds per plan (default 5)")
    parser.add_argument("--only", nargs="*", default=[], help="only these problems (file names without .json)")
    parser.add_argument(
        "--ompl", action="store_true", help="also OMPL's RRTConnect on the projected space (slow: it mostly times out)"
    )
    parser.add_argument("--no-mplib", action="store_true", help="leave mplib out")
    parser.add_argument("--mplib-python", type=Path, default=MPLIB_VENV / "bin" / "python")
    parser.add_argument("--report", type=Path, default=ROOT / "benchmarks" / "REPORT-glass.md")
    args = parser.parse_args()
    began = time.perf_counter()
    paths = [p for p in sorted(GLASS.glob("*.json")) if not args.only or p.stem in args.only]
    problems = [load_problem(p) for p in paths]
    runs: list[Run] = []
    planners = list(PLANNERS) if args.ompl else list(PLANNERS)[:1]
    for problem in problems:
        mine = hriplan_runs(problem, planners, args.seeds, args.time_limit)
        runs += mine
        print(
            problem.name,
            " ".join(f"{r.planner.split()[1]}:{'valid' if r.valid else r.status}:{r.seconds:.2f}s" for r in mine),
            flush=True,
        )
    note = "mplib left out (--no-mplib)" if args.no_mplib else ""
    if not args.no_mplib:
        found, note = mplib_runs(problems, args.mplib_python, args.seeds, args.time_limit)
        runs += found
    command = "PYTHONPATH=src .venv/bin/python benchmarks/bench_glass.py " + " ".join(sys.argv[1:])
    text = report(runs, problems, command.strip(), note, time.perf_counter() - began)
    args.report.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
