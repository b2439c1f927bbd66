"""Forward kinematics compiled with numba, for the collision certifier's inner loop.

Why: the certifier (`free_certifier.py`) places every collision part at every state it is asked
about; a call into pinocchio from Python and reading its placements back costs more than the
whole check. The robot is data: each joint's parent, placement in its parent, axis, kind and
place in q, read from the pinocchio model (any tree of one-axis revolute, continuous or
prismatic joints, as `BatchKinematics` walks them), so no robot has code of its own.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
from numba import njit

from hriplan.robots.batch_kinematics import _joint

# A joint's row in the table: placement rotation (9, row-major), translation (3), unit axis (3).
JOINT_ROW = 15
REVOLUTE, CONTINUOUS, PRISMATIC = 0, 1, 2


def joint_tables(model: pin.Model) -> tuple[np.ndarray, np.ndarray] | None:
    """Per joint (0: the world): its row (njoints, 15) and (parent, kind, idx_q) (njoints, 3);
    None if the model holds a joint of another kind (free-flyer, spherical, ...: no kernel)."""
    neutral = pin.neutral(model)
    rows, ints = np.zeros((model.njoints, JOINT_ROW)), np.zeros((model.njoints, 3), dtype=np.int64)
    rows[0, [0, 4, 8]] = 1.0
    for j in range(1, model.njoints):
        joint = _joint(model, j, model.parents[j], neutral)
        if joint is None:
            return None
        rows[j] = np.concatenate([joint.rotation.reshape(9), joint.translation, joint.axis])
        kind = PRISMATIC if not joint.turns else CONTINUOUS if joint.nq == 2 else REVOLUTE
        ints[j] = (joint.parent, kind, joint.idx_q)
    return rows, ints


@njit(cache=True, nogil=True)
def place_joints(q: np.ndarray, rows: np.ndarray, ints: np.ndarray, rotation: np.ndarray, origin: np.ndarray) -> None:
    """World frames of every joint at `q` into `rotation` (njoints, 3, 3) and `origin` (njoints, 3):
    a joint's frame is its parent's, times its placement, times its own motion (as pinocchio).
    Scalars throughout: an array made per joint cost more than the arithmetic."""
    for r in range(3):  # the world (np.eye would allocate at every call)
        origin[0, r] = 0.0
        for c in range(3):
            rotation[0, r, c] = 1.0 if r == c else 0.0
    for j in range(1, rows.shape[0]):
        p, kind, iq = ints[j, 0], ints[j, 1], ints[j, 2]
        ax, ay, az = rows[j, 12], rows[j, 13], rows[j, 14]
        if kind == PRISMATIC:
            cos, sin, slide = 1.0, 0.0, q[iq]
        elif kind == CONTINUOUS:
            cos, sin, slide = q[iq], q[iq + 1], 0.0
        else:
            cos, sin, slide = math.cos(q[iq]), math.sin(q[iq]), 0.0
        # The joint's own motion in its placement's frame, Rodrigues: cos I + sin [a]x + (1 - cos) a a^T.
        v = 1.0 - cos
        t00, t01, t02 = cos + v * ax * ax, v * ax * ay - sin * az, v * ax * az + sin * ay
        t10, t11, t12 = v * ay * ax + sin * az, cos + v * ay * ay, v * ay * az - sin * ax
        t20, t21, t22 = v * az * ax - sin * ay, v * az * ay + sin * ax, cos + v * az * az
        # Placement times motion (rotation), and the placement's translation plus the slide.
        m00 = rows[j, 0] * t00 + rows[j, 1] * t10 + rows[j, 2] * t20
        m01 = rows[j, 0] * t01 + rows[j, 1] * t11 + rows[j, 2] * t21
        m02 = rows[j, 0] * t02 + rows[j, 1] * t12 + rows[j, 2] * t22
        m10 = rows[j, 3] * t00 + rows[j, 4] * t10 + rows[j, 5] * t20
        m11 = rows[j, 3] * t01 + rows[j, 4] * t11 + rows[j, 5] * t21
        m12 = rows[j, 3] * t02 + rows[j, 4] * t12 + rows[j, 5] * t22
        m20 = rows[j, 6] * t00 + rows[j, 7] * t10 + rows[j, 8] * t20
        m21 = rows[j, 6] * t01 + rows[j, 7] * t11 + rows[j, 8] * t21
        m22 = rows[j, 6] * t02 + rows[j, 7] * t12 + rows[j, 8] * t22
        x = rows[j, 9] + (rows[j, 0] * ax + rows[j, 1] * ay + rows[j, 2] * az) * slide
        y = rows[j, 10] + (rows[j, 3] * ax + rows[j, 4] * ay + rows[j, 5] * az) * slide
        z = rows[j, 11] + (rows[j, 6] * ax + rows[j, 7] * ay + rows[j, 8] * az) * slide
        for r in range(3):
            u0, u1, u2 = rotation[p, r, 0], rotation[p, r, 1], rotation[p, r, 2]
            rotation[j, r, 0] = u0 * m00 + u1 * m10 + u2 * m20
            rotation[j, r, 1] = u0 * m01 + u1 * m11 + u2 * m21
            rotation[j, r, 2] = u0 * m02 + u1 * m12 + u2 * m22
            origin[j, r] = origin[p, r] + u0 * x + u1 * y + u2 * z
