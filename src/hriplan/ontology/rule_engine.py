"""The in-process reasoner: the rules evaluated in Python on top of the ontology's schema.

What Pellet concludes about hriplan's situations needs only the fragment `schema` reads: every
class's superclasses and implied values, super-properties, inverses, chains, domains and ranges,
plus the rules, which are Datalog-shaped (class and property atoms and numeric comparisons).
So facts are closed under those axioms as they are added and the rules run to a fixed point;
no JVM starts. Pellet stays the reference (tests derive every corpus situation both ways).

What this reasoner cannot settle it hands back (`None`): a contradiction (Pellet explains it),
or two values of a functional object property (Pellet would merge the individuals). Schema
constructs or built-ins outside the fragment are refused with a one-line error.
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Sequence

from hriplan import HriplanError
from hriplan.ontology.assertions import TYPE, Assertion
from hriplan.ontology.facts import Facts, Value
from hriplan.ontology.rule_matching import EVALUATED, constant, same_value, solutions
from hriplan.ontology.ruleset import Rule, Var
from hriplan.ontology.schema import Schema

MAX_ROUNDS = 100


class _Store:
    """Facts closed under the schema's axioms as they are added."""

    def __init__(self, schema: Schema) -> None:
        self.schema = schema
        self.types: dict[str, set[str]] = {}
        self.values: dict[str, dict[str, list[Value]]] = {}
        self.changed = False

    def is_a(self, individual: str, cls: str) -> bool:
        return cls in self.types.get(individual, ())

    def get(self, individual: str, prop: str) -> list[Value]:
        return self.values.get(individual, {}).get(prop, [])

    def individual(self, name: str) -> None:
        self.types.setdefault(name, set())
        self.values.setdefault(name, {})

    def add(self, subject: str, predicate: str, value: Value) -> None:
        """One assertion (predicate `a`: a class) with everything the schema makes follow from it."""
        if predicate == TYPE:
            self.add_type(subject, str(value))
        else:
            self.add_value(subject, predicate, value)

    def add_type(self, individual: str, cls: str) -> None:
        self.individual(individual)
        for ancestor in self.schema.ancestors.get(cls, {cls}):
            if ancestor not in self.types[individual]:
                self.types[individual].add(ancestor)
                self.changed = True
                for prop, value in self.schema.implied_values.get(ancestor, ()):
                    self.add_value(individual, prop, value)

    def add_value(self, subject: str, prop: str, value: Value) -> None:
        schema = self.schema
        self.individual(subject)
        for sup in schema.super_properties.get(prop, {prop}):
            present = self.values[subject].setdefault(sup, [])
            if any(same_value(v, value) for v in present):
                continue
            present.append(value)
            self.changed = True
            for cls in schema.domains.get(sup, ()):
                self.add_type(subject, cls)
            if sup in schema.object_properties:
                self.individual(str(value))
                for cls in schema.ranges.get(sup, ()):
                    self.add_type(str(value), cls)
                if sup in schema.inverse:
                    self.add_value(str(value), schema.inverse[sup], subject)

    def follow_chains(self) -> None:
        for prop, chains in self.schema.chains.items():
            for chain in chains:
                for subject in list(self.values):
                    for end in self._along(subject, chain):
                        self.add_value(subject, prop, end)

    def _along(self, subject: str, chain: Sequence[str]) -> Iterable[Value]:
        ends: list[Value] = [subject]
        for link in chain:
            ends = [v for e in ends for v in self.get(str(e), link)]
        return ends

    def copy(self) -> _Store:
        other = _Store(self.schema)
        other.types = {i: set(t) for i, t in self.types.items()}
        other.values = {i: {p: list(vs) for p, vs in v.items()} for i, v in self.values.items()}
        return other

    def facts(self) -> Facts:
        return Facts(
            types={i: sorted(t) for i, t in self.types.items()},
            values={i: {p: sorted(vs, key=repr) for p, vs in v.items()} for i, v in self.values.items()},
            labels=self.schema.individuals.labels,
        )


def check_supported(schema: Schema, rules: Sequence[Rule]) -> None:
    """Refuse what this reasoner does not evaluate, naming it (Pellet does: --reasoner pellet)."""
    if schema.unsupported:
        raise HriplanError(
            f"the fast reasoner does not handle {schema.unsupported[0]} in the ontology; use --reasoner pellet"
        )
    for rule in rules:
        for atom in rule.body:
            if atom.builtin and atom.predicate not in EVALUATED:
                raise HriplanError(
                    f"{rule.source}: rule {rule.name!r} uses built-in {atom.predicate}, which the fast "
                    "reasoner does not evaluate; use --reasoner pellet"
                )


def reason(schema: Schema, rules: Sequence[Rule], assertions: Sequence[Assertion]) -> Facts | None:
    """Everything that follows from the ontology, the rules and the assertions; None if Pellet must decide."""
    check_supported(schema, rules)
    store = _ontology_closure(schema).copy()
    for subject, prop, value in assertions:
        store.add(subject, prop, value)
    for _ in range(MAX_ROUNDS):
        store.changed = False
        store.follow_chains()
        for rule in rules:
            for binding in list(solutions(list(rule.body), {}, store)):
                for atom in rule.head:
                    args = [binding[a.name] if isinstance(a, Var) else constant(a) for a in atom.args]
                    predicate, value = (TYPE, atom.predicate) if len(args) == 1 else (atom.predicate, args[1])
                    store.add(str(args[0]), predicate, value)
        if not store.changed:
            break
    else:
        raise HriplanError(f"the fast reasoner found no fixed point in {MAX_ROUNDS} rounds; use --reasoner pellet")
    return None if _needs_pellet(store) else store.facts()


@functools.lru_cache(maxsize=8)
def _ontology_closure(schema: Schema) -> _Store:
    """The ontology's own individuals closed under its axioms: the same for every situation."""
    store = _Store(schema)
    for name, classes in schema.individuals.types.items():
        store.individual(name)
        for cls in classes:
            store.add_type(name, cls)
    for name, values in schema.individuals.values.items():
        for prop, vs in values.items():
            for value in vs:
                store.add_value(name, prop, value)
    return store


def _needs_pellet(store: _Store) -> bool:
    """A contradiction, or a functional object property with two values (individuals to merge)."""
    schema = store.schema
    for classes in store.types.values():
        if any(len(classes.intersection(group)) > 1 for group in schema.disjoint):
            return True
    for values in store.values.values():
        for prop, vs in values.items():
            if prop in schema.functional and len(vs) > 1:
                return True
            allowed = schema.data_ranges.get(prop)
            if allowed is not None and not all(_in_range(v, allowed) for v in vs):
                return True
    return False


def _in_range(value: Value, allowed: tuple[type, ...] | frozenset[Value]) -> bool:
    if isinstance(allowed, frozenset):
        return any(same_value(value, a) for a in allowed)
    return object in allowed or (type(value) in allowed)
