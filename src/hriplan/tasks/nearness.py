"""Nearness along a planned motion, until the knowledge base measures it itself (interface I4).

The rules decide "fragile/hot near a person" from `isNear`; for a carried object that must hold
over the whole motion, so the pipeline fills each carried object's `path` from the planned
motion and asserts `isNear` where the closest horizontal approach of that polyline to a
person's body axis is below the ontology's NearHuman distance. The reasoning helper's
`hriplan.ontology.relations` does the same measurement from the same `path` field inside the
knowledge base; once it is on main, this module and its one call in the pipeline go.
"""

from __future__ import annotations

import numpy as np

from hriplan.ontology.assertions import Assertion
from hriplan.ontology.situation import Situation


def closest_approach(points: np.ndarray, target: np.ndarray) -> float:
    """Smallest distance from `target` to the polyline through `points` (one point: to it)."""
    if len(points) == 1:
        return float(np.linalg.norm(points[0] - target))
    start, segment = points[:-1], np.diff(points, axis=0)
    lengths = np.einsum("ij,ij->i", segment, segment)
    along = np.clip(np.einsum("ij,ij->i", target - start, segment) / np.where(lengths > 0.0, lengths, 1.0), 0.0, 1.0)
    return float(np.min(np.linalg.norm(start + along[:, None] * segment - target, axis=1)))


def near_along_path(situation: Situation, threshold: float) -> list[Assertion]:
    """isNear(object, person) for every carried object whose path comes within `threshold`."""
    near: list[Assertion] = []
    for name in situation.task.carries:
        obj = situation.object(name)
        if not obj.path:
            continue
        points = np.array([obj.pose.xyz, *obj.path], dtype=float)[:, :2]
        near += [(name, "isNear", h.name) for h in situation.humans
                 if closest_approach(points, np.array(h.position, dtype=float)) < threshold]  # fmt: skip
    return near
