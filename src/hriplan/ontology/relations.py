"""Relations that depend on numbers, computed from the geometry before any reasoning.

The reasoner never sees a coordinate. A relation such as "near a person" is measured here, where
the numbers are, compared with its threshold read from the ontology (`NearHuman hasDistance`),
and asserted as a qualitative fact (`isNear(glass1, dana)`) that carries its measurement in
words for the explanation. A change of geometry that changes no relation changes no assertion,
so the reasoning cache hits; the rules only ever read the qualitative fact.

Nearness along a motion: an object may carry `path`, the positions it passes through (filled
from a planned motion); the measure is then the closest approach of that polyline (from the
object's pose through the path) to the person's body axis.

A new relation is one `RelationKind`: the property it asserts, the ontology individual and
property holding its threshold, and a measure over the situation.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from hriplan.ontology.assertions import Assertion
from hriplan.ontology.facts import Facts
from hriplan.ontology.situation import Situation


@dataclass(frozen=True)
class Measurement:
    subject: str
    other: str
    value: float  # in the threshold's unit
    along_path: bool  # measured over the positions the subject passes through


@dataclass(frozen=True)
class RelationKind:
    """How a qualitative relation follows from a measurement and a threshold in the ontology."""

    name: str  # named among the rules of a conclusion's provenance
    predicate: str  # the ontology property asserted between subject and other
    criterion: str  # the ontology individual holding the threshold
    threshold: str  # the criterion's property with the threshold
    measure: Callable[[Situation], Iterator[Measurement]]
    holds: Callable[[float, float], bool] = operator.lt
    comparison: str = "below"  # how `holds` reads in words
    unit: str = "m"


@dataclass(frozen=True)
class ComputedRelation:
    """A relation that holds, as the assertion the reasoner gets and the measurement in words."""

    assertion: Assertion
    relation: str
    words: str


def horizontal_distances(situation: Situation) -> Iterator[Measurement]:
    """Every carried object to every person's body axis: the closest horizontal approach.

    Only carried objects: nearness matters for what the robot moves.
    """
    for name in situation.task.carries:
        obj = situation.object(name)
        points = np.array([obj.pose.xyz, *obj.path], dtype=float)[:, :2]
        for human in situation.humans:
            yield Measurement(
                name, human.name, closest_approach(points, np.array(human.position, dtype=float)), bool(obj.path)
            )


def closest_approach(points: np.ndarray, target: np.ndarray) -> float:
    """Smallest distance from `target` to the polyline through `points` (one point: to it)."""
    if len(points) == 1:
        return float(np.linalg.norm(points[0] - target))
    start, segment = points[:-1], np.diff(points, axis=0)
    lengths = np.einsum("ij,ij->i", segment, segment)
    along = np.clip(np.einsum("ij,ij->i", target - start, segment) / np.where(lengths > 0.0, lengths, 1.0), 0.0, 1.0)
    return float(np.min(np.linalg.norm(start + along[:, None] * segment - target, axis=1)))


NEAR_HUMAN = RelationKind(
    name="carried_object_near_human",
    predicate="isNear",
    criterion="NearHuman",
    threshold="hasDistance",
    measure=horizontal_distances,
)
RELATIONS: tuple[RelationKind, ...] = (NEAR_HUMAN,)


def compute_relations(
    situation: Situation, ontology: Facts, kinds: Sequence[RelationKind] = RELATIONS
) -> list[ComputedRelation]:
    """The relations that hold in the situation, each with its measurement against its threshold."""
    found = []
    for kind in kinds:
        threshold = ontology.number(kind.criterion, kind.threshold)
        for m in kind.measure(situation):
            if math.isfinite(m.value) and kind.holds(m.value, threshold):
                where = (
                    f"comes within {m.value:.2f} {kind.unit} of {m.other} along its path"
                    if m.along_path
                    else f"is {m.value:.2f} {kind.unit} from {m.other}"
                )
                words = f"{m.subject} {where}, {kind.comparison} {kind.criterion} {threshold:g} {kind.unit}"
                found.append(ComputedRelation((m.subject, kind.predicate, m.other), kind.name, words))
    return found
