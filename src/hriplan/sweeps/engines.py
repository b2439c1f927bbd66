"""Where variants run: local worker processes (the default) or Ray actors (local runtime or cluster).

An engine is started before anything is written (joining a cluster and starting its first actor
fail as one line, within a bound), runs the variants, and is stopped after (also on Ctrl-C).

Both engines give each worker one variant at a time, so a worker that dies is known to have been
running that variant: it is retried once (alone, on a fresh worker) and then recorded as failed
with the reason. A variant whose planning raises is recorded as an error, not retried. Workers are
long-lived and keep their planning sessions (see worker.py).
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import socket
import sys
import tempfile
import threading
from collections import Counter, deque
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Any, Protocol

from hriplan import HriplanError
from hriplan.blas_threads import VARIABLES, single_threaded_blas
from hriplan.planner.outcome import Status
from hriplan.sweeps.variants import Variant
from hriplan.sweeps.worker import Row, failure_rows, run_variant, variant_columns

Work = Callable[[Variant, bool], list[Row]]
Deliver = Callable[[Variant, list[Row]], None]

ATTEMPTS = 2  # a variant whose worker dies is retried once


class Engine(Protocol):
    def start(self, work: Work, count: int) -> None:
        """Get ready to run `count` variants (connect, start workers): a failure is one line."""

    def run(self, variants: list[Variant], plan: bool, deliver: Deliver, work: Work = run_variant) -> None: ...

    def stop(self) -> None:
        """Stop the workers (also after a failure or Ctrl-C)."""


def _error_rows(variant: Variant, exc: BaseException) -> list[Row]:
    return [
        variant_columns(variant)
        | {"step": "", "step_index": -1, "status": Status.ERROR.value, "reason": f"{type(exc).__name__}: {exc}"}
    ]


def _outcome(variant: Variant, future: Future) -> list[Row]:
    """A finished variant's rows, or an error row if its planning raised."""
    exc = future.exception()
    return _error_rows(variant, exc) if exc else future.result()


def _died(variant: Variant, detail: str) -> list[Row]:
    return failure_rows(variant, f"its worker died on each of {ATTEMPTS} attempts ({detail})")


class LocalEngine:
    """Worker processes on this machine (spawned, one per core by default)."""

    def __init__(self, workers: int | None = None) -> None:
        self.workers = max(1, workers or os.cpu_count() or 1)

    def start(self, work: Work, count: int) -> None:
        """Nothing to prepare: the pool starts with the run."""

    def stop(self) -> None:
        """The run stops its own pool."""

    def _pool(self) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(self.workers, mp_context=multiprocessing.get_context("spawn"))

    def run(self, variants: list[Variant], plan: bool, deliver: Deliver, work: Work = run_variant) -> None:
        single_threaded_blas()
        queue, alone = deque(variants), deque()  # after a death, suspects rerun one at a time
        attempts: Counter[str] = Counter()
        running: dict[Future, Variant] = {}
        pool = self._pool()

        def submit(variant: Variant, source: deque) -> bool:
            """Start a variant; False (and the variant back in `source`) if the pool has broken."""
            try:
                running[pool.submit(work, variant, plan)] = variant
            except BrokenProcessPool:  # a worker died since the last wait: found out here first
                source.appendleft(variant)
                return False
            return True

        try:
            while queue or alone or running:
                broken = False
                if alone and not running:
                    broken = not submit(alone.popleft(), alone)
                while not broken and not alone and queue and len(running) < self.workers:
                    broken = not submit(queue.popleft(), queue)
                done, _ = wait(running, return_when=FIRST_COMPLETED) if running else (set(), set())
                if broken or any(isinstance(f.exception(), BrokenProcessPool) for f in done):
                    wait(running)  # every variant still running went down with the pool
                    for future, variant in running.items():
                        if not isinstance(future.exception(), BrokenProcessPool):
                            deliver(variant, _outcome(variant, future))  # it finished before the pool broke
                            continue
                        attempts[variant.key] += 1
                        if attempts[variant.key] >= ATTEMPTS:
                            deliver(variant, _died(variant, "the process ended abruptly"))
                        else:
                            alone.append(variant)
                    running.clear()
                    _stop(pool)
                    pool = self._pool()
                    continue
                for future in done:
                    variant = running.pop(future)
                    deliver(variant, _outcome(variant, future))
        except BaseException:  # Ctrl-C or a failure here: stop the workers, keep what was delivered
            _stop(pool)
            raise
        pool.shutdown(wait=True)


def _stop(pool: ProcessPoolExecutor) -> None:
    """Shut `pool` down without waiting, and end its workers. A broken pool's manager ends those
    it knows of, but a worker started by a submit racing the break waits for work for ever, and the
    interpreter's exit then waits for it (a test run once hung there after a worker died). The
    workers are read before the shutdown, which forgets them."""
    workers = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in workers:
        process.terminate()


class SessionActor:
    """A Ray actor: a long-lived worker process holding its planning sessions."""

    def __init__(self, work: Work) -> None:
        self.work = work

    def ready(self) -> str:
        """The hriplan version this worker imported (the driver checks it is its own)."""
        from hriplan import __version__

        return __version__

    def run(self, variant: Variant, plan: bool) -> list[Row]:
        return self.work(variant, plan)


START_TIMEOUT = 120.0  # seconds for a cluster's first actor to start (runtime_env set-up included)
PROBE_TIMEOUT = 5.0  # seconds for the head node's port to answer at all
JOIN_RETRIES = "10"  # Ray's connection attempts (about 1 s each; its default 20) when joining


def _blas_threads() -> dict[str, str]:
    single_threaded_blas()
    return {k: os.environ[k] for k in VARIABLES}


def cluster_runtime_env(extra: dict[str, Any] | None = None) -> dict[str, Any]:
    """What a cluster's workers get: this hriplan (its package uploaded, so nodes run the driver's
    code and version, needing only its dependencies) and one BLAS thread each; `extra` (a Ray
    runtime_env: pip, py_modules, env_vars, working_dir, ...) replaces these keys."""
    import hriplan

    return {"py_modules": [str(Path(hriplan.__file__).parent)], "env_vars": _blas_threads()} | (extra or {})


@contextlib.contextmanager
def _captured_stderr() -> Iterator[Callable[[], str]]:
    """Ray's C++ core logs straight to file descriptor 2 (connection retries; on a machine with no
    route out, a warning that it falls back to the host name for its own address): keep them
    aside (read back to explain a failure) so the sweep's stderr stays its own lines."""
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile("w+") as log:
        os.dup2(log.fileno(), 2)
        try:
            yield lambda: (log.seek(0), log.read())[1]
        finally:
            sys.stderr.flush()
            os.dup2(saved, 2)
            os.close(saved)


@contextlib.contextmanager
def _own_sigterm() -> Iterator[None]:
    """ray.init replaces the SIGTERM handler with a bare exit: keep the caller's (the sweep stops
    on SIGTERM as on Ctrl-C, keeping its rows)."""
    main = threading.current_thread() is threading.main_thread()
    previous = signal.getsignal(signal.SIGTERM) if main else None
    try:
        yield
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _join(ray: Any, address: str, runtime_env: dict[str, Any], logged: Callable[[], str]) -> None:
    """Join a cluster, or one line saying why not, within about 20 s and before anything is written
    (`logged` reads what Ray wrote to stderr meanwhile, to tell a refused token)."""
    from ray._private.services import canonicalize_bootstrap_address_or_die

    try:
        gcs = canonicalize_bootstrap_address_or_die(address)
    except ValueError:
        raise HriplanError(
            f"--ray-address {address!r} is not HOST:PORT (the address `ray start --head` prints)"
        ) from None
    except ConnectionError as exc:
        raise HriplanError(f"--ray-address {address}: {exc}".splitlines()[0]) from None
    host, _, port = gcs.rpartition(":")
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=PROBE_TIMEOUT).close()
    except (OSError, ValueError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
        raise HriplanError(f"cannot reach the Ray cluster at {address} ({gcs}: {reason})") from None
    os.environ.setdefault("RAY_gcs_server_port_wait_time_s", JOIN_RETRIES)
    try:
        ray.init(address=gcs, runtime_env=runtime_env, logging_level="ERROR", log_to_driver=False)
        return
    except Exception as exc:  # Ray raises many kinds: each becomes one line
        failure, log = exc, logged()
    if "InvalidAuthToken" in log or "Unauthenticated" in log:
        raise HriplanError(
            f"the Ray cluster at {address} refused this client's token: set RAY_AUTH_MODE=token and "
            "RAY_AUTH_TOKEN (or RAY_AUTH_TOKEN_PATH) to the cluster's token"
        )
    raise HriplanError(f"cannot join the Ray cluster at {address}: {str(failure).splitlines()[0]}")


class RayEngine:
    """Ray actors, one per CPU the cluster has: a local runtime (no dashboard), or a cluster
    joined with --ray-address (never RAY_ADDRESS alone)."""

    def __init__(
        self,
        workers: int | None = None,
        address: str | None = None,
        runtime_env: dict[str, Any] | None = None,
        start_timeout: float = START_TIMEOUT,
    ) -> None:
        self.workers, self.address, self.runtime_env, self.start_timeout = workers, address, runtime_env, start_timeout
        self._started = False  # this engine started (or joined) Ray, so it shuts it down
        self._actors: list[Any] = []  # ready to take a variant
        self._starting: dict[Any, Any] = {}  # an actor's ready() -> the actor
        self._actor_class: Any = None

    def _connect(self) -> Any:
        import ray

        if ray.is_initialized():
            return ray
        with _own_sigterm(), _captured_stderr() as logged:
            self._init(ray, logged)
        self._started = True
        return ray

    def _init(self, ray: Any, logged: Callable[[], str]) -> None:
        if self.address:
            _join(ray, self.address, cluster_runtime_env(self.runtime_env), logged)
        else:
            env = {"PYTHONPATH": os.pathsep.join(p for p in sys.path if p)} | _blas_threads()  # as the driver
            # address="local": a runtime of our own even when RAY_ADDRESS names a cluster (joining
            # one is --ray-address). Ray resolves 127.0.0.1 to the node's address by design
            # (ray-project/ray#26293): its services listen there, not on loopback.
            ray.init(
                address="local",
                num_cpus=self.workers or os.cpu_count(),
                include_dashboard=False,
                runtime_env={"env_vars": env} | (self.runtime_env or {}),
                logging_level="ERROR",
                log_to_driver=False,
            )

    def start(self, work: Work, count: int) -> None:
        """Connect and start the actors: as many as asked, but no more than the cluster's CPUs
        and the variants; one line if none starts within `start_timeout`."""
        ray = self._connect()
        try:
            cpus = int(ray.cluster_resources().get("CPU", 0))
            if cpus < 1:
                raise HriplanError("the Ray cluster has no CPU to run a worker on")
            self._actor_class = ray.remote(num_cpus=1, max_restarts=0)(SessionActor)
            for _ in range(max(1, min(self.workers or cpus, cpus, count))):
                actor = self._actor_class.remote(work)
                self._starting[actor.ready.remote()] = actor
            ready, _ = ray.wait(list(self._starting), num_returns=1, timeout=self.start_timeout)
            if not ready:
                raise HriplanError(
                    f"no Ray worker started within {self.start_timeout:.0f} s (the cluster has {cpus} CPUs: "
                    "are other jobs holding them?)"
                )
            self._started_actor(ray, ready[0], strict=True)
        except BaseException:
            self.stop()
            raise

    def _started_actor(self, ray: Any, ready: Any, strict: bool = False) -> None:
        """An actor's start finished: ready for variants, or (strict: one line) why it cannot run."""
        actor = self._starting.pop(ready)
        try:
            version = ray.get(ready)
        except ray.exceptions.RayError as exc:
            ray.kill(actor)
            if strict:
                raise HriplanError(f"a Ray worker could not start: {str(exc).strip().splitlines()[-1]}") from None
            return
        from hriplan import __version__

        if version != __version__:
            ray.kill(actor)
            raise HriplanError(f"a Ray worker runs hriplan {version}, this driver {__version__}: see docs/sweeps.md")
        self._actors.append(actor)

    def stop(self) -> None:
        """Kill the actors; shut Ray down if this engine started it."""
        import ray

        if ray.is_initialized():
            for actor in [*self._actors, *self._starting.values()]:
                ray.kill(actor)
            if self._started:
                ray.shutdown()
        self._actors, self._starting, self._started, self._actor_class = [], {}, False, None

    def run(self, variants: list[Variant], plan: bool, deliver: Deliver, work: Work = run_variant) -> None:
        owned = self._actor_class is None
        if owned:
            self.start(work, len(variants))
        import ray

        queue, attempts = deque(variants), Counter()
        running: dict[Any, tuple[Any, Variant]] = {}
        try:
            while queue or running:
                while queue and self._actors:
                    actor, variant = self._actors.pop(), queue.popleft()
                    running[actor.run.remote(variant, plan)] = (actor, variant)
                ready, _ = ray.wait(list(running) + list(self._starting), num_returns=1)
                if ready[0] in self._starting:
                    self._started_actor(ray, ready[0])
                    continue
                actor, variant = running.pop(ready[0])
                try:
                    rows = ray.get(ready[0])
                except ray.exceptions.RayActorError as exc:
                    ray.kill(actor)
                    self._actors.append(self._actor_class.remote(work))
                    attempts[variant.key] += 1
                    if attempts[variant.key] < ATTEMPTS:
                        queue.appendleft(variant)
                    else:
                        deliver(variant, _died(variant, str(exc).splitlines()[0][:200]))
                    continue
                except ray.exceptions.RayTaskError as exc:
                    rows = _error_rows(variant, exc.cause or exc)
                self._actors.append(actor)
                deliver(variant, rows)
        finally:
            self._actors += [actor for actor, _ in running.values()]
            if owned:
                self.stop()
