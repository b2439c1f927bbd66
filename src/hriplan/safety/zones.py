"""Keep ISO/TS 15066's minimum separation S_0 while planning, not only while timing.

At S_0 + the policy's padding the speed allowed towards a person is 0 (separation.py), so a path
that passes closer to a body part outside the person's contact regions cannot be timed: the
timing would have to stop the robot there, and refuses the path. The planner therefore keeps the
parts the planned group moves (and what they carry) out of each such capsule grown by S_0, the
padding and a little slack, so that the smooth timed motion, which rounds the planned path's
corners, stays outside them too. A part that does not move has no approach speed: it is not checked (a fixed torso next
to a standing person does not make every state invalid). Contact regions (a receiver's hand and
lower arm) get no zone: there power and force limiting caps the speed instead.
"""

from __future__ import annotations

import numpy as np

from hriplan.robots.collision import CollisionChecker, SeparationZones
from hriplan.robots.model import Robot
from hriplan.safety.separation import SeparationPolicy, kept_separation

# Beyond S_0 + padding, for the timed motion's rounding of the planned path (m); never past the start,
# which keeps at least START_CLEARANCE from its zones' surfaces.
ZONE_SLACK = 0.005
START_CLEARANCE = 1e-4


def separation_zones(
    checker: CollisionChecker, robot: Robot, policy: SeparationPolicy, group: str, q_start: np.ndarray | None
) -> SeparationZones:
    """Per person of the scene in `policy`: S_0 + padding (+ slack) around every capsule outside their
    contact regions. The slack is cut where the start already lies within it, so a start that
    the timing accepts (outside S_0 + padding) is a valid start for planning; without a start
    (None) the zones keep their whole slack (where a leave phase must end, planner/leave.py)."""
    moving = robot.moved_joints(group)
    distances: dict[str, dict[str, float]] = {}
    for name in checker.humans:
        person = policy.person(name)
        if person is None:
            continue
        s0 = kept_separation(policy, person)  # S_0 and the policy's padding
        at_start: dict[str, float] = {}
        if q_start is not None:
            pairs = checker.person_distances(q_start, name)
            moved = np.array([int(j) in moving for j in pairs.joints], dtype=bool)
            for capsule, distance in zip(np.array(pairs.capsules)[moved], pairs.distance[moved]):
                at_start[capsule] = min(at_start.get(capsule, np.inf), float(distance))
        distances[name] = {
            capsule.name: s0
            + float(np.clip(at_start.get(capsule.name, np.inf) - s0 - START_CLEARANCE, 0.0, ZONE_SLACK))
            for capsule in checker.humans[name].capsules
            if person.contact_region(capsule.name) is None
        }
    return SeparationZones(distances=distances, moving_joints=moving)
