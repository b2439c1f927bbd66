"""The OWL ontology and the knowledge base built from a task's facts."""
