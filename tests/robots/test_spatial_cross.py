"""The scalar cross product gives np.cross's bits, so frames built with it (held objects' poses
in the tool, goal orientations, the rules' constraint frames) are those np.cross gave."""

from __future__ import annotations

import itertools

import numpy as np

from hriplan.robots.bounding import frame_with_z
from hriplan.robots.spatial import cross


def _vectors() -> list[np.ndarray]:
    # Signed zeros and axis-aligned vectors too: a product's sign of zero is part of its bits.
    aligned = [np.array(v) for v in itertools.product([-1.0, -0.0, 0.0, 0.5, 1.0], repeat=3) if any(v)]
    return aligned + list(np.random.default_rng(7).normal(size=(2000, 3)))


def test_cross_has_the_bits_of_np_cross():
    vectors = _vectors()
    for a, b in zip(vectors, vectors[1:] + vectors[:1]):
        assert np.array(cross(a.tolist(), b.tolist())).tobytes() == np.cross(a, b).tobytes()


def test_frame_with_z_has_the_bits_of_the_np_cross_construction():
    for axis in _vectors():
        z = axis / np.linalg.norm(axis)
        helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        x = np.cross(helper, z)
        x /= np.linalg.norm(x)
        assert frame_with_z(axis).tobytes() == np.column_stack([x, np.cross(z, x), z]).tobytes()
