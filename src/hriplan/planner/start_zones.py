"""The people's separation zones around a start (safety/zones.py), made once for the two that ask.

A step asks twice, one right after the other, for the same start: the leave check (does the
start lie in someone's S_0? planner/leave.py) and the plan that follows it (planner/motion.py).
Each measured every robot part against every person's capsules (~2.5 ms a re-plan); the second
now gets the first's zones while nothing they depend on changed: the checker and its scene (where
the people stand, what is carried), the policy, the group and the start.
"""

from __future__ import annotations

import numpy as np

from hriplan.robots.collision import CollisionChecker, SeparationZones
from hriplan.robots.model import Robot
from hriplan.safety.separation import SeparationPolicy
from hriplan.safety.zones import separation_zones

# The last zones made, with what they were made from (the checker and robot themselves).
_LAST: list[tuple[CollisionChecker, Robot, object, SeparationPolicy, str, bytes, SeparationZones]] = []


def start_zones(
    checker: CollisionChecker, robot: Robot, policy: SeparationPolicy | None, group: str, q_start: np.ndarray
) -> SeparationZones | None:
    """`separation_zones` of the people in `checker`'s scene for `group` from `q_start`, or None
    without a policy or people; the last ones made if made from the same."""
    if policy is None or not checker.humans:
        return None
    start = np.asarray(q_start, dtype=float).tobytes()
    if _LAST:
        held, by, scene, was, moved, at, zones = _LAST[0]
        same_world = held is checker and by is robot and scene == checker.scene
        if same_world and at == start and moved == group and was == policy:
            return zones
    zones = separation_zones(checker, robot, policy, group, q_start)
    _LAST[:] = [(checker, robot, checker.scene, policy, group, start, zones)]
    return zones
