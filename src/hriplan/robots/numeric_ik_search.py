"""One numeric IK solve's starts (robots/numeric_ik.py) as `solve_ik` spends them: the solution
nearest the reference among the first few, a failure decided early where it can be, and a
failure message that says what is true.

Why: the first start converging is not the nearest solution a planner wants (a goal far from
its start is a long path), and a failed solve paid 31 starts and then up to three more searches
to explain itself; a task planner's `feasible` questions pay for failures."""

from __future__ import annotations

import math
from collections.abc import Iterator
from itertools import islice
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from hriplan.robots import numeric_ik
from hriplan.robots.model import Robot

if TYPE_CHECKING:
    from hriplan.robots.ik import _Arm

WIDE = 2.0 * math.pi  # rad: limits moved out this far leave a revolute joint free
PREFERRED_STARTS = 4  # the seed and 3 random starts: their solutions are ranked by distance
NEAR = 0.5  # rad (norm): the seed's solution this near the reference is taken without ranking
DIAGNOSIS_RESTARTS = 8  # per search that explains a failure (REPORT-ik.md: enough on reachable poses)


def chain(robot: Robot, arm: _Arm, widen: float = 0.0) -> numeric_ik.Chain:
    """The arm as numeric IK sees it; `widen` moves each joint limit out by that much."""
    lower, upper = robot.limits(arm.group)
    return numeric_ik.Chain(
        robot.model,
        robot.data,
        robot.frame_id(arm.tool),
        robot.group_indices(arm.group),
        robot.velocity_indices(arm.group),
        lower - widen,
        upper + widen,
    )


def reach(robot: Robot, arm: _Arm, name: str) -> float | None:
    """An upper bound on how far the tool gets from the shoulder (the first joint's origin): the
    lengths joint to joint to the tool, added up; None if a joint is not revolute or the joints
    are not listed from the base to the tool, each below the one before.

    Conservative: a revolute joint turns its child about an axis through its own origin, so the
    next joint's origin (and the tool, rigid on the last link) keeps its distance from it at every
    value; joints outside the arm stay at `base_q` during a solve. By the triangle inequality no
    configuration puts the tool farther than the sum, so a target beyond it (plus the tolerance)
    has no solution and needs no start."""
    model = robot.model
    joints = robot.description.arms[name].joints
    ids = [model.getJointId(j) for j in joints] + [model.frames[robot.frame_id(arm.tool)].parentJoint]
    if not all(model.joints[i].shortname().startswith("JointModelR") for i in ids[:-1]):
        return None
    if not all(above in _ancestors(model, below) for above, below in zip(ids, ids[1:])):
        return None
    points = [robot.frame_pose(frame, arm.base_q)[:3, 3] for frame in [*joints, arm.tool]]
    return sum(float(np.linalg.norm(b - a)) for a, b in zip(points, points[1:]))


def _ancestors(model: pin.Model, joint: int) -> set[int]:
    """The joint and every joint between it and the root."""
    found = set()
    while joint:
        found.add(joint)
        joint = model.parents[joint]
    return found


class Search:
    """The starts of one solve, counted: `candidates` yields solutions, `failure` says why there
    were none."""

    def __init__(
        self,
        robot: Robot,
        arm: _Arm,
        name: str,
        target: np.ndarray,
        axis: int | None,
        reference: np.ndarray | None,
        tolerance: float,
    ) -> None:
        self.robot, self.arm, self.name, self.target, self.axis = robot, arm, name, target, axis
        self.reference, self.tolerance = reference, tolerance
        self.starts = 0
        self._asked: dict[tuple[float, bool], np.ndarray | None] = {}  # `_found`'s answers

    def attempts(
        self, widen: float = 0.0, position_only: bool = False, restarts: int = numeric_ik.RESTARTS
    ) -> Iterator[np.ndarray | None]:
        """Each start's solution or None (`numeric_ik.attempts`), the first from the reference (or
        the middle of the limits)."""
        lower, upper = self.robot.limits(self.arm.group)
        seed = (lower + upper) / 2.0 if self.reference is None else self.reference
        arm_chain = chain(self.robot, self.arm, widen)
        return numeric_ik.attempts(
            arm_chain, self.arm.base_q, self.target, self.axis, seed, self.tolerance, restarts, position_only
        )

    def _found(self, widen: float = 0.0, position_only: bool = False) -> np.ndarray | None:
        """The first solution of a search asking less of the arm (wider limits, the position
        only), within `DIAGNOSIS_RESTARTS` restarts; each search runs once per solve."""
        if (widen, position_only) not in self._asked:
            attempts = self.attempts(widen, position_only, DIAGNOSIS_RESTARTS)
            self._asked[widen, position_only] = next((v for v in attempts if v is not None), None)
        return self._asked[widen, position_only]

    def candidates(self) -> Iterator[np.ndarray]:
        """Solutions to try in turn. With a reference, those of the first `PREFERRED_STARTS`
        starts nearest it first (analytic IK picks its nearest branch; a far goal is a long path),
        unless the seed's own is within `NEAR`; then the rest as found. After the seed's start
        fails, none if the position alone is out of reach even with the limits widened: no restart
        could succeed (the failure is decided after a few cheap starts, which its message needs
        anyway; no reachable pose of bench_ik lost, REPORT-ik.md)."""
        attempts = self._counted(self.attempts())
        first = next(attempts)
        if first is None and self._found(WIDE, position_only=True) is None:
            return
        if self.reference is None or (first is not None and np.linalg.norm(first - self.reference) <= NEAR):
            head = [first]
        else:
            head = [first, *islice(attempts, PREFERRED_STARTS - 1)]
            head.sort(key=lambda v: np.inf if v is None else float(np.linalg.norm(v - self.reference)))
        yield from (v for v in head if v is not None)
        yield from (v for v in attempts if v is not None)

    def _counted(self, attempts: Iterator[np.ndarray | None]) -> Iterator[np.ndarray | None]:
        for values in attempts:
            self.starts += 1
            yield values

    def failure(self) -> str:
        """Why no start reached the target, found by asking less of the arm: the position alone
        out of reach with the limits widened (the distance); else the joints a solution of the
        whole pose needs beyond the limits; else, the position alone being within them, the
        orientation. So that a user knows what to change, instead of a guess between "out of
        reach" and "singular"."""
        robot, arm, name, axis = self.robot, self.arm, self.name, self.axis
        distance = np.linalg.norm(self.target[:3, 3] - arm.shoulder)
        if self._found(WIDE, position_only=True) is None:
            return f"the position is out of reach: {distance:.3f} m from the shoulder of arm {name!r}"
        beyond = self._found(WIDE)
        if beyond is not None:
            lower, upper = robot.limits(arm.group)
            joints = robot.group_joints(arm.group)
            needs = ", ".join(
                f"{joints[i]} at {beyond[i]:.3f} (limits {lower[i]:.3f} to {upper[i]:.3f})"
                for i in np.flatnonzero((beyond < lower) | (beyond > upper))
            )
            if not needs:  # the wider search's start happened to lead inside the limits
                return f"its starts missed a solution within the limits, {np.round(beyond, 3).tolist()}: give it as the reference"
            return f"none within the joint limits of arm {name!r}; beyond them the pose is reached with {needs}"
        if self._found(position_only=True) is None:
            return f"the position is reached only beyond the joint limits of arm {name!r}, and not in this orientation"
        if axis is None:
            return "the position is within reach but not in this orientation: turn the goal, or free the tool's turn about one axis"
        return f"the position is within reach but not with the tool's {'xyz'[axis]} axis this way: turn the goal"


def beyond_reach(distance: float, name: str, length: float) -> str:
    """The message for a target farther than the arm's `reach`."""
    return f"the position is out of reach: {distance:.3f} m from the shoulder of arm {name!r}, which reaches at most {length:.3f} m"
