"""A pool of worker processes, driven from the server's event loop.

OMPL's solve holds the GIL, and a SPARQL regex or VALUES join runs in C or Python without ever
checking a deadline, so requests run in separate processes (spawn context: no forked locks or
JVM state) that can be killed. The server keeps two pools: planning, and a separate lane for
queries, so a query can never take a planning worker. A request waits for an idle worker in a
bounded queue (full: `Busy`, HTTP 503), has a time limit, and is cancelled when its client goes
away; a cancelled or timed out request's worker is killed and replaced. A worker may announce a
harder deadline for the rest of its job (a query's time limit): past it, it is killed too.
A worker that dies while idle is noticed at once (its process sentinel) and replaced; a request
it never accepted is retried on another worker; one that dies mid-request fails only that
request. Workers die with the server (worker_main sets a parent-death signal).
"""

from __future__ import annotations

import asyncio
import multiprocessing
import os
import time
from collections.abc import Awaitable, Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from hriplan.service.worker_main import serve

SPAWN = multiprocessing.get_context("spawn")
POLL = 0.05  # seconds between checks of a running request's deadlines and client


class PoolError(Exception):
    """A request the pool could not complete; `status` is its HTTP status."""

    status = 500

    def __init__(self, message: str) -> None:
        super().__init__(message)


class Busy(PoolError):
    status = 503


class TimedOut(PoolError):
    status = 504


class Cancelled(PoolError):
    status = 499  # the client is gone: nobody reads this


class WorkerCrashed(PoolError):
    status = 500


class _Worker:
    """One process and the pipe to it; `call` blocks (it runs in a thread)."""

    def __init__(self, memory_limit: int | None, lane: str, kernels: bool) -> None:
        self.conn, child = SPAWN.Pipe()
        self.process = SPAWN.Process(
            target=serve, args=(child, os.getpid(), memory_limit, lane, kernels), daemon=True, name=f"hriplan-{lane}"
        )
        self.process.start()
        child.close()
        self.busy = self.ready = self.dead = False
        self.kernels: bool | None = None  # planning with the compiled kernels: known once ready
        self.accepted = False  # the current job reached the worker
        self.hard_deadline: tuple[float, str] | None = None  # (monotonic time, why) announced by the worker

    def wait_ready(self) -> None:
        """Until the worker sends ("ready", pid, kernels on) (worker_main.serve)."""
        _, _, self.kernels = self.conn.recv()
        self.ready = True

    def call(self, job: tuple[str, dict[str, Any]]) -> tuple:
        self.conn.send(job)
        while True:
            message = self.conn.recv()
            if message[0] == "accepted":
                self.accepted = True
            elif message[0] == "deadline":
                self.hard_deadline = (time.monotonic() + message[1], message[2])
            else:
                return message

    def alive(self) -> bool:
        return not self.dead and self.process.is_alive()

    def kill(self) -> None:
        self.dead = True
        self.process.kill()
        self.process.join(5)
        self.conn.close()


class WorkerPool:
    def __init__(
        self,
        size: int,
        queue_limit: int,
        memory_limit: int | None = None,
        lane: str = "planning",
        kernels: bool = False,
    ) -> None:
        """`memory_limit`: bytes of address space a worker's bounded job may add (None: unbounded);
        `lane`: "planning" or "queries", the jobs its workers do (worker_main.serve); `kernels`:
        the workers plan with the compiled kernels, loaded as each starts (planning workers)."""
        self.size, self.queue_limit, self.memory_limit, self.lane = size, queue_limit, memory_limit, lane
        self.kernels = kernels
        self.workers: list[_Worker] = []
        self._idle: asyncio.Queue[_Worker] = asyncio.Queue()
        self._in_flight = 0  # running + waiting
        self._starting: set[asyncio.Task] = set()  # replacements being started (kept referenced)
        self._threads = ThreadPoolExecutor(max_workers=2 * size + 2, thread_name_prefix="hriplan-pipe")

    async def start(self) -> None:
        await asyncio.gather(*(self._add() for _ in range(self.size)))

    async def _add(self) -> None:
        worker = _Worker(self.memory_limit, self.lane, self.kernels)
        self.workers.append(worker)
        loop = asyncio.get_running_loop()
        try:
            await loop.run_in_executor(self._threads, worker.wait_ready)
        except (EOFError, OSError):
            self.workers.remove(worker)
            raise
        loop.add_reader(worker.process.sentinel, self._died, worker)
        self._idle.put_nowait(worker)

    def _died(self, worker: _Worker) -> None:
        """A worker's process ended: an idle one is replaced now; a busy one by its request."""
        asyncio.get_running_loop().remove_reader(worker.process.sentinel)
        if not worker.busy and not worker.dead:
            self._replace(worker)

    def _replace(self, worker: _Worker) -> None:
        loop = asyncio.get_running_loop()
        loop.remove_reader(worker.process.sentinel)
        worker.kill()
        if worker in self.workers:
            self.workers.remove(worker)
        task = loop.create_task(self._add())
        self._starting.add(task)
        task.add_done_callback(self._starting.discard)

    def status(self) -> dict[str, Any]:
        return {
            "workers": [
                {"pid": w.process.pid, "ready": w.ready and w.alive(), "busy": w.busy, "kernels": w.kernels}
                for w in self.workers
            ],
            "in_flight": self._in_flight,
        }

    def healthy(self) -> bool:
        """Every worker is alive and ready (false while a replacement starts)."""
        return len(self.workers) == self.size and all(w.ready and w.alive() for w in self.workers)

    async def run(
        self,
        kind: str,
        payload: dict[str, Any],
        time_limit: float,
        disconnected: Callable[[], Awaitable[bool]] | None = None,
    ) -> tuple:
        """A worker's reply ("ok", body, media) or ("error", status, message); PoolError otherwise."""
        if self._in_flight >= self.size + self.queue_limit:
            raise Busy(f"all {self.size} workers are busy and {self.queue_limit} requests are waiting; retry shortly")
        self._in_flight += 1
        try:
            deadline = time.monotonic() + time_limit
            for _attempt in range(3):  # a job no worker accepted is retried
                reply = await self._run((kind, payload), deadline, time_limit, disconnected)
                if reply is not None:
                    return reply
            raise WorkerCrashed("three workers died before accepting this request; see the server log")
        finally:
            self._in_flight -= 1

    async def _idle_worker(self, deadline: float, time_limit: float) -> _Worker:
        while True:
            try:
                worker = await asyncio.wait_for(self._idle.get(), max(deadline - time.monotonic(), 0.0))
            except asyncio.TimeoutError:
                raise TimedOut(f"no worker became free within the request time limit of {time_limit:g} s") from None
            if worker.alive():
                return worker
            if not worker.dead:  # died before its sentinel was read
                self._replace(worker)

    async def _run(
        self,
        job: tuple[str, dict[str, Any]],
        deadline: float,
        time_limit: float,
        disconnected: Callable[[], Awaitable[bool]] | None,
    ) -> tuple | None:
        """The reply, or None if the worker died before accepting the job (so it can be retried)."""
        loop = asyncio.get_running_loop()
        worker = await self._idle_worker(deadline, time_limit)
        worker.busy, worker.accepted, worker.hard_deadline = True, False, None
        call = loop.run_in_executor(self._threads, worker.call, job)
        watch = asyncio.ensure_future(_until_disconnected(disconnected))
        try:
            while True:
                done, _ = await asyncio.wait({call, watch}, timeout=POLL, return_when=asyncio.FIRST_COMPLETED)
                now = time.monotonic()
                if done or now > deadline or (worker.hard_deadline and now > worker.hard_deadline[0]):
                    break
        except asyncio.CancelledError:  # the server is shutting down or the handler was cancelled
            self._replace(worker)
            raise
        finally:
            watch.cancel()
        if call in done:
            try:
                reply = call.result()
            except (EOFError, OSError):
                worker.process.join(1)
                code, accepted = worker.process.exitcode, worker.accepted
                self._replace(worker)
                if not accepted:
                    return None
                raise WorkerCrashed(
                    f"the worker serving this request died (exit code {code}); it has been replaced"
                ) from None
            worker.busy = False
            self._idle.put_nowait(worker)
            return reply
        hard = worker.hard_deadline
        self._replace(worker)
        if watch in done:
            raise Cancelled("the client disconnected; its request was cancelled")
        if hard and time.monotonic() > hard[0]:
            raise TimedOut(hard[1])
        raise TimedOut(f"the request ran past its time limit of {time_limit:g} s and was stopped")

    async def close(self) -> None:
        loop = asyncio.get_running_loop()
        for task in list(self._starting):
            task.cancel()
        for worker in list(self.workers):
            loop.remove_reader(worker.process.sentinel)
            worker.kill()
        self.workers.clear()
        self._threads.shutdown(wait=False, cancel_futures=True)


async def _until_disconnected(disconnected: Callable[[], Awaitable[bool]] | None) -> None:
    if disconnected is None:
        await asyncio.Event().wait()
        return
    while not await disconnected():
        await asyncio.sleep(POLL)
