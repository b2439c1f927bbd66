"""hriplan as a service: an HTTP planning API and a SPARQL 1.1 Protocol endpoint (`hriplan serve`).

app.py routes requests; workers.py plans in worker processes; jobs.py is what a worker does;
sparql_protocol.py speaks the SPARQL Protocol; guard.py is the edge (size, YAML, token);
schemas.py holds the request and response bodies, built on the project's file formats.
"""
