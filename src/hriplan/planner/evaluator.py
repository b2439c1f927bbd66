"""Constraint values and analytic Jacobians over the planned joints.

Two formulations of the same constraints:
- margins: one signed number per constraint, > 0 by how much it is violated (the validator and
  the dead-zone rows `max(margin, 0)` use them);
- equality rows: the orientation constraints made exact (the tool axis exactly on target), a
  smooth manifold that Atlas and TangentBundle spaces can chart; their tolerance band then holds
  with room to spare and the volumes are checked as validity.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence

import numpy as np
import pinocchio as pin

from hriplan.robots.model import Robot

from . import geometry as G
from .resolve import BoundConstraint
from .spec import BoxConstraint, ConeConstraint, CylinderConstraint, SphereConstraint

LWA = pin.LOCAL_WORLD_ALIGNED


def shape_sd(spec: object) -> Callable[[np.ndarray], tuple[float, np.ndarray]]:
    """The signed-distance function of a volume constraint's shape."""
    if isinstance(spec, BoxConstraint):
        return functools.partial(G.box_sd, size=spec.size)
    if isinstance(spec, SphereConstraint):
        return functools.partial(G.sphere_sd, radius=spec.radius)
    if isinstance(spec, CylinderConstraint):
        return functools.partial(G.cylinder_sd, radius=spec.radius, height=spec.height)
    if isinstance(spec, ConeConstraint):
        return functools.partial(G.cone_sd, radius=spec.radius, height=spec.height)
    raise TypeError(type(spec).__name__)


def equality_row_count(c: BoundConstraint) -> int:
    return (3, 2, 1)[len(c.free)] if c.is_orientation else 0


class ConstraintEvaluator:
    """Evaluates bound constraints for ambient vectors `x` (values of the planned group's joints)."""

    def __init__(self, robot: Robot, constraints: Sequence[BoundConstraint], group: str, base_q: np.ndarray) -> None:
        self.robot = robot
        self.model = robot.model
        self.data = robot.model.createData()  # own workspace: evaluators never share pinocchio data
        self.constraints = list(constraints)
        self.idx = robot.group_indices(group)
        self.vidx = np.array([robot.model.joints[robot.model.getJointId(j)].idx_v for j in robot.group_joints(group)])
        self.q = np.array(base_q, dtype=float)
        self.links = sorted({c.link for c in self.constraints})
        self.n = len(self.idx)
        self.n_equality = sum(equality_row_count(c) for c in self.constraints)
        self._sd = [None if c.is_orientation else shape_sd(c.spec) for c in self.constraints]
        self._sign = [1.0 if c.is_orientation or c.spec.region == "inside" else -1.0 for c in self.constraints]

    # -- kinematics ------------------------------------------------------------------------
    def full(self, x: Sequence[float]) -> np.ndarray:
        """The full configuration for ambient values `x` (the other joints stay at base_q)."""
        q = self.q.copy()
        q[self.idx] = x
        return q

    def _update(self, q: np.ndarray, jacobians: bool) -> None:
        if jacobians:
            pin.computeJointJacobians(self.model, self.data, q)
        else:
            pin.forwardKinematics(self.model, self.data, q)
        for link in self.links:
            pin.updateFramePlacement(self.model, self.data, link)

    def _jac(self, link: int) -> np.ndarray:
        return pin.getFrameJacobian(self.model, self.data, link, LWA)[:, self.vidx]

    # -- margins ---------------------------------------------------------------------------
    def _margin(self, i: int, with_grad: bool) -> tuple[float, np.ndarray | None]:
        c = self.constraints[i]
        placement = self.data.oMf[c.link]
        jac = self._jac(c.link) if with_grad else None
        if not c.is_orientation:
            rf = c.frame.rotation
            value, grad_p = self._sd[i](rf.T @ (placement.translation - c.frame.translation))
            sign = self._sign[i]
            return sign * value, (sign * (rf @ grad_p) @ jac[:3] if with_grad else None)
        angle, grad_w = self._orientation_error(c, placement.rotation)
        margin = angle - c.spec.tolerance
        grad = grad_w @ jac[3:] if with_grad else None
        if c.spec.tolerance_gradient > 0.0 and c.p_goal is not None:
            offset = placement.translation - c.p_goal
            distance = math.sqrt(float(offset @ offset))
            margin -= c.spec.tolerance_gradient * distance
            if with_grad and distance > 1e-12:
                grad = grad - c.spec.tolerance_gradient * (offset / distance) @ jac[:3]
        return margin, grad

    def _orientation_error(self, c: BoundConstraint, r_world: np.ndarray) -> tuple[float, np.ndarray]:
        """(error angle, its gradient w.r.t. the world angular velocity of the link)."""
        rf = c.frame.rotation
        r_in_frame = rf.T @ r_world
        free = c.free
        if not free:
            angle, grad_local = G.rotation_angle(c.target.T @ r_in_frame)
            return angle, r_world @ grad_local
        if len(free) == 1:
            a = free[0]
            angle, grad_frame = G.axis_angle(r_in_frame[:, a], c.target[:, a])
            return angle, rf @ grad_frame
        restricted = ({0, 1, 2} - set(free)).pop()
        twist, grad_local = G.twist_angle(c.target.T @ r_in_frame, np.eye(3)[restricted])
        sign = 1.0 if twist >= 0.0 else -1.0
        return abs(twist), sign * (r_world @ grad_local)

    def margins(self, q: np.ndarray) -> np.ndarray:
        """Per constraint: > 0 means violated by that much (m or rad), <= 0 satisfied."""
        self._update(q, jacobians=False)
        return np.array([self._margin(i, False)[0] for i in range(len(self.constraints))])

    def deadzone(self, x: Sequence[float], offset: float = 0.0) -> np.ndarray:
        """One row per constraint: max(margin + offset, 0)."""
        self._update(self.full(x), jacobians=False)
        return np.array([max(self._margin(i, False)[0] + offset, 0.0) for i in range(len(self.constraints))])

    def deadzone_jacobian(self, x: Sequence[float], offset: float = 0.0) -> np.ndarray:
        self._update(self.full(x), jacobians=True)
        rows = np.zeros((len(self.constraints), self.n))
        for i in range(len(self.constraints)):
            margin, grad = self._margin(i, True)
            if margin + offset > 0.0:
                rows[i] = grad
        return rows

    # -- equality rows (orientation made exact) ---------------------------------------------
    def equality(self, x: Sequence[float]) -> np.ndarray:
        self._update(self.full(x), jacobians=False)
        return np.concatenate([self._equality(c, False)[0] for c in self.constraints if c.is_orientation])

    def equality_jacobian(self, x: Sequence[float]) -> np.ndarray:
        self._update(self.full(x), jacobians=True)
        return np.vstack([self._equality(c, True)[1] for c in self.constraints if c.is_orientation])

    def _equality(self, c: BoundConstraint, with_grad: bool) -> tuple[np.ndarray, np.ndarray | None]:
        r_world = self.data.oMf[c.link].rotation
        rf = c.frame.rotation
        r_in_frame = rf.T @ r_world
        jac_w = self._jac(c.link)[3:] if with_grad else None
        free = c.free
        if not free:
            r_err = c.target.T @ r_in_frame
            values = pin.log3(r_err)
            return values, (pin.Jlog3(r_err) @ r_world.T @ jac_w if with_grad else None)
        if len(free) == 1:
            a = free[0]
            u = r_in_frame[:, a]
            others = [c.target[:, k] for k in range(3) if k != a]
            values = np.array([e @ u for e in others])
            grads = np.array([(rf @ G.cross(u, e)) @ jac_w for e in others]) if with_grad else None
            return values, grads
        restricted = ({0, 1, 2} - set(free)).pop()
        twist, grad_local = G.twist_angle(c.target.T @ r_in_frame, np.eye(3)[restricted])
        return np.array([twist]), ((r_world @ grad_local) @ jac_w)[None, :] if with_grad else None
