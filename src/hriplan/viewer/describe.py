"""One line per constraint for legends and plot titles: the rules' reason, else its words.

The reason says why a constraint is there; when a constraint did not come from the rules it has
none, and the constraint's words (planner/constraints/words.py, as `hriplan derive` prints them)
state its geometry, so that the legend is never empty.
"""

from __future__ import annotations

from hriplan.planner.constraints import words
from hriplan.planner.trajectory import ResolvedConstraint


def describe(constraint: ResolvedConstraint) -> str:
    return constraint.reason.strip() or words.describe(constraint.spec)
