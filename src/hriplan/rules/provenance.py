"""Why a fact holds: the rules that concluded it and the facts their bodies matched, in words.

Pellet says what follows, not which rule made it follow. So each rule whose head can produce
the fact is matched again, in Python, against the reasoned facts with the head's variables
bound; every solution names the rule and the facts it used. Facts that rules derived in turn
(a can is a FullOpenContainer, an object `isNear` a person) are explained the same way, a few
levels deep. A relation computed from geometry (`isNear`, see ontology.relations) is explained
by its measurement ("cup1 is 0.87 m from col, below NearHuman 1.2 m"), and by any rule that
concludes it too. Numeric built-ins are evaluated; other built-ins cannot be and are taken as
satisfied (Pellet checked them). A class atom is worded with the individual's stated kind
("can1 is a Can"), so the facts read as what the situation said.

An explanation depends on the rules, the reasoned and asserted facts (all in the knowledge
base's reasoning key) and the relations measured; of those, only the measurements' words change
while a person moves without crossing a threshold. So, given the key, explanations are
remembered with a slot for each measurement's words, filled in as each is given (a re-plan
explains the same conclusions in three situations of one step).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field

from hriplan.ontology.assertions import TYPE, Assertion
from hriplan.ontology.facts import Facts, Value
from hriplan.ontology.relations import ComputedRelation
from hriplan.ontology.rule_matching import Binding, resolve, solutions, unify
from hriplan.ontology.ruleset import Atom, Rule
from hriplan.recent import Recent

MAX_DEPTH = 3


@dataclass(frozen=True)
class _Measured:
    """Where a remembered explanation states a computed relation's measurement: its words (the
    numbers of this situation) are put in when the explanation is given."""

    assertion: Assertion


@dataclass
class Support:
    """The rules behind a fact (`direct`: those concluding it; `rules`: those and the rules
    behind the facts they matched) and the matched facts in words."""

    direct: list[str] = field(default_factory=list)
    rules: list[str] = field(default_factory=list)
    facts: list[str] = field(default_factory=list)  # a remembered explanation's hold _Measured slots too

    def add(self, other: Support) -> None:
        self.rules += [r for r in other.rules if r not in self.rules]
        self.facts += [f for f in other.facts if f not in self.facts]


# Explanations (with _Measured slots) by reasoning key, computed relations and the fact explained.
_EXPLAINED: Recent[tuple, Support] = Recent(512)


class Provenance:
    """Explains facts of one reasoned situation with its rules. With `key`, the reasoning key the
    facts came from (`KnowledgeBase.key`: ontology, rules, asserted facts, reasoner), its
    explanations are remembered for every situation of that key and the same computed relations."""

    def __init__(
        self,
        rules: Sequence[Rule],
        facts: Facts,
        assertions: Sequence[Assertion],
        computed: Sequence[ComputedRelation] = (),
        key: str | None = None,
    ) -> None:
        self.rules = rules
        self.facts = facts
        self.computed = {c.assertion: c for c in computed}
        self.asserted = set(assertions) - set(self.computed)
        self.kind_of = {s: str(o) for s, p, o in assertions if p == TYPE}
        # Beyond the key, an explanation names the relation that made each computed assertion.
        made_by = tuple(sorted((repr(c.assertion), c.relation) for c in computed))
        self._key = None if key is None else (key, made_by)

    def why(self, subject: str, predicate: str, value: Value | None = None) -> Support:
        """Support of predicate(subject, value), or of the class fact predicate(subject) if value is None."""
        asked = (self._key, subject, predicate, type(value).__name__, value)  # True and 1.0 are equal keys
        explained = _EXPLAINED.get(asked) if self._key is not None else None
        if explained is None:
            explained = self._why(subject, predicate, value, 0)
            if self._key is not None:
                _EXPLAINED.put(asked, explained)
        return self._worded(explained)

    def _worded(self, explained: Support) -> Support:
        """`explained` with each measurement's words in its slot, kept once (as `Support.add` would)."""
        facts = [self.computed[f.assertion].words if isinstance(f, _Measured) else f for f in explained.facts]
        return Support(list(explained.direct), list(explained.rules), list(dict.fromkeys(facts)))

    def _why(self, subject: str, predicate: str, value: Value | None, depth: int) -> Support:
        support = Support()
        for rule, bindings in self._matches(subject, predicate, value):
            support.direct.append(rule.name)
            support.add(Support(rules=[rule.name]))
            for solution in bindings:
                for atom in rule.body:
                    support.add(self._atom_support(atom, solution, depth))
        return support

    def _matches(self, subject: str, predicate: str, value: Value | None) -> Iterator[tuple[Rule, list[Binding]]]:
        values = (subject,) if value is None else (subject, value)
        for rule in self.rules:
            for head in rule.head:
                binding = unify(head, predicate, values)
                if binding is not None:
                    found = list(solutions(list(rule.body), binding, self.facts))
                    if found:
                        yield rule, found
                        break

    def _atom_support(self, atom: Atom, binding: Binding, depth: int) -> Support:
        """The atom in words; for a derived fact, also the rules and facts behind it."""
        if atom.builtin:
            return Support()
        args = [resolve(a, binding) for a in atom.args]
        subject = str(args[0])
        if len(args) == 1:
            kind = self.kind_of.get(subject, atom.predicate)
            support = Support(facts=[f"{subject} is {_article(kind)} {kind}"])
            if kind != atom.predicate and depth < MAX_DEPTH:
                derived = self._why(subject, atom.predicate, None, depth + 1)
                if derived.direct:
                    support.add(derived)
                    support.add(Support(facts=[f"{subject} is {_article(atom.predicate)} {atom.predicate} (derived)"]))
            return support
        value = args[1]
        assert value is not None
        support = Support(facts=[self._words(subject, atom.predicate, value)])
        computed = self.computed.get((subject, atom.predicate, value))
        if computed is not None:
            support.add(Support(rules=[computed.relation], facts=[_Measured(computed.assertion)]))
        if (subject, atom.predicate, value) not in self.asserted and depth < MAX_DEPTH:
            support.add(self._why(subject, atom.predicate, value, depth + 1))
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
