"""The ontology read in Python, once per version of its text: what every situation shares.

The class hierarchy, the property axioms (super-properties, inverses, chains, domains, ranges,
functional), disjoint classes, the values a class implies (`Glass` -> isFragile true) and the
ontology's own individuals with their data (constraint kinds, thresholds, arms). Thresholds of
computed relations are read from here before any reasoning, and the in-process reasoner starts
from it. Constructs outside that fragment (owl:equivalentClass between classes, existential
restrictions, unions, ...) are listed in `unsupported`: Pellet handles them, the in-process
reasoner refuses them.

Reading it from the triples (schema_reader.py) needs rdflib and the parsed ontology, about a
tenth of a second of a warm `plan` that reasons nothing new (issue 21); so the schema is kept on
disk beside the reasoning cache (`$XDG_CACHE_HOME/hriplan/schema-HASH.json`), named and checked by
the ontology version's hash, and read from the triples only when that file is absent or damaged.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, ValidationError

from hriplan.files import write_atomically
from hriplan.ontology.cache import default_cache_dir
from hriplan.ontology.facts import Facts, Value
from hriplan.ontology.vocabulary import OntologySource

FORMAT_VERSION = 1  # bump when the schema file's meaning changes


@dataclass(eq=False)  # compared (and cached on) by identity: one per ontology version
class Schema:
    """The ontology's axioms by local name, and its individuals' told facts (not closed)."""

    classes: set[str] = field(default_factory=set)
    ancestors: dict[str, set[str]] = field(default_factory=dict)  # class -> itself and every superclass
    implied_values: dict[str, list[tuple[str, Value]]] = field(default_factory=dict)  # class -> hasValue restrictions
    object_properties: set[str] = field(default_factory=set)
    data_properties: set[str] = field(default_factory=set)
    super_properties: dict[str, set[str]] = field(default_factory=dict)  # property -> itself and its super-properties
    inverse: dict[str, str] = field(default_factory=dict)
    chains: dict[str, list[tuple[str, ...]]] = field(default_factory=dict)
    domains: dict[str, set[str]] = field(default_factory=dict)
    ranges: dict[str, set[str]] = field(default_factory=dict)  # object properties: classes
    data_ranges: dict[str, tuple[type, ...] | frozenset[Value]] = field(default_factory=dict)
    functional: set[str] = field(default_factory=set)
    disjoint: list[list[str]] = field(default_factory=list)
    individuals: Facts = field(default_factory=Facts)  # told types and values of the ontology's individuals
    terms: set[str] = field(default_factory=set)  # every local name of the hriplan namespace
    unsupported: list[str] = field(default_factory=list)

    def is_subclass(self, cls: str, root: str) -> bool:
        return root in self.ancestors.get(cls, ())

    def descendants(self, root: str) -> list[str]:
        return sorted(c for c in self.classes if c != root and self.is_subclass(c, root))

    def instances(self, cls: str) -> list[str]:
        return sorted(i for i, types in self.individuals.types.items() if any(self.is_subclass(t, cls) for t in types))


def load_schema(source: OntologySource) -> Schema:
    """The schema of one ontology version (read once per process and content hash)."""
    return _schema(source)


@functools.lru_cache(maxsize=8)
def _schema(source: OntologySource) -> Schema:
    path = schema_path(source)
    try:
        record = SchemaFile.model_validate_json(path.read_bytes())
        if record.digest == source.digest:
            return record.schema()
    except (OSError, ValidationError):
        pass  # absent or damaged: read the ontology again
    from hriplan.ontology.schema_reader import read_schema

    schema = read_schema(source.graph)
    try:
        write_atomically(path, SchemaFile.of(schema, source.digest).model_dump_json())
    except OSError:
        pass  # a read-only or full disk only costs reading it again next time
    return schema


def schema_path(source: OntologySource) -> Path:
    return default_cache_dir().parent / f"schema-{source.digest[:16]}.json"


TypeName = Literal["bool", "str", "int", "float", "object"]
_TYPES: dict[str, type] = {"bool": bool, "str": str, "int": int, "float": float, "object": object}


class DataRange(BaseModel):
    """A data property's range on disk: Python types, or the values of an enumeration."""

    model_config = ConfigDict(extra="forbid")
    types: list[TypeName] = []
    one_of: list[Value] | None = None


class SchemaFile(BaseModel):
    """The schema as kept on disk (JSON): its fields, the ontology version's hash and the format."""

    model_config = ConfigDict(extra="forbid")
    format: Literal[1] = FORMAT_VERSION
    digest: str
    classes: set[str]
    ancestors: dict[str, set[str]]
    implied_values: dict[str, list[tuple[str, Value]]]
    object_properties: set[str]
    data_properties: set[str]
    super_properties: dict[str, set[str]]
    inverse: dict[str, str]
    chains: dict[str, list[tuple[str, ...]]]
    domains: dict[str, set[str]]
    ranges: dict[str, set[str]]
    data_ranges: dict[str, DataRange]
    functional: set[str]
    disjoint: list[list[str]]
    individuals: Facts
    terms: set[str]
    unsupported: list[str]

    @classmethod
    def of(cls, schema: Schema, digest: str) -> SchemaFile:
        ranges = {
            prop: DataRange(one_of=list(allowed))
            if isinstance(allowed, frozenset)
            else DataRange(types=[t.__name__ for t in allowed])
            for prop, allowed in schema.data_ranges.items()
        }
        fields = {name: getattr(schema, name) for name in Schema.__dataclass_fields__}
        return cls(digest=digest, **(fields | {"data_ranges": ranges}))

    def schema(self) -> Schema:
        ranges = {
            prop: frozenset(r.one_of) if r.one_of is not None else tuple(_TYPES[t] for t in r.types)
            for prop, r in self.data_ranges.items()
        }
        fields = {name: getattr(self, name) for name in Schema.__dataclass_fields__}
        return Schema(**(fields | {"data_ranges": ranges}))
