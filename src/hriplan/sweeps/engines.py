"""Where variants run: local worker processes (the default) or Ray actors (local runtime or cluster).

Both engines give each worker one variant at a time, so a worker that dies is known to have been
running that variant: it is retried once (alone, on a fresh worker) and then recorded as failed
with the reason. A variant whose planning raises is recorded as an error, not retried. Workers are
long-lived and keep their planning sessions (see worker.py).
"""

from __future__ import annotations

import multiprocessing
import os
import sys
from collections import Counter, deque
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Protocol

from hriplan.planner.outcome import Status
from hriplan.sweeps.variants import Variant
from hriplan.sweeps.worker import Row, failure_rows, run_variant, variant_columns

Work = Callable[[Variant, bool], list[Row]]
Deliver = Callable[[Variant, list[Row]], None]

ATTEMPTS = 2  # a variant whose worker dies is retried once


class Engine(Protocol):
    def run(self, variants: list[Variant], plan: bool, deliver: Deliver, work: Work = run_variant) -> None: ...


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


def _single_threaded_blas() -> None:
    """One BLAS thread per worker: workers are the parallelism (children inherit the setting)."""
    for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(name, "1")


class LocalEngine:
    """Worker processes on this machine (spawned, one per core by default)."""

    def __init__(self, workers: int | None = None) -> None:
        self.workers = max(1, workers or os.cpu_count() or 1)

    def _pool(self) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(self.workers, mp_context=multiprocessing.get_context("spawn"))

    def run(self, variants: list[Variant], plan: bool, deliver: Deliver, work: Work = run_variant) -> None:
        _single_threaded_blas()
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
                    pool.shutdown(wait=False)
                    pool = self._pool()
                    continue
                for future in done:
                    variant = running.pop(future)
                    deliver(variant, _outcome(variant, future))
        except BaseException:  # Ctrl-C or a failure here: stop the workers, keep what was delivered
            pool.shutdown(wait=False, cancel_futures=True)
            for process in (getattr(pool, "_processes", None) or {}).values():
                process.terminate()
            raise
        pool.shutdown(wait=True)


class SessionActor:
    """A Ray actor: a long-lived worker process holding its planning sessions."""

    def __init__(self, work: Work) -> None:
        self.work = work

    def run(self, variant: Variant, plan: bool) -> list[Row]:
        return self.work(variant, plan)


class RayEngine:
    """Ray actors, one per CPU: a local runtime (no dashboard) or an existing cluster."""

    def __init__(self, workers: int | None = None, address: str | None = None) -> None:
        self.workers, self.address = workers, address

    def _connect(self) -> Any:
        import ray

        if ray.is_initialized():
            return ray, False
        if self.address:
            ray.init(address=self.address, logging_level="ERROR", log_to_driver=False)
        else:
            _single_threaded_blas()
            threads = {k: os.environ[k] for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
            env = {
                "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)
            } | threads  # workers import what the driver does
            # Ray resolves 127.0.0.1 to the node's address by design (ray-project/ray#26293): its
            # services listen there, not on loopback; no dashboard is started.
            ray.init(
                num_cpus=self.workers or os.cpu_count(),
                include_dashboard=False,
                runtime_env={"env_vars": env},
                logging_level="ERROR",
                log_to_driver=False,
            )
        return ray, True

    def run(self, variants: list[Variant], plan: bool, deliver: Deliver, work: Work = run_variant) -> None:
        ray, started = self._connect()
        actor_class = ray.remote(num_cpus=1, max_restarts=0)(SessionActor)
        count = self.workers or max(1, int(ray.cluster_resources().get("CPU", 1)))
        idle = [actor_class.remote(work) for _ in range(min(count, len(variants)))]
        queue, attempts = deque(variants), Counter()
        running: dict[Any, tuple[Any, Variant]] = {}
        try:
            while queue or running:
                while queue and idle:
                    actor, variant = idle.pop(), queue.popleft()
                    running[actor.run.remote(variant, plan)] = (actor, variant)
                ready, _ = ray.wait(list(running), num_returns=1)
                actor, variant = running.pop(ready[0])
                try:
                    rows = ray.get(ready[0])
                except ray.exceptions.RayActorError as exc:
                    ray.kill(actor)
                    idle.append(actor_class.remote(work))
                    attempts[variant.key] += 1
                    if attempts[variant.key] < ATTEMPTS:
                        queue.appendleft(variant)
                    else:
                        deliver(variant, _died(variant, str(exc).splitlines()[0][:200]))
                    continue
                except ray.exceptions.RayTaskError as exc:
                    rows = _error_rows(variant, exc.cause or exc)
                idle.append(actor)
                deliver(variant, rows)
        finally:
            for actor, _ in running.values():
                ray.kill(actor)
            for actor in idle:
                ray.kill(actor)
            if started:
                ray.shutdown()
