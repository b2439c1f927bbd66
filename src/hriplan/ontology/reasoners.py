"""Which reasoner a knowledge base uses when none is named, and what a contradiction raises.

Kept light (no JVM bridge, no rdflib): the CLI imports it, and a process that never runs
Pellet never imports owlready2.

"fast" evaluates the rules in process (`rule_engine`); "pellet" runs Pellet on a JVM and is
the reference the fast one is tested against.
"""

from __future__ import annotations

from typing import Literal, get_args

from hriplan import HriplanError

Reasoner = Literal["fast", "pellet"]
REASONERS: tuple[str, ...] = get_args(Reasoner)
_default: list[Reasoner] = ["fast"]


def use_reasoner(name: str) -> str:
    """Make `name` the reasoner of knowledge bases built without one (the CLI's --reasoner)."""
    if name not in REASONERS:
        raise HriplanError(f"unknown reasoner {name!r}; choose one of {', '.join(REASONERS)}")
    _default[0] = name  # type: ignore[assignment]
    return name


def default_reasoner() -> Reasoner:
    return _default[0]


class InconsistentSituation(HriplanError):
    """The situation's facts contradict each other or the ontology."""
