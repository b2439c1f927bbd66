"""Matching a rule's body against facts: the bindings of its variables that satisfy every atom.

Shared by the in-process reasoner (which adds the heads of every match) and by provenance
(which matches again with the head bound, to say which facts a conclusion used). Class atoms
test an individual's classes, property atoms its values; numeric built-ins are evaluated.
"""

from __future__ import annotations

import operator
from collections.abc import Callable, Iterable, Iterator, Mapping
from typing import Protocol

from hriplan.ontology.facts import Value
from hriplan.ontology.ruleset import Atom, Name, Term, Var

Binding = dict[str, Value]
ARITHMETIC: dict[str, Callable[[float, float], float]] = {
    "add": operator.add,
    "subtract": operator.sub,
    "multiply": operator.mul,
    "divide": operator.truediv,
}
COMPARISONS: dict[str, Callable[[Value, Value], bool]] = {
    "lessThan": operator.lt,
    "lessThanOrEqual": operator.le,
    "greaterThan": operator.gt,
    "greaterThanOrEqual": operator.ge,
    "equal": operator.eq,
    "notEqual": operator.ne,
}
EVALUATED = frozenset(ARITHMETIC) | frozenset(COMPARISONS)


class FactStore(Protocol):
    """What matching reads: every individual (keys of `types`), subjects of values, and lookups."""

    @property
    def types(self) -> Mapping[str, Iterable[str]]: ...

    @property
    def values(self) -> Mapping[str, Mapping[str, Iterable[Value]]]: ...

    def is_a(self, individual: str, cls: str) -> bool: ...

    def get(self, individual: str, prop: str) -> Iterable[Value]: ...


def solutions(atoms: list[Atom], binding: Binding, facts: FactStore) -> Iterator[Binding]:
    """Every extension of `binding` satisfying all atoms (built-ins wait until their inputs are bound)."""
    if not atoms:
        yield binding
        return
    index = next((i for i, a in enumerate(atoms) if _ready(a, binding)), 0)
    atom, rest = atoms[index], atoms[:index] + atoms[index + 1 :]
    for extended in _evaluate(atom, binding, facts):
        yield from solutions(rest, extended, facts)


def unify(head: Atom, predicate: str, values: tuple[Value, ...]) -> Binding | None:
    """The binding making `head` read predicate(values), or None."""
    if head.builtin or head.predicate != predicate or len(head.args) != len(values):
        return None
    binding: Binding = {}
    for term, value in zip(head.args, values):
        if isinstance(term, Var):
            if binding.setdefault(term.name, value) != value:
                return None
        elif constant(term) != value:
            return None
    return binding


def resolve(term: Term, binding: Binding) -> Value | None:
    return binding.get(term.name) if isinstance(term, Var) else constant(term)


def constant(term: Term) -> Value:
    assert not isinstance(term, Var)
    return term.name if isinstance(term, Name) else term


def same_value(a: Value, b: Value) -> bool:
    """Equal and of the same type (True is not 1, 1 is not 1.0 for a reasoner's literals)."""
    return type(a) is type(b) and a == b


def _evaluate(atom: Atom, binding: Binding, facts: FactStore) -> Iterator[Binding]:
    args = [resolve(a, binding) for a in atom.args]
    if atom.builtin:
        yield from _builtin(atom, args, binding)
    elif len(args) == 1:
        candidates = [args[0]] if args[0] is not None else list(facts.types)
        for individual in candidates:
            if facts.is_a(str(individual), atom.predicate):
                yield _bind(atom.args[0], individual, binding)
    else:
        subjects = [args[0]] if args[0] is not None else list(facts.values)
        for subject in subjects:
            for value in list(facts.get(str(subject), atom.predicate)):
                if args[1] is None or value == args[1]:
                    yield _bind(atom.args[1], value, _bind(atom.args[0], subject, binding))


def _ready(atom: Atom, binding: Binding) -> bool:
    """Built-ins wait until their inputs are bound (arithmetic binds its first argument)."""
    if not atom.builtin:
        return True
    inputs = atom.args[1:] if atom.predicate in ARITHMETIC else atom.args
    return all(resolve(a, binding) is not None for a in inputs)


def _builtin(atom: Atom, args: list[Value | None], binding: Binding) -> Iterator[Binding]:
    """Evaluate a numeric built-in; inputs that are unbound or not numbers match nothing.

    Other built-ins cannot be evaluated here and are taken as satisfied: provenance explains
    what Pellet concluded, and the in-process reasoner refuses rules that use them.
    """
    try:
        if atom.predicate in ARITHMETIC:
            result = ARITHMETIC[atom.predicate](float(args[1]), float(args[2]))  # type: ignore[arg-type]
            if args[0] is None:
                yield _bind(atom.args[0], result, binding)
            elif abs(float(args[0]) - result) <= 1e-9 * max(1.0, abs(result)):
                yield binding
        elif atom.predicate in COMPARISONS:
            if None not in args[:2] and COMPARISONS[atom.predicate](args[0], args[1]):  # type: ignore[arg-type]
                yield binding
        else:
            yield binding
    except (TypeError, ValueError, IndexError, ZeroDivisionError):
        return


def _bind(term: Term, value: Value, binding: Binding) -> Binding:
    return {**binding, term.name: value} if isinstance(term, Var) else binding
