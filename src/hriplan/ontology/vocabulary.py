"""Where the ontology lives and how its terms are named: namespaces, prefixes, the Turtle file.

owlready2 reads N-Triples but not Turtle, so the Turtle file is converted once per version of
its text (keyed by the text's hash, which also keys the reasoning cache). The robot individuals
are generated from the robot descriptions (robot_individuals.py) and read with the file: the
hash covers both, so a changed description is a new ontology version.
"""

from __future__ import annotations

import functools
import hashlib
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from hriplan import HriplanError
from hriplan.ontology.robot_individuals import robot_turtle
from hriplan.recent import Recent

if TYPE_CHECKING:
    import rdflib

NAMESPACE = "https://hriplan.org/ontology#"
SITUATION_NAMESPACE = "https://hriplan.org/situation#"
RULES_NAMESPACE = "https://hriplan.org/rules#"
ONTOLOGY_IRI = "https://hriplan.org/ontology"
ONTOLOGY_PATH = Path(__file__).with_name("hriplan.ttl")

PREFIXES = {
    "hp": NAMESPACE,
    "sit": SITUATION_NAMESPACE,
    "rule": RULES_NAMESPACE,
    "rdf": "http://www.w3.org/1999/02/22-rdf-syntax-ns#",
    "rdfs": "http://www.w3.org/2000/01/rdf-schema#",
    "owl": "http://www.w3.org/2002/07/owl#",
    "xsd": "http://www.w3.org/2001/XMLSchema#",
    "swrl": "http://www.w3.org/2003/11/swrl#",
    "swrlb": "http://www.w3.org/2003/11/swrlb#",
    "dcterms": "http://purl.org/dc/terms/",
    "qudt": "http://qudt.org/schema/qudt/",
    "unit": "http://qudt.org/vocab/unit/",
}


@dataclass(frozen=True)
class OntologySource:
    """One version of the ontology: the file, the robot individuals generated with it, the hash of
    both, their triples, and them as N-Triples (for owlready2)."""

    path: Path
    robots: str  # Turtle of the robot individuals (robot_individuals.py)
    digest: str

    @property
    def ntriples(self) -> bytes:
        return _to_ntriples(self.path, self.robots, self.digest)

    @property
    def graph(self) -> rdflib.Graph:
        """The ontology's triples (parsed once per version; do not modify)."""
        return _parse(self.path, self.robots, self.digest)


def ontology_source(path: str | Path | None = None) -> OntologySource:
    """The ontology at `path` (default: the packaged one) with the described robots, identified by
    the hash of both. The hash is kept by the file's identity (device, inode, size, modification
    and change times in ns) and the robots' Turtle: every knowledge base and safety policy of a
    re-plan asks (~60 us to read and hash, ~5 us to stat); an edited file is hashed anew."""
    path = Path(path) if path is not None else ONTOLOGY_PATH
    try:
        stat = path.stat()
    except OSError as exc:
        raise HriplanError(f"cannot read ontology {path}: {exc.strerror or exc}") from None
    robots = robot_turtle()
    key = (str(path), stat.st_dev, stat.st_ino, stat.st_size, stat.st_mtime_ns, stat.st_ctime_ns, robots)
    digest = _DIGESTS.get(key)
    if digest is None:
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise HriplanError(f"cannot read ontology {path}: {exc.strerror or exc}") from None
        digest = hashlib.sha256(data + b"\0" + robots.encode()).hexdigest()
        _DIGESTS.put(key, digest)
    return OntologySource(path, robots, digest)


# Ontology digests by file identity and robots (`ontology_source`).
_DIGESTS: Recent[tuple, str] = Recent(16)


@functools.lru_cache(maxsize=8)
def _to_ntriples(path: Path, robots: str, digest: str) -> bytes:
    return _parse(path, robots, digest).serialize(format="nt", encoding="utf-8")


@functools.lru_cache(maxsize=8)
def _parse(path: Path, robots: str, digest: str) -> rdflib.Graph:
    import rdflib  # not needed when every result is cached

    graph = rdflib.Graph()
    try:
        graph.parse(path, format="turtle")
    except Exception as exc:
        raise HriplanError(f"{path}: not valid Turtle: {str(exc).splitlines()[0]}") from None
    graph.parse(data=robots, format="turtle")
    return graph
