"""How a motion, a plan, a task step or a sweep row ended: the one `Status` every layer reports.

A `str` enum: its values are the strings trajectory files, task outcomes, service responses and
sweep tables have always carried, so JSON, Parquet and CSV keep them exactly.
"""

from __future__ import annotations

from enum import Enum


class Status(str, Enum):
    SOLVED = "solved"
    """A validated path (a motion), and for a plan or a step also its validated timed trajectory."""
    DERIVED = "derived"
    """A task step derived (constraints, speeds) but not planned: `hriplan constraints`, `plan=False`."""
    INVALID_START = "invalid_start"
    """The start collides, violates a constraint (and may not or cannot be projected onto it),
    or is not valid for planning (within the planning margin of a band)."""
    INVALID_GOAL = "invalid_goal"
    """The joint goal collides or violates a constraint, or is not valid for planning."""
    UNREACHABLE_GOAL = "unreachable_goal"
    """No valid IK solution for the tool goal, or a pick's lift cannot leave what it stands on."""
    TIMEOUT = "timeout"
    """The search found no path within the time limit."""
    INVALID_PATH = "invalid_path"
    """The search found paths within the time limit, but the last failed dense validation."""
    PLANNER_ERROR = "planner_error"
    """OMPL refused the problem (a chart or set-up failure raised by OMPL)."""
    TIMING_FAILED = "timing_failed"
    """A valid path that could not be time-parameterised, or whose timed samples left it."""
    ERROR = "error"
    """A sweep row: the variant was bad input (one-line HriplanError) or its planning raised."""
    WORKER_DIED = "worker_died"
    """A sweep row: the variant's worker process died on every attempt."""

    def __str__(self) -> str:
        """The value, as messages have always printed it (`planning failed (timeout): ...`)."""
        return self.value


# A task step or a sweep variant succeeded: it planned, or it was only to be derived.
SUCCEEDED = (Status.SOLVED, Status.DERIVED)
