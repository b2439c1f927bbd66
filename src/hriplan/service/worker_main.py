"""The body of a worker process (started with the spawn context by workers.py).

BLAS thread pools are capped before numpy loads: a planning worker uses one core, and the pool
size says how many cores planning may take. Once set up the worker sends ("ready", pid, kernels
on), having frozen what it holds then out of later full garbage collections (hriplan/collector.py;
its first plan adds no second freeze). Each request is a (kind, payload) pair on the pipe;
the worker first answers ("accepted",) (a job never accepted is retried elsewhere), may announce
("deadline", seconds, why) (past it the server kills it), and ends with ("ok", body, media type)
or ("error", status, one-line message). A traceback goes to the server's log, never into an
answer. On Linux the worker gets SIGKILL when the server dies, even in the middle of a C call.
"""

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"

import contextlib  # noqa: E402 - after the thread caps
import ctypes  # noqa: E402
import signal  # noqa: E402
import sys  # noqa: E402
import traceback  # noqa: E402
from collections.abc import Iterator  # noqa: E402
from multiprocessing.connection import Connection  # noqa: E402

PR_SET_PDEATHSIG = 1


class _Serving:
    """This worker's pipe to the server (once serving) and the bytes a bounded job may add."""

    pipe: Connection | None = None
    memory_limit: int | None = None


def die_with(parent: int) -> None:
    """Ask Linux to SIGKILL this process when the server ends (a killed server leaves no worker
    spinning on a query); elsewhere the pipe's end stops an idle worker."""
    if sys.platform.startswith("linux"):
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    if os.getppid() != parent:  # the server died before the signal was set
        os._exit(1)


def announce_deadline(seconds: float, why: str) -> None:
    """Tell the server to kill this worker if the job has not answered within `seconds` from now
    (`why` is the 504 message): for work that checks no deadline itself, a regex, a VALUES join."""
    if _Serving.pipe is not None:
        _Serving.pipe.send(("deadline", seconds, why))


class OutOfMemory(Exception):
    """A bounded job needed more memory than the worker's limit."""


@contextlib.contextmanager
def bounded_memory() -> Iterator[None]:
    """Run a block with the address space capped at what the worker uses now plus its limit;
    past it an allocation fails (MemoryError), raised here as OutOfMemory, and the cap is lifted."""
    limit = _Serving.memory_limit
    if limit is None or not sys.platform.startswith("linux"):
        yield
        return
    import resource

    with open("/proc/self/statm") as statm:
        used = int(statm.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    cap = used + limit if hard == resource.RLIM_INFINITY else min(used + limit, hard)
    resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
    try:
        yield
    except MemoryError:
        raise OutOfMemory(f"the query needed more than the memory limit of {limit >> 20} MB; narrow it") from None
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


def kernels_for_worker(wanted: bool) -> bool:
    """Set this worker's compiled-kernel switch to `wanted` (not the environment's HRIPLAN_KERNELS
    it inherited) and, on, load them now (planner/kernels.py); whether they are on. A load that
    fails (numba broken, its cache not writable) leaves them off, the traceback in the server's
    log: a worker without them still plans."""
    from hriplan.robots.kernel_switch import kernels_on, use_kernels

    use_kernels(False)
    if wanted:
        from hriplan.planner.kernels import load_kernels

        try:
            load_kernels()
        except Exception:
            traceback.print_exc(file=sys.stderr)
            use_kernels(False)
    return kernels_on()


def serve(
    conn: Connection, parent: int, memory_limit: int | None = None, lane: str = "planning", kernels: bool = False
) -> None:
    """Answer requests until the server closes the pipe: planning jobs, or queries (`lane`). It
    first sends ("ready", its pid, whether it plans with the compiled kernels: `kernels` asks
    for them, kernels_for_worker)."""
    die_with(parent)
    _Serving.pipe, _Serving.memory_limit = conn, memory_limit
    from hriplan import HriplanError
    from hriplan.collector import freeze_what_lives
    from hriplan.ontology.sparql import QueryTimeout, UpdateRefused
    from hriplan.service.errors import RequestError

    if lane == "queries":
        from hriplan.service.query_jobs import JOBS
    else:
        from hriplan.service.jobs import JOBS
    from hriplan.service.negotiation import NotAcceptable

    kernels_on = kernels_for_worker(kernels)
    freeze_what_lives()  # what the imports and kernels made, out of the requests' full collections
    conn.send(("ready", os.getpid(), kernels_on))
    while True:
        try:
            kind, payload = conn.recv()
        except (EOFError, OSError):
            return
        conn.send(("accepted",))
        try:
            body, media = JOBS[kind](payload)
            reply = ("ok", body, media)
        except RequestError as exc:
            reply = ("error", exc.status, str(exc))
        except NotAcceptable as exc:
            reply = ("error", 406, str(exc))
        except QueryTimeout as exc:
            reply = ("error", 504, str(exc))
        except UpdateRefused as exc:
            reply = ("error", 403, str(exc))
        except (HriplanError, OutOfMemory) as exc:
            reply = ("error", 400, str(exc))
        except Exception as exc:
            traceback.print_exc(file=sys.stderr)
            reply = ("error", 500, f"internal error while serving {kind} ({type(exc).__name__}); see the server log")
        conn.send(reply)
