"""The numpy walk of many configurations gives pinocchio's frames and velocities, one by one.

Reference: pinocchio's forwardKinematics per configuration (data.oMi, and data.v rotated to the
world), on random configurations and joint velocities of MADAR, of a chain with every joint kind
the walk knows (continuous, revolute about an unaligned axis, prismatic along an unaligned and
an aligned axis), and of a free-flyer humanoid (the walk does not know the free-flyer: the
result must be the same).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from hriplan.robots.batch_kinematics import BatchKinematics, cross
from hriplan.robots.model import load_robot


def _mixed_chain() -> pin.Model:
    rng = np.random.default_rng(3)
    unit = lambda v: np.asarray(v, dtype=float) / np.linalg.norm(v)  # noqa: E731
    model, parent = pin.Model(), 0
    placements = [pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(size=3)) for _ in range(5)]
    joints = [
        pin.JointModelRUBZ(),
        pin.JointModelRevoluteUnaligned(unit([0.3, -0.5, 0.8])),
        pin.JointModelPrismaticUnaligned(unit([1.0, 2.0, -0.5])),
        pin.JointModelPY(),
        pin.JointModelRX(),
    ]
    for k, (joint, placement) in enumerate(zip(joints, placements)):
        parent = model.addJoint(parent, joint, placement, f"j{k}")
        model.appendBodyToJoint(parent, pin.Inertia.Random(), pin.SE3.Identity())
    model.lowerPositionLimit[:], model.upperPositionLimit[:] = -2.0, 2.0
    return model


@pytest.mark.parametrize(
    "model, walked",
    [
        (load_robot("madar").model, True),
        (_mixed_chain(), True),
        (pin.buildSampleModelHumanoid(), False),
    ],
    ids=["madar", "every-kind", "free-flyer"],
)
def test_the_walk_gives_pinocchios_frames_and_velocities(model, walked, either_route):
    rng = np.random.default_rng(5)
    qs = np.array([pin.randomConfiguration(model) for _ in range(25)])
    dqs = rng.normal(size=(25, model.nv))
    joints = list(range(model.njoints - 1, 0, -2))  # some joints, not in the model's order
    kinematics = BatchKinematics(model, joints)
    assert (kinematics._walk is not None) == walked
    frames = kinematics(qs, dqs)
    data = model.createData()
    for n, (q, dq) in enumerate(zip(qs, dqs)):
        pin.forwardKinematics(model, data, q, dq)
        for k, j in enumerate(joints):
            rotation = data.oMi[j].rotation
            np.testing.assert_allclose(frames.rotation[n, k], rotation, atol=1e-9)
            np.testing.assert_allclose(frames.origin[n, k], data.oMi[j].translation, atol=1e-9)
            np.testing.assert_allclose(frames.linear[n, k], rotation @ data.v[j].linear, atol=1e-9)
            np.testing.assert_allclose(frames.angular[n, k], rotation @ data.v[j].angular, atol=1e-9)


@pytest.mark.parametrize(
    "model",
    [load_robot("madar").model, _mixed_chain(), pin.buildSampleModelHumanoid()],
    ids=["madar", "every-kind", "free-flyer"],
)
def test_placements_are_the_walks_own_bit_for_bit(model, either_route):
    """The placements alone (the velocities' walk skipped, for distance bounds) are the very
    numbers the full walk gives, whatever the velocities."""
    rng = np.random.default_rng(6)
    lower, upper = np.maximum(model.lowerPositionLimit, -2.0), np.minimum(model.upperPositionLimit, 2.0)  # finite
    qs = np.array([pin.randomConfiguration(model, lower, upper) for _ in range(25)])
    joints = list(range(model.njoints - 1, 0, -2))
    kinematics = BatchKinematics(model, joints)
    rotation, origin = kinematics.placements(qs)
    frames = kinematics(qs, rng.normal(size=(25, model.nv)))
    assert np.array_equal(rotation, frames.rotation) and np.array_equal(origin, frames.origin)
    assert rotation.shape == (25, len(joints), 3, 3) and origin.shape == (25, len(joints), 3)


def test_cross_is_numpys_bit_for_bit():
    """The cross product the walk and the monitor use gives np.cross's numbers exactly (the
    same products and differences), on stacks of random vectors of several scales."""
    rng = np.random.default_rng(11)
    a = rng.normal(size=(50, 7, 3)) * rng.choice([1e-9, 1.0, 1e6], size=(50, 7, 1))
    b = rng.normal(size=(50, 7, 3))
    assert np.array_equal(cross(a, b), np.cross(a, b))
    assert np.array_equal(cross(a[0], b[0]), np.cross(a[0], b[0]))
    np.testing.assert_array_equal(cross(np.eye(3), np.roll(np.eye(3), -1, axis=0)), np.roll(np.eye(3), 1, axis=0))
