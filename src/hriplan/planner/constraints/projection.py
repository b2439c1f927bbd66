"""Newton projection onto constraint rows (used for start/goal repair and the hybrid's ends)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


def project(
    x: np.ndarray,
    rows: Callable[[np.ndarray], np.ndarray],
    jacobian: Callable[[np.ndarray], np.ndarray],
    tolerance: float = 1e-9,
    max_iterations: int = 50,
) -> np.ndarray | None:
    """The nearby x with |rows(x)| <= tolerance (minimum-norm Newton steps), or None."""
    x = np.array(x, dtype=float)
    for _ in range(max_iterations):
        f = rows(x)
        if float(np.abs(f).max(initial=0.0)) <= tolerance:
            return x
        jac = jacobian(x)
        x = x - np.linalg.lstsq(jac, f, rcond=None)[0]
    return x if float(np.abs(rows(x)).max(initial=0.0)) <= tolerance else None
