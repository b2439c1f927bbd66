"""Reasoning results cached by the facts they came from, in memory and on disk.

The key is the SHA-256 of the canonical JSON of everything the reasoner sees: the ontology
text's hash, the rules, the situation's qualitative assertions (no coordinate that no rule
reads) and which reasoner concluded it. The same situation therefore never starts
the JVM twice, in one process (memory) or across processes (disk:
`$XDG_CACHE_HOME/hriplan/reasoning/`, default `~/.cache/hriplan/reasoning/`). An inconsistency
is a result too and is cached as its message.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from pydantic import ValidationError

from hriplan.files import write_atomically
from hriplan.ontology.assertions import Assertion
from hriplan.ontology.facts import Facts
from hriplan.ontology.ruleset import Rule
from hriplan.recent import Recent

FORMAT_VERSION = 2  # bump when what is cached changes meaning
MEMORY_ENTRIES = 256


@dataclass(frozen=True)
class Reasoning:
    """What one reasoner run concluded: the facts, or why the situation is inconsistent."""

    facts: Facts | None = None
    inconsistency: str | None = None


def reasoning_key(ontology_digest: str, rules: Sequence[Rule], assertions: Sequence[Assertion], reasoner: str) -> str:
    document = {
        "format": FORMAT_VERSION,
        "reasoner": reasoner,
        "ontology": ontology_digest,
        "rules": [r.digest for r in rules],
        "facts": [list(a) for a in assertions],
    }
    canonical = json.dumps(document, sort_keys=True, separators=(",", ":"), ensure_ascii=True)
    return hashlib.sha256(canonical.encode()).hexdigest()


def default_cache_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "hriplan" / "reasoning"


class ReasoningCache:
    """Memory in front of an optional directory; disk trouble only costs a cache miss."""

    def __init__(self, directory: str | Path | None) -> None:
        self.directory = Path(directory) if directory is not None else None
        self._memory: Recent[str, tuple[Reasoning, bytes | None]] = Recent(MEMORY_ENTRIES)

    def get(self, key: str) -> Reasoning | None:
        kept = self._memory.get(key)
        if kept is not None:
            return kept[0]
        reasoning = self._read(key)
        if reasoning is not None:
            self._remember(key, reasoning, None)
        return reasoning

    def put(self, key: str, reasoning: Reasoning, ntriples: bytes | None = None) -> None:
        self._remember(key, reasoning, ntriples)
        if self.directory is None:
            return
        record = {
            "inconsistency": reasoning.inconsistency,
            "facts": reasoning.facts.model_dump(mode="json") if reasoning.facts else None,
        }
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
            if ntriples is not None:
                write_atomically(self.directory / f"{key}.nt", ntriples)
            write_atomically(self.directory / f"{key}.json", json.dumps(record).encode())
        except OSError:
            pass  # a read-only or full disk must not break reasoning

    def ntriples(self, key: str) -> bytes | None:
        """The reasoned graph of a cached result, if it was kept."""
        cached = self._memory.get(key)
        if cached is not None and cached[1] is not None:
            return cached[1]
        if self.directory is None:
            return None
        try:
            return (self.directory / f"{key}.nt").read_bytes()
        except OSError:
            return None

    def _remember(self, key: str, reasoning: Reasoning, ntriples: bytes | None) -> None:
        self._memory.put(key, (reasoning, ntriples))

    def _read(self, key: str) -> Reasoning | None:
        if self.directory is None:
            return None
        try:
            record = json.loads((self.directory / f"{key}.json").read_text())
            facts = Facts.model_validate(record["facts"]) if record["facts"] is not None else None
            return Reasoning(facts, record["inconsistency"])
        except (OSError, ValueError, KeyError, TypeError, ValidationError):
            return None  # absent or damaged: reason again


def default_cache() -> ReasoningCache:
    """The process-wide cache in the XDG cache directory (read from the environment each time;
    the directory kept by the two variables it follows: every knowledge base asks, ~9 us to
    make the path anew, ~1 us to look it up)."""
    return _cache_for(_directory(os.environ.get("XDG_CACHE_HOME"), os.environ.get("HOME")))


@functools.cache
def _directory(xdg_cache_home: str | None, home: str | None) -> Path:
    return default_cache_dir()


@functools.cache
def _cache_for(directory: Path) -> ReasoningCache:
    return ReasoningCache(directory)
