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
from collections.abc import Sequence
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import pinocchio as pin

from hriplan.planner.constraints import geometry as G
from hriplan.planner.constraints.binding import BoundConstraint
from hriplan.planner.constraints.spec import BoxConstraint, ConeConstraint, CylinderConstraint, SphereConstraint
from hriplan.robots.kernel_switch import kernels_on
from hriplan.robots.model import Robot

if TYPE_CHECKING:
    from hriplan.planner.constraints.compiled import CompiledTerms

LWA = pin.LOCAL_WORLD_ALIGNED


def shape_code(spec: object) -> tuple[int, G.Vec]:
    """A volume constraint's shape as geometry's code and dimensions (`G.shape_distance`)."""
    if isinstance(spec, BoxConstraint):
        return G.BOX, tuple(spec.size)
    if isinstance(spec, SphereConstraint):
        return G.SPHERE, (spec.radius, 0.0, 0.0)
    if isinstance(spec, CylinderConstraint):
        return G.CYLINDER, (spec.radius, spec.height, 0.0)
    if isinstance(spec, ConeConstraint):
        return G.CONE, (spec.radius, spec.height, 0.0)
    raise TypeError(type(spec).__name__)


Rows = G.Rows
Gradient6 = tuple[float, float, float, float, float, float]  # d margin / (linear, angular) velocity, world
_times = G.times
_NOWHERE = (0.0, 0.0, 0.0)  # the goal of a fixed tolerance (`G.beyond_tolerance` reads it only to widen)


def _rows(m: np.ndarray) -> Rows:
    return tuple(tuple(row) for row in m.tolist())


class _Pose(NamedTuple):
    """A link's world placement, read from pinocchio once per state (each read copies)."""

    position: G.Vec
    rotation: Rows
    matrix: np.ndarray  # the homogeneous 4x4 (for pinocchio's log3 and quaternions)

    @classmethod
    def of(cls, placement: pin.SE3) -> _Pose:
        matrix = placement.homogeneous
        h = matrix.tolist()
        return cls((h[0][3], h[1][3], h[2][3]), (h[0][:3], h[1][:3], h[2][:3]), matrix)


class _Term:
    """What the hot path needs of one constraint, precomputed: the frame as numpy (equality
    rows, the compiled route's packing) and, when the Python route's margins first ask, as rows
    of floats (the compiled route never does: ~5 us a term, every evaluator)."""

    def __init__(self, c: BoundConstraint) -> None:
        self.bound, self.link = c, c.link
        self.rf = c.frame.rotation.copy()  # constraint frame rotation (world)
        self.rf_t = c.frame.rotation.T.copy()
        self.origin = c.frame.translation.copy()  # constraint frame origin (world)
        self.free: tuple[int, ...] = ()
        self.target: np.ndarray | None = None

    @functools.cached_property
    def frame(self) -> Rows:
        return _rows(self.rf)

    @functools.cached_property
    def frame_t(self) -> Rows:
        return _rows(self.rf_t)

    @functools.cached_property
    def origin_xyz(self) -> G.Vec:
        return tuple(self.origin.tolist())


class _Volume(_Term):
    """A volume: margin(pose, with_grad) is the signed distance, inside or outside, and its
    gradient w.r.t. the link's world (linear, angular) velocity if asked."""

    def __init__(self, c: BoundConstraint) -> None:
        super().__init__(c)
        self.shape, self.dims = shape_code(c.spec)
        self.sign = 1.0 if c.spec.region == "inside" else -1.0  # margin = sign * signed distance

    def margin(self, pose: _Pose, with_grad: bool) -> tuple[float, Gradient6 | None]:
        frame, frame_t, origin = self.frame, self.frame_t, self.origin_xyz
        value, linear = G.volume_term(
            self.shape, self.dims, self.sign, frame, frame_t, origin, pose.position, with_grad
        )
        return value, (linear + (0.0, 0.0, 0.0) if with_grad else None)


class _Orientation(_Term):
    """An orientation: margin(pose, with_grad) is the error angle beyond the tolerance (a
    dynamic tolerance widens with the distance from the goal), with its gradient as a volume's."""

    def __init__(self, c: BoundConstraint) -> None:
        super().__init__(c)
        self.free, self.target = tuple(c.free), c.target
        self.tolerance, self.gradient = c.spec.tolerance, c.spec.tolerance_gradient
        self.target_t = c.target.T.copy()
        self.axis_target = tuple(c.target[:, self.free[0]].tolist()) if len(self.free) == 1 else None
        restricted = ({0, 1, 2} - set(self.free)).pop() if len(self.free) == 2 else None
        self.restricted = None if restricted is None else tuple(np.eye(3)[restricted].tolist())
        self.error = (self._rotation, self._tilt, self._twist)[len(self.free)]

    def margin(self, pose: _Pose, with_grad: bool) -> tuple[float, Gradient6 | None]:
        angle, turn = self.error(pose, with_grad)
        p_goal = self.bound.p_goal  # set once the goal is known, after the evaluator is made
        widens = self.gradient > 0.0 and p_goal is not None  # the dynamic tolerance widens away from the goal
        gradient, goal = (self.gradient, tuple(p_goal.tolist())) if widens else (0.0, _NOWHERE)
        margin, pull = G.beyond_tolerance(angle, self.tolerance, gradient, goal, pose.position)
        return margin, (pull + turn if with_grad else None)

    def _error_rotation(self, pose: _Pose) -> np.ndarray:
        """The link's rotation from its target (no or two free axes); target^T rf^T R in this
        order: log3 near a half turn magnifies a reordering's rounding to ~1e-11."""
        return self.target_t @ (self.rf_t @ pose.matrix[:3, :3])

    # (error angle, its gradient w.r.t. the world angular velocity of the link, if asked)
    def _rotation(self, pose: _Pose, with_grad: bool) -> tuple[float, G.Vec | None]:
        angle, grad = G.rotation_angle(self._error_rotation(pose))
        return angle, (_times(pose.rotation, grad) if with_grad else None)

    def _tilt(self, pose: _Pose, with_grad: bool) -> tuple[float, G.Vec | None]:
        a, r = self.free[0], pose.rotation
        angle, grad = G.axis_angle(_times(self.frame_t, (r[0][a], r[1][a], r[2][a])), self.axis_target)
        return angle, (_times(self.frame, grad) if with_grad else None)

    def _twist(self, pose: _Pose, with_grad: bool) -> tuple[float, G.Vec | None]:
        twist, grad = G.twist_angle(self._error_rotation(pose), self.restricted)
        if not with_grad:
            return abs(twist), None
        sign = 1.0 if twist >= 0.0 else -1.0
        x, y, z = _times(pose.rotation, grad)
        return abs(twist), (sign * x, sign * y, sign * z)


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


def _slot(indices: np.ndarray) -> slice | np.ndarray:
    """A slice where the indices are consecutive (numpy's fancy indexing costs ~1 us more)."""
    listed = np.asarray(indices).tolist()  # compared as ints: numpy's comparison costs ~3 us an evaluator
    if listed and listed == list(range(listed[0], listed[0] + len(listed))):
        return slice(listed[0], listed[0] + len(listed))
    return indices


class ConstraintEvaluator:
    """Evaluates bound constraints for ambient vectors `x` (values of the planned group's joints)."""

    def __init__(self, robot: Robot, constraints: Sequence[BoundConstraint], group: str, base_q: np.ndarray) -> None:
        self.robot, self.group = robot, group
        self.model = robot.model
        self.constraints = list(constraints)
        self.idx = robot.group_indices(group)
        self.vidx = robot.velocity_indices(group)  # the robot's own (read once): 20 us less an evaluator
        self._q_slot, self._v_slot = _slot(self.idx), _slot(self.vidx)
        self.q = np.array(base_q, dtype=float)
        self.links = sorted({c.link for c in self.constraints})
        self.n = len(self.idx)
        self.n_equality = sum(equality_row_count(c) for c in self.constraints)
        self._terms = [_Orientation(c) if c.is_orientation else _Volume(c) for c in self.constraints]
        self._orientations = [t for t in self._terms if t.target is not None]
        # per link, its terms' rows (all of them, the usual case, without indexing)
        self._rows_of_link: list[tuple[int, slice | list[int]]] = [
            (
                link,
                slice(None) if len(self.links) == 1 else [i for i, c in enumerate(self.constraints) if c.link == link],
            )
            for link in self.links
        ]
        self._key: bytes | None = None  # the configuration self.data holds kinematics for
        self._has_jacobians = False
        self._poses: dict[int, _Pose] = {}
        self._compiled: CompiledTerms | bool | None = None  # made when first asked (`_route`); False: none

    @functools.cached_property
    def data(self) -> pin.Data:
        """The evaluator's own pinocchio workspace (evaluators never share one), made when the
        Python route first asks: the compiled route never does, and a plan makes two evaluators
        (~15-20 us each)."""
        return self.model.createData()

    @property
    def terms(self) -> list[_Term]:
        """Each constraint's precomputed term, in order (`compiled.py` packs them)."""
        return self._terms

    # -- kinematics ------------------------------------------------------------------------
    def full(self, x: Sequence[float]) -> np.ndarray:
        """The full configuration for ambient values `x` (the other joints stay at base_q)."""
        q = self.q.copy()
        q[self._q_slot] = x
        return q

    def full_many(self, xs: np.ndarray) -> np.ndarray:
        """`full` of every row of `xs` (N, n) at once: (N, nq)."""
        qs = np.repeat(self.q[None, :], len(xs), axis=0)
        qs[:, self._q_slot] = xs
        return qs

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
        self._poses = {link: _Pose.of(pin.updateFramePlacement(self.model, self.data, link)) for link in self.links}
        self._key, self._has_jacobians = key, jacobians

    def _jac(self, link: int) -> np.ndarray:
        return pin.getFrameJacobian(self.model, self.data, link, LWA)[:, self._v_slot]

    # -- margins ---------------------------------------------------------------------------
    def margins(self, q: np.ndarray) -> np.ndarray:
        """Per constraint: > 0 means violated by that much (m or rad), <= 0 satisfied."""
        if (route := self._route()) is not None:
            return route.margins(q)
        self._update(q, jacobians=False)
        poses = self._poses
        return np.array([t.margin(poses[t.link], False)[0] for t in self._terms])

    def margins_many(self, qs: np.ndarray) -> np.ndarray:
        """`margins` of every row of `qs` (N, nq): (N, constraints)."""
        if not self._terms:
            return np.zeros((len(qs), 0))
        if (route := self._route()) is not None:
            return route.margins_many(qs)
        return np.array([self.margins(q) for q in qs])

    def gradients(self, x: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
        """(margins, one gradient row per margin w.r.t. the planned joints), in one pass."""
        if (route := self._route()) is not None:
            return route.gradients(self.full(x))
        self._update(self.full(x), jacobians=True)
        poses = self._poses
        values, velocities = zip(*(t.margin(poses[t.link], True) for t in self._terms))
        velocities = np.array(velocities)
        rows = np.empty((len(self._terms), self.n))
        for link, which in self._rows_of_link:  # d margin / d x = (d margin / d velocity) J
            rows[which] = velocities[which] @ self._jac(link)
        return np.array(values), rows

    def _route(self) -> CompiledTerms | None:
        """The compiled route (`compiled.py`) of the terms, where there are any."""
        return self.compiled_terms() if self._terms else None

    def compiled_terms(self) -> CompiledTerms | None:
        """The terms packed for the compiled kernels (none is a valid packing), with the kernels
        on and where they cover every term and joint; else None."""
        if not kernels_on():
            return None
        if self._compiled is None:
            from hriplan.planner.constraints.compiled import CompiledTerms

            self._compiled = CompiledTerms.of(self) or False
        return self._compiled or None

    def deadzone(self, x: Sequence[float], offset: float = 0.0) -> np.ndarray:
        """One row per constraint: max(margin + offset, 0)."""
        return np.maximum(self.margins(self.full(x)) + offset, 0.0)

    def deadzone_jacobian(self, x: Sequence[float], offset: float = 0.0) -> np.ndarray:
        margins, rows = self.gradients(x)
        rows[margins + offset <= 0.0] = 0.0
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
