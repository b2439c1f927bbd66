"""The body of a worker process (started with the spawn context by workers.py).

BLAS thread pools are capped before numpy loads: a planning worker uses one core, and the pool
size says how many cores planning may take. Each request is a (kind, payload) pair on the pipe;
each answer is ("ok", body, media type) or ("error", status, one-line message). A traceback
goes to the server's log, never into an answer.
"""

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"

import sys  # noqa: E402 - after the thread caps
import traceback  # noqa: E402
from multiprocessing.connection import Connection  # noqa: E402


def serve(conn: Connection) -> None:
    """Answer requests until the server closes the pipe."""
    from hriplan import HriplanError
    from hriplan.ontology.sparql import QueryTimeout
    from hriplan.service.errors import RequestError
    from hriplan.service.jobs import JOBS
    from hriplan.service.negotiation import NotAcceptable

    conn.send(("ready", os.getpid()))
    while True:
        try:
            kind, payload = conn.recv()
        except (EOFError, OSError):
            return
        try:
            body, media = JOBS[kind](payload)
            reply = ("ok", body, media)
        except RequestError as exc:
            reply = ("error", exc.status, str(exc))
        except NotAcceptable as exc:
            reply = ("error", 406, str(exc))
        except QueryTimeout as exc:
            reply = ("error", 504, str(exc))
        except HriplanError as exc:
            reply = ("error", 400, str(exc))
        except Exception as exc:
            traceback.print_exc(file=sys.stderr)
            reply = ("error", 500, f"internal error while serving {kind} ({type(exc).__name__}); see the server log")
        conn.send(reply)
