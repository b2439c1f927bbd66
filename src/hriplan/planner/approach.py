"""How fast the robot approaches each person along a path, against the ISO/TS 15066 limit.

For every robot part moved by the planned group (and every carried object) and every capsule of
a person: the separation between them and the speed of the part's closest point towards the
person's closest point (the robot speed v_r of ISO/TS 15066), per unit of the joint velocity
given (its whole speed near a contact region, see separation.py). The allowed speed comes from
`separation.allowed_speed`; the ratio of the two bounds the
path speed. A moved part inside a person's minimum separation (allowed speed 0) is an error:
the robot would have to stand still there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from hriplan import HriplanError
from hriplan.robots.collision import CollisionChecker
from hriplan.robots.model import Robot

from .separation import PersonSeparation, SeparationPolicy, allowed_speed, minimum_separation

# Below this separation (m) the direction to the person is undefined: the part's whole speed counts.
_TOUCHING = 1e-6


@dataclass(frozen=True)
class PersonSample:
    """One person at one configuration: the binding part-capsule pair and its numbers."""

    separation: float  # the closest moved part to the person (m)
    body_separation: float  # the same, outside the person's contact regions (what S_0 applies to)
    allowed: float  # allowed speed towards the person of the binding pair (m/s)
    approach: float  # speed of the binding pair towards the person for the given joint velocity (m/s)
    scale: float  # largest factor on the joint velocity keeping every pair within its limit (inf: none)
    part: str
    capsule: str


class ApproachMonitor:
    """A robot group's approach to the people of a policy, at configurations of that group."""

    def __init__(self, robot: Robot, checker: CollisionChecker, policy: SeparationPolicy, group: str, base: np.ndarray) -> None:
        self.robot, self.checker, self.policy, self.base = robot, checker, policy, np.asarray(base, dtype=float)
        missing = [name for name in checker.humans if policy.person(name) is None]
        if missing:
            raise HriplanError(f"the separation policy has no parameters for {', '.join(missing)}")
        self.people: list[PersonSeparation] = [p for p in policy.people if p.name in checker.humans]
        model = robot.model
        self._iq = robot.group_indices(group)
        self._iv = np.array([model.joints[model.getJointId(j)].idx_v for j in robot.group_joints(group)])
        planned = {model.getJointId(j) for j in robot.group_joints(group)}
        self._moved = {j for j in range(1, model.njoints) if planned & set(_chain(model, j))}

    def full(self, x: np.ndarray) -> np.ndarray:
        q = self.base.copy()
        q[self._iq] = x
        return q

    def samples(self, x: np.ndarray, dx: np.ndarray) -> list[PersonSample]:
        """Per person (policy order), at group values `x` moving with group velocity `dx`."""
        model, data = self.robot.model, self.robot.data
        q = self.full(x)
        velocity = np.zeros(model.nv)
        velocity[self._iv] = dx
        pin.computeJointJacobians(model, data, q)
        point_velocity: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        out = []
        for person in self.people:
            best: tuple[float, float, float, str, str] | None = None  # margin, allowed, approach, part, capsule
            separation, body, scale = np.inf, np.inf, np.inf
            for pair in self.checker.person_pairs(q, person.name):
                if pair.joint not in self._moved:
                    continue
                if pair.joint not in point_velocity:
                    jac = pin.getJointJacobian(model, data, pair.joint, pin.LOCAL_WORLD_ALIGNED) @ velocity
                    point_velocity[pair.joint] = (jac[:3], jac[3:], data.oMi[pair.joint].translation.copy())
                linear, angular, origin = point_velocity[pair.joint]
                v = linear + np.cross(angular, pair.robot_point - origin)
                gap = pair.person_point - pair.robot_point
                contact = person.contact_region(pair.capsule) is not None
                whole = contact or pair.distance <= _TOUCHING
                approach = float(np.linalg.norm(v)) if whole else float(v @ gap) / pair.distance
                allowed = allowed_speed(self.policy.robot, person, pair.distance, pair.capsule)
                if allowed <= 0.0:
                    raise HriplanError(
                        f"{pair.part} passes {pair.distance:.3f} m from {person.name}/{pair.capsule}, inside the minimum "
                        f"protective separation {minimum_separation(self.policy.robot, person):.3f} m of ISO/TS 15066 "
                        f"(the robot would have to stand still there)"
                    )
                separation = min(separation, pair.distance)
                if not contact:
                    body = min(body, pair.distance)
                if approach > 0.0:
                    scale = min(scale, allowed / approach)
                if best is None or allowed - approach < best[0]:
                    best = (allowed - approach, allowed, approach, pair.part, pair.capsule)
            if best is None:
                out.append(PersonSample(np.inf, np.inf, np.inf, 0.0, np.inf, "", ""))
            else:
                out.append(PersonSample(separation, body, best[1], best[2], scale, best[3], best[4]))
        return out

    def speed_scale(self, xs: np.ndarray, dxs: np.ndarray) -> np.ndarray:
        """Per row: the largest factor on `dxs` that keeps every person's limit (inf: unbounded)."""
        return np.array([min((s.scale for s in self.samples(x, dx)), default=np.inf) for x, dx in zip(xs, dxs)])


def _chain(model: pin.Model, joint: int) -> list[int]:
    """The joint and its ancestors up to the universe."""
    chain = []
    while joint > 0:
        chain.append(joint)
        joint = model.parents[joint]
    return chain
