"""hriplan as a service: an HTTP planning API and a SPARQL 1.1 Protocol endpoint (`hriplan serve`).

app.py routes requests (and runs background jobs); workers.py runs them in planning and query
worker processes; worker_main.py is a worker's loop, jobs.py and query_jobs.py what it does; sparql_protocol.py
speaks the SPARQL Protocol; guard.py is the edge (token, Host and Origin, body size, time and
YAML), connections.py the connection cap and head deadline; schemas.py holds the request and
response bodies, built on the project's file formats.
"""
