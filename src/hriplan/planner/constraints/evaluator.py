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
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from hriplan.planner.constraints import geometry as G
from hriplan.planner.constraints.binding import BoundConstraint
from hriplan.planner.constraints.spec import BoxConstraint, ConeConstraint, CylinderConstraint, SphereConstraint
from hriplan.robots.model import Robot

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


@dataclass(slots=True)
class _Term:
    """What the hot path needs of one constraint, precomputed (attribute reads stay cheap)."""

    bound: BoundConstraint
    link: int
    rf: np.ndarray  # constraint frame rotation (world)
    rf_t: np.ndarray
    origin: np.ndarray  # constraint frame origin (world)
    sd: Callable[[np.ndarray], tuple[float, np.ndarray]] | None  # volumes
    sign: float  # +1 inside, -1 outside
    free: tuple[int, ...]  # orientation: free axes
    target: np.ndarray | None
    restricted: np.ndarray | None  # two free axes: the restricted axis
    tolerance: float
    gradient: float

    @classmethod
    def of(cls, c: BoundConstraint) -> _Term:
        orientation = c.is_orientation
        free = tuple(c.free)
        restricted = np.eye(3)[({0, 1, 2} - set(free)).pop()] if len(free) == 2 else None
        return cls(
            bound=c,
            link=c.link,
            rf=c.frame.rotation.copy(),
            rf_t=c.frame.rotation.T.copy(),
            origin=c.frame.translation.copy(),
            sd=None if orientation else shape_sd(c.spec),
            sign=1.0 if orientation or c.spec.region == "inside" else -1.0,
            free=free,
            target=c.target,
            restricted=restricted,
            tolerance=c.spec.tolerance if orientation else 0.0,
            gradient=c.spec.tolerance_gradient if orientation else 0.0,
        )


def _volume_box(spec: object) -> tuple[list[float], list[float]]:
    """The box around a volume's solid in its frame: box and sphere centred, cylinder and cone
    standing on z in [0, height]."""
    if isinstance(spec, BoxConstraint):
        half = [size / 2.0 for size in spec.size]
        return [-h for h in half], half
    r = spec.radius
    z = (-r, r) if isinstance(spec, SphereConstraint) else (0.0, spec.height)
    return [-r, -r, z[0]], [r, r, z[1]]


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
        self._terms = [_Term.of(c) for c in self.constraints]
        self._orientations = [t for t in self._terms if t.target is not None]
        self._key: bytes | None = None  # the configuration self.data holds kinematics for
        self._has_jacobians = False

    # -- kinematics ------------------------------------------------------------------------
    def full(self, x: Sequence[float]) -> np.ndarray:
        """The full configuration for ambient values `x` (the other joints stay at base_q)."""
        q = self.q.copy()
        q[self.idx] = x
        return q

    def _update(self, q: np.ndarray, jacobians: bool) -> None:
        """Kinematics at q, computed once per configuration: OMPL asks for the rows, the
        Jacobian and the validity of the same state in turn, and each needs the same FK."""
        key = q.tobytes()
        if key == self._key and (self._has_jacobians or not jacobians):
            return
        if jacobians:
            pin.computeJointJacobians(self.model, self.data, q)
        else:
            pin.forwardKinematics(self.model, self.data, q)
        for link in self.links:
            pin.updateFramePlacement(self.model, self.data, link)
        self._key, self._has_jacobians = key, jacobians

    def _jac(self, link: int) -> np.ndarray:
        return pin.getFrameJacobian(self.model, self.data, link, LWA)[:, self.vidx]

    # -- margins ---------------------------------------------------------------------------
    def _margin(self, t: _Term, with_grad: bool) -> tuple[float, np.ndarray | None]:
        placement = self.data.oMf[t.link]
        jac = self._jac(t.link) if with_grad else None
        if t.sd is not None:
            value, grad_p = t.sd(t.rf_t @ (placement.translation - t.origin))
            return t.sign * value, (t.sign * (t.rf @ grad_p) @ jac[:3] if with_grad else None)
        angle, grad_w = self._orientation_error(t, placement.rotation)
        margin = angle - t.tolerance
        grad = grad_w @ jac[3:] if with_grad else None
        p_goal = t.bound.p_goal
        if t.gradient > 0.0 and p_goal is not None:
            offset = placement.translation - p_goal
            distance = math.sqrt(float(offset @ offset))
            margin -= t.gradient * distance
            if with_grad and distance > 1e-12:
                grad = grad - t.gradient * (offset / distance) @ jac[:3]
        return margin, grad

    def _orientation_error(self, t: _Term, r_world: np.ndarray) -> tuple[float, np.ndarray]:
        """(error angle, its gradient w.r.t. the world angular velocity of the link)."""
        r_in_frame = t.rf_t @ r_world
        if not t.free:
            angle, grad_local = G.rotation_angle(t.target.T @ r_in_frame)
            return angle, r_world @ grad_local
        if t.restricted is None:
            a = t.free[0]
            angle, grad_frame = G.axis_angle(r_in_frame[:, a], t.target[:, a])
            return angle, t.rf @ grad_frame
        twist, grad_local = G.twist_angle(t.target.T @ r_in_frame, t.restricted)
        sign = 1.0 if twist >= 0.0 else -1.0
        return abs(twist), sign * (r_world @ grad_local)

    def margins(self, q: np.ndarray) -> np.ndarray:
        """Per constraint: > 0 means violated by that much (m or rad), <= 0 satisfied."""
        self._update(q, jacobians=False)
        return np.array([self._margin(t, False)[0] for t in self._terms])

    def gradients(self, x: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
        """(margins, one gradient row per margin w.r.t. the planned joints), in one pass."""
        self._update(self.full(x), jacobians=True)
        values, grads = zip(*(self._margin(t, True) for t in self._terms))
        return np.array(values), np.array(grads)

    def deadzone(self, x: Sequence[float], offset: float = 0.0) -> np.ndarray:
        """One row per constraint: max(margin + offset, 0)."""
        self._update(self.full(x), jacobians=False)
        return np.array([max(self._margin(t, False)[0] + offset, 0.0) for t in self._terms])

    def deadzone_jacobian(self, x: Sequence[float], offset: float = 0.0) -> np.ndarray:
        self._update(self.full(x), jacobians=True)
        rows = np.zeros((len(self.constraints), self.n))
        for i, t in enumerate(self._terms):
            margin, grad = self._margin(t, True)
            if margin + offset > 0.0:
                rows[i] = grad
        return rows

    # -- equality rows (orientation made exact) ---------------------------------------------
    def equality(self, x: Sequence[float]) -> np.ndarray:
        self._update(self.full(x), jacobians=False)
        return np.concatenate([self._equality(t, False)[0] for t in self._orientations])

    def equality_jacobian(self, x: Sequence[float]) -> np.ndarray:
        self._update(self.full(x), jacobians=True)
        return np.vstack([self._equality(t, True)[1] for t in self._orientations])

    # -- banded quantities (for slack variables: each equals a slack bounded by its band) ------
    def quantities(self, x: Sequence[float]) -> np.ndarray:
        """Orientation: the equality rows' values; volumes: the link position in the frame."""
        self._update(self.full(x), jacobians=False)
        return np.concatenate([self._quantity(t, False)[0] for t in self._terms])

    def quantities_jacobian(self, x: Sequence[float]) -> np.ndarray:
        self._update(self.full(x), jacobians=True)
        return np.vstack([self._quantity(t, True)[1] for t in self._terms])

    def quantity_bounds(self, reach: float = 3.0) -> tuple[np.ndarray, np.ndarray]:
        """Boxes that hold every quantity's band: the slack variables' bounds. A dynamic
        tolerance's widest band is taken `reach` metres from the goal; outside a volume, `reach`."""
        low, high = [], []
        for t in self._terms:
            spec = t.bound.spec
            if t.target is not None:
                widest = min(t.tolerance + t.gradient * reach, math.pi)
                # one free axis: rows are sines of the tilt; otherwise angles
                bound = (math.sin(widest) if widest < math.pi / 2 else 1.0) if len(t.free) == 1 else widest
                rows = equality_row_count(t.bound)
                low += [-bound] * rows
                high += [bound] * rows
            else:
                box = ([-reach] * 3, [reach] * 3) if spec.region == "outside" else _volume_box(spec)
                low += box[0]
                high += box[1]
        return np.array(low), np.array(high)

    def _quantity(self, t: _Term, with_grad: bool) -> tuple[np.ndarray, np.ndarray | None]:
        if t.target is not None:
            return self._equality(t, with_grad)
        values = t.rf_t @ (self.data.oMf[t.link].translation - t.origin)
        return values, (t.rf_t @ self._jac(t.link)[:3] if with_grad else None)

    def _equality(self, t: _Term, with_grad: bool) -> tuple[np.ndarray, np.ndarray | None]:
        r_world = self.data.oMf[t.link].rotation
        r_in_frame = t.rf_t @ r_world
        jac_w = self._jac(t.link)[3:] if with_grad else None
        if not t.free:
            r_err = t.target.T @ r_in_frame
            values = pin.log3(r_err)
            return values, (pin.Jlog3(r_err) @ r_world.T @ jac_w if with_grad else None)
        if t.restricted is None:
            a = t.free[0]
            u = r_in_frame[:, a]
            others = [t.target[:, k] for k in range(3) if k != a]
            values = np.array([float(e @ u) for e in others])
            grads = np.array([(t.rf @ G.cross(u, e)) @ jac_w for e in others]) if with_grad else None
            return values, grads
        twist, grad_local = G.twist_angle(t.target.T @ r_in_frame, t.restricted)
        return np.array([twist]), ((r_world @ grad_local) @ jac_w)[None, :] if with_grad else None
