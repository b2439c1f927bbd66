"""mplib's side of bench_glass.py: plan the glass problems with mplib 0.2.1's constrained mode.

Runs in its own environment (mplib 0.2.1 needs numpy < 2; hriplan's pinocchio and coal need
numpy >= 2, and mplib crashes under numpy 2): `python mplib_worker.py JOBS.json RESULTS.jsonl`.
It imports neither hriplan nor the tests: bench_glass.py writes each problem as plain data (a
URDF whose meshes it can open, the SRDF, obstacles, the glass, start, goal, the upright axis)
and re-checks every path it gets back with the tests' geometry.

The constraint, as mplib's constrained-planning example writes one: f(q) = a(q) . t - 1, a the
tool axis along the glass in the world, t the upright direction; f's tolerance 1 - cos(tol) is
exactly "a within tol of t". Its Jacobian: (w_i x a) . t per joint, w_i the joint's axis in the
world (mplib's link Jacobian, angular rows).
"""

from __future__ import annotations

import json
import sys
import time

import mplib
import numpy as np
from mplib.collision_detection import fcl


def placed(shape: dict) -> fcl.CollisionObject:
    """An obstacle (box or cylinder, centred at its pose) as an FCL object for mplib's world."""
    if shape["type"] == "box":
        geometry = fcl.Box(np.array(shape["size"], dtype=float))
    else:
        geometry = fcl.Cylinder(shape["radius"], shape["height"])
    return fcl.CollisionObject(geometry, mplib.Pose(np.array(shape["pose"], dtype=float)))


def tool_axis(planner: mplib.Planner, axis: int) -> np.ndarray:
    """The tool's `axis` column in the robot's base frame (the bases here are not turned)."""
    return _link_matrix(planner)[:3, axis]


def upright(planner: mplib.Planner, axis: int, target: np.ndarray):
    """mplib's constraint function and Jacobian for "the tool's axis along `target`"."""

    def f(x, out):
        planner.robot.set_qpos(x)
        out[0] = tool_axis(planner, axis) @ target - 1.0

    def jacobian(x, out):
        planner.robot.set_qpos(x)
        a = tool_axis(planner, axis)
        full = planner.pad_move_group_qpos(x)
        jac = planner.robot.get_pinocchio_model().compute_single_link_jacobian(full, planner.move_group_link_id)
        angular = jac[3:, planner.move_group_joint_indices]
        for i in range(angular.shape[1]):
            out[i] = np.cross(angular[:, i], a) @ target

    return f, jacobian


def solve(job: dict) -> list[dict]:
    """Every run of one problem: status, seconds, the path and how many of its states mplib's
    own collision check flags."""
    planner = mplib.Planner(job["urdf"], job["move_group"], srdf=job["srdf"])
    planner.set_base_pose(mplib.Pose(np.array(job["base"], dtype=float)))
    for i, shape in enumerate(job["obstacles"]):
        planner.planning_world.add_object(f"obstacle_{i}", placed(shape))
    names = planner.user_joint_names
    start = np.array([job["start"].get(n, 0.0) for n in names])
    moved = [names[i] for i in planner.move_group_joint_indices]
    goal = start.copy()
    goal[planner.move_group_joint_indices] = [job["goal"][n] for n in moved]
    planner.robot.set_qpos(start, True)
    glass = job["glass"]
    tool = np.array(job["base"]) @ _link_matrix(planner)
    held = fcl.Cylinder(glass["radius"], glass["height"])
    planner.planning_world.add_object(
        "glass", fcl.CollisionObject(held, mplib.Pose(tool @ np.array(glass["grasp"], dtype=float)))
    )
    planner.planning_world.attach_object("glass", planner.robot.get_name(), planner.move_group_link_id)
    f, jacobian = upright(planner, job["axis"], np.array(job["target"], dtype=float))
    runs = []
    for _ in range(job["runs"]):
        began = time.perf_counter()
        result = planner.plan_qpos(
            [goal],
            start,
            planning_time=job["time_limit"],
            simplify=False,  # mplib: constrained planning does not support simplification
            constraint_function=f,
            constraint_jacobian=jacobian,
            constraint_tolerance=1.0 - np.cos(job["tolerance"]),
            time_step=0.01,
        )
        seconds = time.perf_counter() - began
        run = {"status": result["status"], "seconds": seconds, "joints": moved}
        if result["status"] == "Success":
            path = np.asarray(result["position"])
            flagged, pairs = 0, set()
            for q in path:
                full = start.copy()
                full[planner.move_group_joint_indices] = q
                planner.robot.set_qpos(full, True)
                collisions = planner.planning_world.check_collision()
                flagged += bool(collisions)
                pairs |= {
                    " - ".join(sorted((c.link_name1 or c.object_name1, c.link_name2 or c.object_name2)))
                    for c in collisions
                }
            run |= {"positions": path.tolist(), "flagged": flagged, "pairs": sorted(pairs)}
        runs.append(run)
    return runs


def _link_matrix(planner: mplib.Planner) -> np.ndarray:
    """The move group link's pose in the robot's base frame, as a 4x4 matrix."""
    pose = planner.robot.get_pinocchio_model().get_link_pose(planner.move_group_link_id)
    return pose.to_transformation_matrix()


def main() -> None:
    jobs = json.loads(open(sys.argv[1]).read())
    with open(sys.argv[2], "w") as out:
        for job in jobs:
            try:
                runs = solve(job)
            except Exception as exc:  # a model mplib cannot load: said, and the others still run
                runs = [{"status": f"mplib error: {type(exc).__name__}: {exc}".splitlines()[0]}]
            out.write(json.dumps({"name": job["name"], "runs": runs}) + "\n")
            out.flush()


if __name__ == "__main__":
    main()
