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

from .separation import PersonSeparation, SeparationPolicy, allowed_speeds, minimum_separation

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
        self._moved = robot.moved_joints(group)
        self._memo: dict[bytes, list[PersonSample]] = {}  # the report re-reads the timing's final check

    def full(self, x: np.ndarray) -> np.ndarray:
        q = self.base.copy()
        q[self._iq] = x
        return q

    def samples(self, x: np.ndarray, dx: np.ndarray) -> list[PersonSample]:
        """Per person (policy order), at group values `x` moving with group velocity `dx`."""
        key = np.concatenate([x, dx]).astype(float).tobytes()
        if key not in self._memo:
            self._memo[key] = self._samples(np.asarray(x, dtype=float), np.asarray(dx, dtype=float))
        return self._memo[key]

    def _samples(self, x: np.ndarray, dx: np.ndarray) -> list[PersonSample]:
        model, data = self.robot.model, self.robot.data
        q = self.full(x)
        velocity = np.zeros(model.nv)
        velocity[self._iv] = dx
        pin.computeJointJacobians(model, data, q)
        twists = {j: pin.getJointJacobian(model, data, j, pin.LOCAL_WORLD_ALIGNED) @ velocity for j in self._moved}
        return [self._person(q, person, twists) for person in self.people]

    def _person(self, q: np.ndarray, person: PersonSeparation, twists: dict[int, np.ndarray]) -> PersonSample:
        pairs = self.checker.person_pairs(q, person.name)
        rows = np.flatnonzero([j in self._moved for j in pairs.joints])
        if rows.size == 0:
            return PersonSample(np.inf, np.inf, np.inf, 0.0, np.inf, "", "")
        joints, distance = pairs.joints[rows], pairs.distance[rows]
        robot_point, person_point = pairs.robot_point[rows], pairs.person_point[rows]
        capsules = [pairs.capsules[k] for k in rows]
        twist = np.array([twists[j] for j in joints])
        origin = np.array([self.robot.data.oMi[int(j)].translation for j in joints])
        v = twist[:, :3] + np.cross(twist[:, 3:], robot_point - origin)
        contact = np.array([person.contact_region(c) is not None for c in capsules])
        whole = contact | (distance <= _TOUCHING)
        towards = np.einsum("ij,ij->i", v, person_point - robot_point) / np.maximum(distance, _TOUCHING)
        approach = np.where(whole, np.linalg.norm(v, axis=1), towards)
        allowed = allowed_speeds(self.policy.robot, person, distance, capsules)
        stopped = np.flatnonzero(allowed <= 0.0)
        if stopped.size:
            k = stopped[np.argmin(distance[stopped])]
            raise HriplanError(
                f"{pairs.parts[rows[k]]} passes {distance[k]:.3f} m from {person.name}/{capsules[k]}, inside the minimum "
                f"protective separation {minimum_separation(self.policy.robot, person):.3f} m of ISO/TS 15066 "
                f"(the robot would have to stand still there)"
            )
        binding = int(np.argmin(allowed - approach))
        closing = approach > 0.0
        scale = float(np.min(allowed[closing] / approach[closing])) if closing.any() else np.inf
        body = float(np.min(distance[~contact])) if (~contact).any() else np.inf
        return PersonSample(float(distance.min()), body, float(allowed[binding]), float(approach[binding]), scale,
                            pairs.parts[rows[binding]], capsules[binding])  # fmt: skip

    def speed_scale(self, xs: np.ndarray, dxs: np.ndarray) -> np.ndarray:
        """Per row: the largest factor on `dxs` that keeps every person's limit (inf: unbounded)."""
        return np.array([min((s.scale for s in self.samples(x, dx)), default=np.inf) for x, dx in zip(xs, dxs)])

