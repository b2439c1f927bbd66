"""OMPL's seeds from a run's seed, without importing OMPL: the planning session derives its
re-plans' seeds from them, and a process whose planner is not OMPL's never loads it."""

from __future__ import annotations

import numpy as np

# OMPL seeds are unsigned 32-bit and 0 means "no seed" (ignored): seeds map into 1 .. 2^32 - 1.
_SEEDS = 2**32 - 1


def ompl_seed(seed: int, attempt: int = 0) -> int:
    """OMPL's seed for attempt `attempt` of run `seed`: distinct integers give distinct seeds
    (every |seed| < 2^31 on the first attempt; later attempts are hashed from both), never 0."""
    zigzag = 2 * seed if seed >= 0 else -2 * seed - 1  # 0, -1, 1, -2, ... -> 0, 1, 2, 3, ...
    if attempt == 0:
        return zigzag % _SEEDS + 1
    return int(np.random.SeedSequence([zigzag, attempt]).generate_state(1)[0]) % _SEEDS + 1
