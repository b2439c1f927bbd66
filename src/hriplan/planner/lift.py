"""The short straight tool motions around a grasp: the lift after a pick, the retreat after a release.

An object standing on a table touches it, so once grasped it cannot leave in a collision-free
motion: every start would be "in collision (cup - table)". As a place ends with the object
released a clearance above its place, a pick ends with the object lifted that far straight up
(the task runner says how far): the tool rises in a straight joint-space line from the grasp to its
IK solution that much higher, nearest the grasp. While lifting, the object is not checked against what it stands on
(`AttachedObject.resting_on`); instead the lift must rise at every dense state (the object can
only move away from its support) and end clear of it.

A released object (put down, handed over, inserted) is still between the fingers, so nothing
could follow a release: the hand opens and backs away along its approach axis (the tool's -z),
the released object touched by that hand only at the first dense states, until it is clear.
Both motions are checked like any other otherwise, and timed and validated like one
(tasks/pipeline.py).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from hriplan.planner.validate import densify
from hriplan.recent import MadeFor
from hriplan.robots.collision import LISTED_WIDTH, CollisionChecker, listed_contacts
from hriplan.robots.ik import solve_ik
from hriplan.robots.model import Robot
from hriplan.robots.scene import Scene

# A straight tool motion may drift sideways this much (m) and must advance at least this much
# between dense states.
SIDEWAYS = 0.005
ADVANCE = -1e-6
STEP = 0.01  # rad, as the planner's validation
WAYPOINT = 0.02  # m between the IK solutions a straight tool motion follows
# How far a hand backs away after a release, shortest first: the first that leaves the released
# object clear of the hand, open and closed.
RETREATS = (0.06, 0.09, 0.12, 0.16)


def supports(checker: CollisionChecker, q: np.ndarray, obj: str) -> list[str]:
    """The obstacles the object `obj` touches at `q` (what it stands on, or the hand around it)."""
    return sorted({c.b if c.a == obj else c.a for c in checker.contacts(q) if obj in (c.a, c.b)})


def straight_tool_path(
    robot: Robot, checker: CollisionChecker, arm: str, q_start: np.ndarray, move: np.ndarray, what: str
) -> tuple[list[np.ndarray] | None, str]:
    """The arm's waypoints (the start first) for the tool moved by the world vector `move` from
    `q_start`: an IK solution every WAYPOINT m, each nearest the one before and valid on
    `checker`; at every state of the joint lines between them (10 mrad apart) the tool advances
    along `move` and is at most SIDEWAYS off the line. Or None and why (`what` names the target
    in the message)."""
    waypoints, why = tool_line(robot, checker, arm, q_start, move, what, {})
    if waypoints is None:
        return None, why
    why = off_line(robot, arm, move, dense_states(robot, arm, q_start, waypoints), what)
    return (None, why) if why else (waypoints, "")


# IK solutions along one straight line, by the tool's offsets from the start so far (nm): each is
# solved nearest the one before, so lines from one start in one direction that share their first
# offsets share those solutions (a retreat of 12 cm begins as one of 6 cm).
Solved = dict[tuple[int, ...], tuple[np.ndarray | None, str]]


def tool_line(
    robot: Robot,
    checker: CollisionChecker,
    arm: str,
    q_start: np.ndarray,
    move: np.ndarray,
    what: str,
    solved: Solved,
) -> tuple[list[np.ndarray] | None, str]:
    """The arm's waypoints (the start first) for the tool moved by `move` from `q_start`: an IK
    solution every WAYPOINT m, each nearest the one before and valid on `checker`, taken from
    `solved` where a line from this start along this direction on this checker found it (and
    added to it); or None and why."""
    group = robot.arm_group(arm)
    tool = robot.frame_pose(robot.tool_frame(arm), q_start)
    length = float(np.linalg.norm(move))
    waypoints, offsets = [robot.group_values(q_start, group)], ()
    for fraction in np.linspace(0.0, 1.0, max(2, int(np.ceil(length / WAYPOINT)) + 1))[1:]:
        offsets = (*offsets, round(fraction * length * 1e9))
        if offsets not in solved:
            target = tool.copy()
            target[:3, 3] += fraction * move
            ik = solve_ik(
                robot,
                arm,
                target,
                base_q=robot.configuration(waypoints[-1], group, base=q_start),
                reference=waypoints[-1],
                is_valid=lambda q: not checker.in_collision(q),
                why_invalid=lambda q: [f"collides: {c.a} - {c.b}" for c in checker.contacts(q)],
            )
            solved[offsets] = (np.asarray(ik.q, dtype=float), "") if ik.success else (None, ik.message)
        q, why = solved[offsets]
        if q is None:
            return None, f"no valid IK solution {what}: {why}"
        waypoints.append(q)
    return waypoints, ""


def dense_states(robot: Robot, arm: str, q_start: np.ndarray, waypoints: list[np.ndarray]) -> np.ndarray:
    """The configurations (N, nq) of the joint lines between the arm's `waypoints` (STEP apart),
    the other joints where `q_start` has them: the first is `q_start`'s."""
    dense = densify(waypoints, STEP)
    states = np.repeat(q_start[None], len(dense), axis=0)
    states[:, robot.group_indices(robot.arm_group(arm))] = dense
    return states


def off_line(robot: Robot, arm: str, move: np.ndarray, states: np.ndarray, what: str) -> str:
    """Why the `states` of a straight tool motion (`dense_states`) do not move the tool straight
    along `move` from the first (it must advance at every state and stay within SIDEWAYS of the
    line), or ""."""
    frame = robot.tool_frame(arm)
    tool = robot.frame_pose(frame, states[0])[:3, 3]
    direction = move / np.linalg.norm(move)
    along, drift = [], 0.0
    for q in states:
        at = robot.frame_pose(frame, q)[:3, 3] - tool
        along.append(float(at @ direction))
        drift = max(drift, float(np.linalg.norm(at - along[-1] * direction)))
    if np.diff(along).min(initial=0.0) < ADVANCE or drift > SIDEWAYS:
        return f"the straight line {what} is not straight (drifts {drift:.3f} m sideways)"
    return ""


def lift_path(
    robot: Robot, checker: CollisionChecker, arm: str, q_grasp: np.ndarray, height: float
) -> tuple[list[np.ndarray] | None, str]:
    """The arm's waypoints to `height` above the grasp, rising straight all the way (checked on
    `checker`, whose scene lets the object touch its supports), or None and why."""
    return straight_tool_path(robot, checker, arm, q_grasp, np.array([0.0, 0.0, height]), f"{height} m above the grasp")


def retreat_directions(robot: Robot, arm: str, arrival: list[np.ndarray]) -> list[tuple[str, np.ndarray]]:
    """The ways a hand may back away from where the configurations `arrival` (the released step's
    motion, the last at the release) bring it, in order: away from the palm (the tool's -z), back
    the way it came (from the last tool position at least WAYPOINT away), straight up."""
    frame = robot.tool_frame(arm)
    release = robot.frame_pose(frame, arrival[-1])
    ways = [("away from the palm", -release[:3, 2])]
    back = (
        robot.frame_pose(frame, q)[:3, 3] - release[:3, 3] for q in reversed(arrival)
    )  # from the release back: most of the motion is never asked
    came = next((v for v in back if np.linalg.norm(v) >= WAYPOINT), None)
    if came is not None:
        ways.append(("back the way it came", came / np.linalg.norm(came)))
    return [*ways, ("straight up", np.array([0.0, 0.0, 1.0]))]


def retreat_path(
    hands: Sequence[Robot],
    closed: Robot,
    arm: str,
    arrival: list[np.ndarray],
    released: str,
    touching: Scene,
    free: Scene,
) -> tuple[Robot | None, list[np.ndarray] | None, str]:
    """A retreat from the release (the last of the configurations `arrival` that brought the
    hand there): the first of the robots `hands` (the hand opened, then as it closed) whose hand
    is clear at the release but for the released object, and the arm's waypoints along the first
    of the retreat_directions and RETREATS that works: straight, valid in the `touching` scene
    (where this hand may touch the released object) at every dense state, touching `released`
    (in the `free` scene, without that allowance) only on a first stretch, and at the end clear
    of everything in the `free` scene with that hand and the hand `closed` (as the next step has
    it). Or (None, None, why each way failed)."""
    q_release, failures = arrival[-1], []
    next_start = _checker(closed, free, "free")
    for hand in hands:
        checker, untouched = _checker(hand, touching, "touching"), _checker(hand, free, "free")
        posture = hand.hand_postures.get(arm, "bare")
        if checker.in_collision(q_release):
            failures.append(f"the hand {posture} at the release collides: {_contacts(checker, q_release)}")
            continue
        for way, direction in retreat_directions(hand, arm, arrival):
            waypoints, why = _retreat_along(hand, arm, q_release, released, direction, checker, untouched, next_start)
            if waypoints is not None:
                return hand, waypoints, ""
            failures.append(f"the hand {posture}, {way}: {why}")
    return None, None, "; ".join(failures)


# The checkers retreat_path used last, by robot and scene ("touching": the released object may
# touch this hand): a re-plan asks again for the same, in a scene whose people moved and whose
# released object lies elsewhere, and a checker given that scene keeps what does not change (its
# person and distance models, the people's bodies), where a new one built everything (~20 ms).
_CHECKERS: MadeFor[CollisionChecker] = MadeFor(6)


def _checker(robot: Robot, scene: Scene, kind: str) -> CollisionChecker:
    """A checker of `robot` in `scene`: the one retreat_path used last for this robot and kind of
    scene, given `scene`, else a new one."""
    checker = _CHECKERS.get((robot,), kind)
    if checker is None:
        checker = CollisionChecker(robot, scene)
        _CHECKERS.put((robot,), checker, kind)
    else:
        checker.set_scene(scene)
    return checker


def _retreat_along(
    opened: Robot,
    arm: str,
    q_release: np.ndarray,
    released: str,
    direction: np.ndarray,
    checker: CollisionChecker,
    untouched: CollisionChecker,
    next_start: CollisionChecker,
) -> tuple[list[np.ndarray] | None, str]:
    """The first of RETREATS along `direction` that retreat_path accepts, or None and why (the
    farthest whose IK line was solved, else the first). Each is asked first what is cheapest to
    ask and most often fails: where its line ends (the shorter retreats end with the hand still
    around the object); a failure's contacts are listed only if every distance fails."""
    group, solved = opened.arm_group(arm), {}
    told: tuple[str, CollisionChecker | None, np.ndarray] | None = None  # why, and whose contacts at what q
    for distance in RETREATS:
        move, what = direction * distance, f"{distance} m away"
        waypoints, why = tool_line(opened, checker, arm, q_release, move, what, solved)
        if waypoints is None:
            told = told or (why, None, q_release)
            continue
        end = opened.configuration(waypoints[-1], group, base=q_release)
        if untouched.touches(end, released):
            told = (f"{what} the hand still touches {released}", None, end)
            continue
        if next_start.in_collision(end):
            told = (f"{what} the next step would start in collision: ", next_start, end)
            continue
        states = dense_states(opened, arm, q_release, waypoints)
        why = off_line(opened, arm, move, states, what)
        if why:
            told = told or (why, None, end)
            continue
        hit = checker.first_collision(states)  # the first colliding state, the tables asked all at once
        if hit is not None:
            told = (f"{what} it collides: ", checker, states[hit])
            continue
        touches = [untouched.touches(q, released) for q in states]
        if touches[-1] or (False in touches and True in touches[touches.index(False) :]):
            told = (f"{what} the hand {'still' if touches[-1] else 'again'} touches {released}", None, end)
            continue
        return waypoints, ""
    if told is None:
        return None, ""
    why, contacts, q = told
    return None, why + (_contacts(contacts, q) if contacts is not None else "")


def _contacts(checker: CollisionChecker, q: np.ndarray) -> str:
    return listed_contacts(checker.contacts(q), LISTED_WIDTH // 2)  # one of several failures in a message
