"""Why a fact holds: the rules that concluded it and the facts their bodies matched, in words.

Pellet says what follows, not which rule made it follow. So each rule whose head can produce
the fact is matched again, in Python, against the reasoned facts with the head's variables
bound; every solution names the rule and the facts it used. Facts that rules derived in turn
(a can is a FullOpenContainer, an object `isNear` a person) are explained the same way, a few
levels deep. Numeric built-ins are evaluated; other built-ins cannot be and are taken as
satisfied (Pellet checked them). A class atom is worded with the individual's stated kind
("can1 is a Can"), so the facts read as what the situation said.
"""

from __future__ import annotations

import operator
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field

from hriplan.ontology.assertions import TYPE, Assertion
from hriplan.ontology.facts import Facts, Value

from .ruleset import Atom, Name, Rule, Term, Var

MAX_DEPTH = 3
Binding = dict[str, Value]
_ARITHMETIC: dict[str, Callable[[float, float], float]] = {
    "add": operator.add, "subtract": operator.sub, "multiply": operator.mul, "divide": operator.truediv,
}  # fmt: skip
_COMPARISONS: dict[str, Callable[[Value, Value], bool]] = {
    "lessThan": operator.lt, "lessThanOrEqual": operator.le, "greaterThan": operator.gt,
    "greaterThanOrEqual": operator.ge, "equal": operator.eq, "notEqual": operator.ne,
}  # fmt: skip


@dataclass
class Support:
    """The rules behind a fact (`direct`: those concluding it; `rules`: those and the rules
    behind the facts they matched) and the matched facts in words."""

    direct: list[str] = field(default_factory=list)
    rules: list[str] = field(default_factory=list)
    facts: list[str] = field(default_factory=list)

    def add(self, other: Support) -> None:
        self.rules += [r for r in other.rules if r not in self.rules]
        self.facts += [f for f in other.facts if f not in self.facts]


class Provenance:
    """Explains facts of one reasoned situation with its rules."""

    def __init__(self, rules: Sequence[Rule], facts: Facts, assertions: Sequence[Assertion]) -> None:
        self.rules = rules
        self.facts = facts
        self.asserted = set(assertions)
        self.kind_of = {s: str(o) for s, p, o in assertions if p == TYPE}

    def why(self, subject: str, predicate: str, value: Value | None = None, depth: int = 0) -> Support:
        """Support of predicate(subject, value), or of the class fact predicate(subject) if value is None."""
        support = Support()
        for rule, solutions in self._matches(subject, predicate, value):
            support.direct.append(rule.name)
            support.add(Support(rules=[rule.name]))
            for solution in solutions:
                for atom in rule.body:
                    support.add(self._atom_support(atom, solution, depth))
        return support

    def _matches(self, subject: str, predicate: str, value: Value | None) -> Iterator[tuple[Rule, list[Binding]]]:
        values = (subject,) if value is None else (subject, value)
        for rule in self.rules:
            for head in rule.head:
                binding = _unify(head, predicate, values)
                if binding is not None:
                    solutions = list(self._solve(list(rule.body), binding))
                    if solutions:
                        yield rule, solutions
                        break

    def _solve(self, atoms: list[Atom], binding: Binding) -> Iterator[Binding]:
        if not atoms:
            yield binding
            return
        index = next((i for i, a in enumerate(atoms) if _ready(a, binding)), 0)
        atom, rest = atoms[index], atoms[:index] + atoms[index + 1 :]
        for extended in self._evaluate(atom, binding):
            yield from self._solve(rest, extended)

    def _evaluate(self, atom: Atom, binding: Binding) -> Iterator[Binding]:
        args = [_resolve(a, binding) for a in atom.args]
        if atom.builtin:
            yield from _builtin(atom, args, binding)
        elif len(args) == 1:
            candidates = [args[0]] if args[0] is not None else list(self.facts.types)
            for individual in candidates:
                if self.facts.is_a(str(individual), atom.predicate):
                    yield _bind(atom.args[0], individual, binding)
        else:
            subjects = [args[0]] if args[0] is not None else list(self.facts.values)
            for subject in subjects:
                for value in self.facts.get(str(subject), atom.predicate):
                    if args[1] is None or value == args[1]:
                        yield _bind(atom.args[1], value, _bind(atom.args[0], subject, binding))

    def _atom_support(self, atom: Atom, binding: Binding, depth: int) -> Support:
        """The atom in words; for a derived fact, also the rules and facts behind it."""
        if atom.builtin:
            return Support()
        args = [_resolve(a, binding) for a in atom.args]
        subject = str(args[0])
        if len(args) == 1:
            kind = self.kind_of.get(subject, atom.predicate)
            support = Support(facts=[f"{subject} is {_article(kind)} {kind}"])
            if kind != atom.predicate and depth < MAX_DEPTH:
                derived = self.why(subject, atom.predicate, None, depth + 1)
                if derived.direct:
                    support.add(derived)
                    support.add(Support(facts=[f"{subject} is {_article(atom.predicate)} {atom.predicate} (derived)"]))
            return support
        value = args[1]
        assert value is not None
        support = Support(facts=[self._words(subject, atom.predicate, value)])
        if (subject, atom.predicate, value) not in self.asserted and depth < MAX_DEPTH:
            support.add(self.why(subject, atom.predicate, value, depth + 1))
        return support

    def _words(self, subject: str, prop: str, value: Value) -> str:
        label = self.facts.label(prop)
        if value is True:
            return f"{subject} {label}"
        if value is False:
            return f"{subject} {label}: false"
        if isinstance(value, float):
            return f"{subject} {label} {value:g}"
        return f"{subject} {label} {value}"


def _article(noun: str) -> str:
    return "an" if noun[:1].lower() in "aeiou" else "a"


def _unify(head: Atom, predicate: str, values: tuple[Value, ...]) -> Binding | None:
    if head.builtin or head.predicate != predicate or len(head.args) != len(values):
        return None
    binding: Binding = {}
    for term, value in zip(head.args, values):
        if isinstance(term, Var):
            if binding.setdefault(term.name, value) != value:
                return None
        elif _constant(term) != value:
            return None
    return binding


def _ready(atom: Atom, binding: Binding) -> bool:
    """Built-ins wait until their inputs are bound (arithmetic binds its first argument)."""
    if not atom.builtin:
        return True
    inputs = atom.args[1:] if atom.predicate in _ARITHMETIC else atom.args
    return all(_resolve(a, binding) is not None for a in inputs)


def _builtin(atom: Atom, args: list[Value | None], binding: Binding) -> Iterator[Binding]:
    """Evaluate a numeric built-in; inputs that are unbound or not numbers match nothing."""
    try:
        if atom.predicate in _ARITHMETIC:
            result = _ARITHMETIC[atom.predicate](float(args[1]), float(args[2]))  # type: ignore[arg-type]
            if args[0] is None:
                yield _bind(atom.args[0], result, binding)
            elif abs(float(args[0]) - result) <= 1e-9 * max(1.0, abs(result)):
                yield binding
        elif atom.predicate in _COMPARISONS:
            if None not in args[:2] and _COMPARISONS[atom.predicate](args[0], args[1]):  # type: ignore[arg-type]
                yield binding
        else:
            yield binding
    except (TypeError, ValueError, IndexError, ZeroDivisionError):
        return


def _resolve(term: Term, binding: Binding) -> Value | None:
    return binding.get(term.name) if isinstance(term, Var) else _constant(term)


def _constant(term: Term) -> Value:
    assert not isinstance(term, Var)
    return term.name if isinstance(term, Name) else term


def _bind(term: Term, value: Value, binding: Binding) -> Binding:
    return {**binding, term.name: value} if isinstance(term, Var) else binding
