"""What holds after reasoning, as plain data that survives the cache (JSON) without the World.

Individuals are named by their local names (situation names and ontology individuals such as
`UprightFull`); property values are individual names or data values.
"""

from __future__ import annotations

from pydantic import BaseModel, Field

from hriplan import HriplanError

Value = bool | int | float | str


class Facts(BaseModel):
    """Asserted and inferred facts about every named individual, plus the ontology's words.

    types: each individual's classes with every superclass. values: property -> values.
    labels: rdfs:label of ontology terms (to put facts in words).
    """

    types: dict[str, list[str]] = Field(default_factory=dict)
    values: dict[str, dict[str, list[Value]]] = Field(default_factory=dict)
    labels: dict[str, str] = Field(default_factory=dict)

    def is_a(self, individual: str, cls: str) -> bool:
        return cls in self.types.get(individual, ())

    def get(self, individual: str, prop: str) -> list[Value]:
        return self.values.get(individual, {}).get(prop, [])

    def one(self, individual: str, prop: str) -> Value:
        """The single value of a functional property; missing data is a clear error."""
        values = self.get(individual, prop)
        if not values:
            raise HriplanError(
                f"the knowledge base has no {prop} for {individual}; add it to the ontology or the situation"
            )
        return values[0]

    def number(self, individual: str, prop: str) -> float:
        value = self.one(individual, prop)
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise HriplanError(f"{individual} {prop} must be a number, got {value!r}")
        return float(value)

    def label(self, term: str) -> str:
        return self.labels.get(term, term)
