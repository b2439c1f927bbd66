"""The robot's joints as the compiled forward kinematics reads them: the whole model for the
certifier (`certifier_kernels.place_joints`), a walked chain with its velocities for
`BatchKinematics` (`certifier_kernels.walk_frames`).

Why: the certifier (`free_certifier.py`) places every collision part at every state it is asked
about; a call into pinocchio from Python and reading its placements back costs more than the
whole check. The robot is data: each joint's parent, placement in its parent, axis, kind and
place in q, read from the pinocchio model (any tree of one-axis revolute, continuous or
prismatic joints, as `BatchKinematics` walks them), so no robot has code of its own.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from hriplan.recent import Recent
from hriplan.robots.batch_kinematics import _Joint, _joint
from hriplan.robots.certifier_kernels import CONTINUOUS, JOINT_ROW, PRISMATIC, REVOLUTE

Tables = tuple[np.ndarray, np.ndarray]
# The tables of the last few models, each with a copy of its model: found again only for a model
# equal to that copy (pinocchio compares every field, ~4 us), so a model changed in place gets
# its own. Every constraint evaluator asks (a re-plan makes two, ~0.5 ms each for MADAR).
_KEPT: Recent[int, tuple[pin.Model, Tables | None]] = Recent(8)


def joint_tables(model: pin.Model) -> Tables | None:
    """Per joint (0: the world): its row (njoints, 15) and (parent, kind, idx_q) (njoints, 3);
    None if the model holds a joint of another kind (free-flyer, spherical, ...: no kernel).
    The caller's own arrays (copies of those kept)."""
    kept = _KEPT.get(id(model))
    if kept is None or not kept[0] == model:
        kept = (pin.Model(model), _tables(model))
        _KEPT.put(id(model), kept)
    return None if kept[1] is None else (kept[1][0].copy(), kept[1][1].copy())


def _tables(model: pin.Model) -> Tables | None:
    """`joint_tables` made from the model's joints."""
    neutral = pin.neutral(model)
    joints = [_joint(model, j, model.parents[j], neutral) for j in range(1, model.njoints)]
    if any(joint is None for joint in joints):
        return None
    rows, ints, _ = _walk_rows(joints, parents=[joint.parent for joint in joints])
    return rows, ints


def walk_tables(walk: list[_Joint]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A chain `BatchKinematics` walks, as `certifier_kernels.walk_frames` reads it: the world
    first, then per joint its row, (parent, kind, idx_q) with the parent's place in the walk,
    and idx_v."""
    return _walk_rows(walk, parents=[joint.parent + 1 for joint in walk])


def _walk_rows(joints: list[_Joint], parents: list[int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The world's row, then per joint its row (placement rotation, translation, unit axis),
    (parent, kind, idx_q) given its parent's index in these tables, and idx_v."""
    rows, ints = np.zeros((len(joints) + 1, JOINT_ROW)), np.zeros((len(joints) + 1, 3), dtype=np.int64)
    idx_v = np.zeros(len(joints) + 1, dtype=np.int64)
    rows[0, [0, 4, 8]] = 1.0
    for k, (joint, parent) in enumerate(zip(joints, parents), start=1):
        rows[k] = np.concatenate([joint.rotation.reshape(9), joint.translation, joint.axis])
        kind = PRISMATIC if not joint.turns else CONTINUOUS if joint.nq == 2 else REVOLUTE
        ints[k], idx_v[k] = (parent, kind, joint.idx_q), joint.idx_v
    return rows, ints, idx_v
