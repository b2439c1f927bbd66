"""What one search returns, whichever searched: hriplan's CBiRRT or an OMPL planner."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hriplan.planner.outcome import Status


@dataclass
class Counters:
    """Calls one search made: constraint rows, their Jacobians, validity checks."""

    function: int = 0
    jacobian: int = 0
    validity: int = 0


@dataclass
class SearchResult:
    """A search's path, or why there is none: `status` is SOLVED, TIMEOUT or PLANNER_ERROR, set
    by the search that knows, so no caller reads it from `message`."""

    status: Status
    states: list[np.ndarray]
    space: str
    message: str = ""
    counters: Counters = field(default_factory=Counters)
    unsimplified: list[np.ndarray] = field(default_factory=list)  # the planner's own path, if simplified

    @property
    def solved(self) -> bool:
        return self.status == Status.SOLVED
