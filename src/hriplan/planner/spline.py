"""What a joint trajectory controller executes between two written points: the cubic Hermite
spline through their positions and velocities (ros2_control's joint_trajectory_controller
interpolates so when velocities are given), not the straight line a dense validation checks.

So a written trajectory is only as safe as its spline: its speed peaks between points (exactly:
the speed along a cubic is a quadratic), and where written velocities disagree with the
positions the spline bulges off the straight segment. `executed_states` adds spline samples
where the bulge exceeds `CHORD_TOLERANCE`, so that validating straight between the states
validates what the controller follows; a trajectory hriplan timed is dense and smooth (bulges
near 4e-5 rad) and gains none.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

CHORD_TOLERANCE = 1e-3  # rad a joint's spline may leave the straight segment between checked states
_BULGE_SAMPLES = np.linspace(0.0, 1.0, 33)


@dataclass(frozen=True)
class Spline:
    """Points (rows) of a joint trajectory: times (s), positions (rad), velocities (rad/s)."""

    times: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray

    def at(self, segment: int, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions and velocities at fractions `s` of segment `segment` (rows: fractions)."""
        h = self.times[segment + 1] - self.times[segment]
        p0, p1 = self.positions[segment], self.positions[segment + 1]
        v0, v1 = self.velocities[segment], self.velocities[segment + 1]
        s = np.asarray(s, dtype=float)[:, None]
        h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, 3 * s**2 - 2 * s**3, s**3 - s**2
        position = h00 * p0 + h * h10 * v0 + h01 * p1 + h * h11 * v1
        velocity = 6 * s * (1 - s) * (p1 - p0) / h + (3 * s**2 - 4 * s + 1) * v0 + (3 * s**2 - 2 * s) * v1
        return position, velocity

    def mean_speeds(self) -> np.ndarray:
        """|displacement| / duration of every segment (rows) and joint (columns): the spline's
        speed reaches it somewhere in the segment, whatever the written velocities say."""
        return np.abs(np.diff(self.positions, axis=0)) / np.diff(self.times)[:, None]

    def peak_speeds(self) -> np.ndarray:
        """The largest |velocity| of the spline in every segment (rows) and joint (columns), exactly:
        at an end, or at the vertex of the quadratic velocity inside the segment."""
        h = np.diff(self.times)[:, None]
        m = np.diff(self.positions, axis=0) / h
        v0, v1 = self.velocities[:-1], self.velocities[1:]
        a, b = 3 * (v0 + v1) - 6 * m, 6 * m - 4 * v0 - 2 * v1  # velocity(s) = a s^2 + b s + v0
        with np.errstate(divide="ignore", invalid="ignore"):
            vertex = np.where(np.abs(a) > 1e-12, -b / (2 * a), 0.0)
        vertex = np.clip(np.nan_to_num(vertex), 0.0, 1.0)
        inside = np.abs(a * vertex**2 + b * vertex + v0)
        return np.maximum(np.maximum(np.abs(v0), np.abs(v1)), inside)

    def bulges(self) -> np.ndarray:
        """How far (rad) each segment's spline leaves its straight segment, per segment (the
        largest over joints): written velocities that disagree with the positions show here."""
        h = np.diff(self.times)[:, None, None]
        m = (np.diff(self.positions, axis=0) / h[:, :, 0])[:, None, :]
        s = _BULGE_SAMPLES[None, :, None]
        v0, v1 = self.velocities[:-1, None, :], self.velocities[1:, None, :]
        off = h * (s * (1 - s) ** 2 * (v0 - m) - s**2 * (1 - s) * (v1 - m))
        return np.abs(off).max(axis=(1, 2))

    def accelerations(self) -> np.ndarray:
        """The spline's largest |acceleration| in every segment (rows) and joint (columns): at an
        end, since a cubic's acceleration is linear in time."""
        h = np.diff(self.times)[:, None]
        dp = np.diff(self.positions, axis=0)
        v0, v1 = self.velocities[:-1], self.velocities[1:]
        start = (6 * dp / h - 4 * v0 - 2 * v1) / h
        end = (-6 * dp / h + 2 * v0 + 4 * v1) / h
        return np.maximum(np.abs(start), np.abs(end))

    def executed_states(self, tolerance: float = CHORD_TOLERANCE) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Times, positions and velocities of the written points plus spline samples in every
        segment that bulges more than `tolerance`, so that straight lines between the states
        stay within `tolerance` of the spline (a straight line between samples dt apart is off a
        curve by at most dt^2/8 times its largest acceleration)."""
        times, positions, velocities = [self.times[:1]], [self.positions[:1]], [self.velocities[:1]]
        h, accelerations = np.diff(self.times), self.accelerations().max(axis=1)
        for k, bulge in enumerate(self.bulges()):
            pieces = 1 if bulge <= tolerance else int(np.ceil(h[k] * np.sqrt(accelerations[k] / (8.0 * tolerance))))
            s = np.arange(1, pieces + 1) / pieces
            p, v = self.at(k, s)
            p[-1], v[-1] = self.positions[k + 1], self.velocities[k + 1]  # the written point itself
            times.append(self.times[k] + s * h[k])
            positions.append(p)
            velocities.append(v)
        return np.concatenate(times), np.vstack(positions), np.vstack(velocities)
