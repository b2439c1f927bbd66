"""The OWL ontology and the knowledge base built from a situation's facts.

- `situation`: the pydantic Situation (task, robot arms, objects, people, extra facts).
- `relations`: relations that depend on numbers (near a person), measured from the geometry
  against thresholds in the ontology and asserted as qualitative facts with their measurement.
- `knowledge_base.KnowledgeBase`: reasons about a situation once per qualitative situation
  (cached), in process (`schema` + `rule_engine`) or with Pellet (`reasoner`, `world`), exports
  the asserted + inferred graph as Turtle and answers SPARQL (`sparql`).
- `hriplan.ttl`: the ontology; `queries/*.rq`: example queries; `situations/*.json`: examples.
- `export`: the ontology as Turtle, RDF/XML or OWL/XML for OWL tools, optionally with an
  alignment to another ontology (`alignment/*.ttl`: SOMA and DUL).
"""
