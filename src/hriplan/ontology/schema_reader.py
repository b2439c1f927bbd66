"""The ontology's schema read from its triples (rdflib): only when no copy of it is on disk for
this version of the ontology (schema.py), so a warm process never imports rdflib."""

from __future__ import annotations

from collections.abc import Iterator

import rdflib
from rdflib.collection import Collection
from rdflib.namespace import OWL, RDF, RDFS, XSD

from hriplan.ontology.facts import Value
from hriplan.ontology.schema import Schema
from hriplan.ontology.vocabulary import NAMESPACE

DATA_TYPES: dict[str, tuple[type, ...]] = {
    str(XSD.boolean): (bool,),
    str(XSD.string): (str,),
    str(XSD.integer): (int,),
    str(XSD.decimal): (int, float),
    str(XSD.double): (int, float),
    str(XSD.float): (int, float),
}


def read_schema(graph: rdflib.Graph) -> Schema:
    """The schema of the ontology's triples."""
    return _Reader(graph).schema


class _Reader:
    def __init__(self, graph: rdflib.Graph) -> None:
        self.graph = graph
        self.schema = schema = Schema()
        schema.terms = {_local(s) for s in graph.subjects() if _own(s)}
        schema.classes = {_local(c) for c in graph.subjects(RDF.type, OWL.Class) if _own(c)}
        schema.object_properties = {_local(p) for p in graph.subjects(RDF.type, OWL.ObjectProperty) if _own(p)}
        schema.data_properties = {_local(p) for p in graph.subjects(RDF.type, OWL.DatatypeProperty) if _own(p)}
        self._classes()
        self._properties()
        self._individuals()
        for group in graph.subjects(RDF.type, OWL.AllDisjointClasses):
            schema.disjoint.append(sorted(_local(m) for m in self._list(graph.value(group, OWL.members))))
        for a, b in graph.subject_objects(OWL.disjointWith):
            schema.disjoint.append(sorted([_local(a), _local(b)]))
        for cls in graph.subjects(OWL.equivalentClass):
            if (cls, RDF.type, RDFS.Datatype) not in graph:
                schema.unsupported.append(f"owl:equivalentClass on {_local(cls)}")

    def _classes(self) -> None:
        schema, direct = self.schema, {c: set() for c in self.schema.classes}
        for cls in schema.classes:
            for sup in self.graph.objects(_iri(cls), RDFS.subClassOf):
                for named, restriction in self._expression(sup, cls):
                    if named is not None:
                        direct[cls].add(named)
                    else:
                        schema.implied_values.setdefault(cls, []).append(restriction)  # type: ignore[arg-type]
        for cls in schema.classes:
            schema.ancestors[cls] = _closure(cls, direct)

    def _expression(self, node: rdflib.term.Node, cls: str) -> Iterator[tuple[str | None, tuple[str, Value] | None]]:
        """A superclass expression as named classes and (property, value) pairs; others are unsupported."""
        if isinstance(node, rdflib.URIRef):
            if _own(node):
                yield _local(node), None
            elif node != OWL.Thing:
                self.schema.unsupported.append(f"superclass {node} of {cls}")
            return
        members = self.graph.value(node, OWL.intersectionOf)
        on_property, value = self.graph.value(node, OWL.onProperty), self.graph.value(node, OWL.hasValue)
        if members is not None:
            for member in self._list(members):
                yield from self._expression(member, cls)
        elif on_property is not None and value is not None:
            yield None, (_local(on_property), _value(value))
        else:
            kinds = sorted(_local(p) for p in self.graph.predicates(node) if p != RDF.type)
            self.schema.unsupported.append(f"a superclass of {cls} using {', '.join(kinds)}")

    def _properties(self) -> None:
        schema, graph = self.schema, self.graph
        direct: dict[str, set[str]] = {}
        for prop in schema.object_properties | schema.data_properties:
            node = _iri(prop)
            direct[prop] = {_local(s) for s in graph.objects(node, RDFS.subPropertyOf) if _own(s)}
            schema.domains[prop] = {_local(d) for d in graph.objects(node, RDFS.domain) if _own(d)}
            if (node, RDF.type, OWL.FunctionalProperty) in graph:
                schema.functional.add(prop)
            for chain in graph.objects(node, OWL.propertyChainAxiom):
                schema.chains.setdefault(prop, []).append(tuple(_local(p) for p in self._list(chain)))
            for other in graph.objects(node, OWL.inverseOf):
                schema.inverse[prop], schema.inverse[_local(other)] = _local(other), prop
            for kind in (OWL.TransitiveProperty, OWL.SymmetricProperty, OWL.InverseFunctionalProperty):
                if (node, RDF.type, kind) in graph:
                    schema.unsupported.append(f"{_local(kind)} {prop}")
            ranges = list(graph.objects(node, RDFS.range))
            if prop in schema.object_properties:
                schema.ranges[prop] = {_local(r) for r in ranges if _own(r)}
            for r in ranges if prop in schema.data_properties else ():
                schema.data_ranges[prop] = DATA_TYPES.get(str(r)) or self._one_of(r) or (object,)
        for prop in direct:
            schema.super_properties[prop] = _closure(prop, direct)

    def _one_of(self, datatype: rdflib.term.Node) -> frozenset[Value] | None:
        for equivalent in self.graph.objects(datatype, OWL.equivalentClass):
            values = self.graph.value(equivalent, OWL.oneOf)
            if values is not None:
                return frozenset(_value(v) for v in self._list(values))
        return None

    def _individuals(self) -> None:
        schema, graph, facts = self.schema, self.graph, self.schema.individuals
        for individual in graph.subjects(RDF.type, OWL.NamedIndividual):
            name = _local(individual)
            facts.types[name] = sorted({_local(t) for t in graph.objects(individual, RDF.type) if _own(t)})
            values: dict[str, list[Value]] = {}
            for prop, value in graph.predicate_objects(individual):
                if _own(prop) and _local(prop) in schema.object_properties | schema.data_properties:
                    values.setdefault(_local(prop), []).append(
                        _local(value) if isinstance(value, rdflib.URIRef) else _value(value)
                    )
            facts.values[name] = values
        for subject, label in graph.subject_objects(RDFS.label):
            name = _local(subject) if _own(subject) else None
            if name is not None and (name in schema.classes or name in schema.super_properties or name in facts.types):
                facts.labels.setdefault(name, str(label))

    def _list(self, node: rdflib.term.Node | None) -> list[rdflib.term.Node]:
        return list(Collection(self.graph, node)) if node is not None else []


def _closure(start: str, direct: dict[str, set[str]]) -> set[str]:
    seen, todo = {start}, [start]
    while todo:
        for parent in direct.get(todo.pop(), ()):
            if parent not in seen:
                seen.add(parent)
                todo.append(parent)
    return seen


def _own(node: object) -> bool:
    return isinstance(node, rdflib.URIRef) and str(node).startswith(NAMESPACE)


def _local(node: rdflib.term.Node) -> str:
    text = str(node)
    return text[len(NAMESPACE) :] if text.startswith(NAMESPACE) else text.rsplit("#", 1)[-1]


def _iri(name: str) -> rdflib.URIRef:
    return rdflib.URIRef(NAMESPACE + name)


def _value(literal: rdflib.term.Node) -> Value:
    """A literal as owlready2 gives it: decimals as floats, integers, booleans, strings."""
    if not isinstance(literal, rdflib.Literal):
        return _local(literal)
    python = literal.toPython()
    if isinstance(python, bool | int | str):
        return python
    try:
        return float(python)
    except (TypeError, ValueError):
        return str(literal)
