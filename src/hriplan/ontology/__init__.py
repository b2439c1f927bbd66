"""The OWL ontology and the knowledge base built from a situation's facts.

- `situation`: the pydantic Situation (task, robot arms, objects, people, extra facts).
- `knowledge_base.KnowledgeBase`: reasons about a situation with Pellet (once, cached by its
  facts), exports the asserted + inferred graph as Turtle and answers SPARQL (`sparql`).
- `hriplan.ttl`: the ontology; `queries/*.rq`: example queries; `situations/*.json`: examples.
"""
