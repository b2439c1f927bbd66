"""Rule files: named SWRL rules in plain text, one entry per rule, each with its rationale.

Format of a `*.rules` file (the SWRL syntax is Protégé's, so a rule pastes into its SWRL tab)::

    # Why the rule exists, in one or more comment lines (required).
    [rule_name] Class(?x) ^ property(?x, ?y) ^ swrlb:lessThan(?a, 0.5) -> otherProperty(?x, Individual)

- An entry is a block of `#` lines directly followed by a `[name]` line; the rule may continue
  on indented lines below it. Comment blocks followed by a blank line (a file header, say) are
  not rationales and are skipped.
- Atoms are joined by `^`, body and head are separated by `->`. Predicates are local names of
  the hriplan ontology (classes take one argument, properties two) or SWRL built-ins written
  `swrlb:name(...)`. Arguments: variables `?x`, ontology individuals (`UprightFull`), numbers,
  `true`, `false`, "strings". Head variables must occur in the body (DL-safe rules).
- Rule names are unique over every file loaded. The rules in this package's folder are always
  loaded; `load_rules(extra)` adds a user's files, so a new rule needs no Python.
"""

from __future__ import annotations

import functools
import hashlib
import json
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from hriplan import HriplanError
from hriplan.files import read_text

RULES_DIR = Path(__file__).parents[1] / "rules"  # the built-in rule files, data of the rules stage
BUILTIN_PREFIX = "swrlb:"

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_HEADER = re.compile(r"^\[([^\]]*)\]\s*(.*)$")
_ATOM = re.compile(r"^((?:swrlb:)?[A-Za-z_][A-Za-z0-9_]*)\s*\((.*)\)$", re.DOTALL)
_NUMBER = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$")


@dataclass(frozen=True)
class Var:
    """A rule variable (`?name`)."""

    name: str


@dataclass(frozen=True)
class Name:
    """An individual of the ontology named in a rule (e.g. `UprightFull`)."""

    name: str


Term = Var | Name | float | int | bool | str


@dataclass(frozen=True)
class Atom:
    predicate: str  # local name, or a built-in without its `swrlb:` prefix
    args: tuple[Term, ...]
    builtin: bool = False

    def variables(self) -> set[str]:
        return {a.name for a in self.args if isinstance(a, Var)}


@dataclass(frozen=True)
class Rule:
    name: str
    rationale: str
    body: tuple[Atom, ...]
    head: tuple[Atom, ...]
    source: str  # file:line, for error messages

    def swrl(self) -> str:
        """The rule in owlready2's SWRL syntax (built-ins without prefix)."""
        return f"{_side(self.body)} -> {_side(self.head)}"

    @functools.cached_property
    def digest(self) -> str:
        """Hash of the name, rationale and rule (computed once: it keys every reasoning)."""
        return hashlib.sha256(json.dumps([self.name, self.rationale, self.swrl()]).encode()).hexdigest()


def _side(atoms: tuple[Atom, ...]) -> str:
    return ", ".join(f"{a.predicate}({', '.join(_term_text(t) for t in a.args)})" for a in atoms)


def _term_text(term: Term) -> str:
    if isinstance(term, Var):
        return f"?{term.name}"
    if isinstance(term, Name):
        return term.name
    if isinstance(term, bool):
        return "true" if term else "false"
    if isinstance(term, str):
        return f'"{term}"'
    return repr(term)


def read_predicates(rules: Sequence[Rule]) -> set[str]:
    """The classes and properties some rule's body reads (facts nobody reads need not be stated)."""
    return {a.predicate for r in rules for a in r.body if not a.builtin}


def load_rules(extra_files: Sequence[str | Path] = ()) -> tuple[Rule, ...]:
    """The package's rules plus the given rule files, in that order; names must be unique."""
    files = sorted(RULES_DIR.glob("*.rules")) + [Path(f) for f in extra_files]
    rules: list[Rule] = []
    seen: dict[str, str] = {}
    for path in files:
        text = read_text(path, "rule file")
        for rule in _parsed(text, str(path)):
            if rule.name in seen:
                raise HriplanError(f"{rule.source}: rule name {rule.name!r} is already used at {seen[rule.name]}")
            seen[rule.name] = rule.source
            rules.append(rule)
    return tuple(rules)


@functools.lru_cache(maxsize=64)
def _parsed(text: str, filename: str) -> tuple[Rule, ...]:
    """Parsing is memoised by text: the knowledge base loads the rules for every situation."""
    return tuple(parse_rules(text, filename))


def parse_rules(text: str, filename: str = "<rules>") -> list[Rule]:
    """Parse the entries of one rule file; errors name the file and line."""
    rules = []
    comments: list[str] = []
    entry: tuple[int, list[str]] | None = None  # (line number of [name], text lines)
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if entry is not None and stripped and line[0].isspace() and not stripped.startswith("#"):
            entry[1].append(stripped)
            continue
        if entry is not None:
            rules.append(_entry(entry, comments, filename))
            entry, comments = None, []
        if not stripped:
            comments = []
        elif stripped.startswith("#"):
            comments.append(stripped.lstrip("#").strip())
        elif stripped.startswith("["):
            entry = (number, [stripped])
        else:
            raise HriplanError(
                f"{filename}:{number}: expected '# rationale' or '[rule_name] body -> head', got {stripped[:40]!r}"
            )
    if entry is not None:
        rules.append(_entry(entry, comments, filename))
    return rules


def _entry(entry: tuple[int, list[str]], comments: list[str], filename: str) -> Rule:
    number, lines = entry
    source = f"{filename}:{number}"
    match = _HEADER.match(" ".join(lines))
    if match is None:
        raise HriplanError(f"{source}: a rule starts with '[name]'")
    name, text = match.group(1).strip(), match.group(2)
    if not _NAME.match(name):
        raise HriplanError(f"{source}: rule name {name!r} must be letters, digits and '_'")
    rationale = " ".join(c for c in comments if c)
    missing = f"rule {name!r} needs a '#' comment line just above it giving its rationale"
    try:
        rule = _rule(name, rationale, text, source)
    except HriplanError as exc:
        raise HriplanError(f"{exc}; also, {missing}" if not rationale else str(exc)) from None
    if not rationale:
        raise HriplanError(f"{source}: {missing}")
    return rule


def _rule(name: str, rationale: str, text: str, source: str) -> Rule:
    """The rule an entry's text states; a syntax error names the rule and its line."""
    where = f"{source}: rule {name!r}"
    if text.count("->") != 1:
        raise HriplanError(f"{where}: write exactly one '->' between body and head")
    body_text, head_text = text.split("->")
    body, head = _atoms(body_text, where), _atoms(head_text, where)
    if any(a.builtin for a in head):
        raise HriplanError(f"{where}: built-ins belong in the body, not the head")
    unbound = set().union(*(a.variables() for a in head)) - set().union(*(a.variables() for a in body))
    if unbound:
        raise HriplanError(
            f"{where}: head variables {', '.join('?' + v for v in sorted(unbound))} do not occur in the body"
        )
    return Rule(name, rationale, body, head, source)


def _atoms(text: str, where: str) -> tuple[Atom, ...]:
    parts = [p.strip() for p in text.split("^")]
    if not all(parts):
        raise HriplanError(f"{where}: empty atom (a stray '^' or an empty side of '->')")
    return tuple(_atom(p, where) for p in parts)


def _atom(text: str, where: str) -> Atom:
    match = _ATOM.match(text)
    if match is None:
        raise HriplanError(f"{where}: cannot read atom {text!r}; expected Name(arg, ...)")
    predicate, args_text = match.groups()
    args = tuple(_term(a.strip(), where) for a in args_text.split(","))
    builtin = predicate.startswith(BUILTIN_PREFIX)
    if builtin:
        predicate = predicate[len(BUILTIN_PREFIX) :]
    elif len(args) not in (1, 2):
        raise HriplanError(f"{where}: {predicate} has {len(args)} arguments; classes take 1, properties 2")
    return Atom(predicate, args, builtin)


def _term(text: str, where: str) -> Term:
    if text.startswith("?") and _NAME.match(text[1:]):
        return Var(text[1:])
    if text in ("true", "false"):
        return text == "true"
    if _NUMBER.match(text):
        number = float(text)
        return int(text) if number.is_integer() and not any(c in text for c in ".eE") else number
    if len(text) >= 2 and text[0] == text[-1] == '"' and '"' not in text[1:-1]:
        return text[1:-1]
    if _NAME.match(text):
        return Name(text)
    raise HriplanError(f"{where}: cannot read argument {text!r}")
