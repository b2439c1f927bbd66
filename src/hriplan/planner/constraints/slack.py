"""Slack variables: every band as an equality on an augmented space that Atlas can chart.

Each banded quantity g(x) (the orientation rows, a link position in a volume's frame) gets a
slack s with g(x) - s = 0; the rows' Jacobian [dg/dx, -I] has full rank everywhere, so Atlas and
TangentBundle can chart the manifold (dead-zone rows cannot: their Jacobian vanishes inside a
band). The slack's bounds (the joint space's bounds, extended) hold each band's box; the exact
band (cone of tilts, the dynamic tolerance, a sphere or a cone volume) stays in validity.
"""

from __future__ import annotations

import numpy as np

from hriplan.planner.constraints.evaluator import ConstraintEvaluator


class SlackRows:
    """Rows g(x) - s over (x, s) for one evaluator's constraints."""

    def __init__(self, evaluator: ConstraintEvaluator) -> None:
        self.evaluator = evaluator
        self.n = evaluator.n
        self.low, self.high = evaluator.quantity_bounds()
        self.k = len(self.low)
        self._minus_identity = -np.eye(self.k)

    def function(self, xs: np.ndarray) -> np.ndarray:
        return self.evaluator.quantities(xs[: self.n]) - xs[self.n :]

    def jacobian(self, xs: np.ndarray) -> np.ndarray:
        return np.hstack([self.evaluator.quantities_jacobian(xs[: self.n]), self._minus_identity])

    def lift(self, x: np.ndarray) -> np.ndarray:
        """(x, s) on the manifold: the slack at its quantity's value."""
        return np.concatenate([x, self.evaluator.quantities(x)])

    def bounds(self, joint_bounds: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        return np.concatenate([joint_bounds[0], self.low]), np.concatenate([joint_bounds[1], self.high])
