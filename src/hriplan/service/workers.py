"""A pool of planning worker processes, driven from the server's event loop.

OMPL's solve holds the GIL, so requests plan in separate processes (spawn context: no forked
locks or JVM state). A request waits for an idle worker in a bounded queue (full: `Busy`,
HTTP 503), has a time limit, and is cancelled when its client goes away; a cancelled or timed
out request's worker is killed (a solve cannot be interrupted otherwise) and replaced, and so
is a worker that crashes, which fails only the request it was serving.
"""

from __future__ import annotations

import asyncio
import multiprocessing
from collections.abc import Awaitable, Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from hriplan.service.worker_main import serve

SPAWN = multiprocessing.get_context("spawn")


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

    def __init__(self) -> None:
        self.conn, child = SPAWN.Pipe()
        self.process = SPAWN.Process(target=serve, args=(child,), daemon=True, name="hriplan-worker")
        self.process.start()
        child.close()
        self.busy = self.ready = False

    def wait_ready(self) -> None:
        self.conn.recv()
        self.ready = True

    def call(self, job: tuple[str, dict[str, Any]]) -> tuple:
        self.conn.send(job)
        return self.conn.recv()

    def kill(self) -> None:
        self.process.kill()
        self.process.join(5)
        self.conn.close()


class WorkerPool:
    def __init__(self, size: int, queue_limit: int) -> None:
        self.size, self.queue_limit = size, queue_limit
        self.workers: list[_Worker] = []
        self._idle: asyncio.Queue[_Worker] = asyncio.Queue()
        self._in_flight = 0  # running + waiting
        self._starting: set[asyncio.Task] = set()  # replacements being started (kept referenced)
        self._threads = ThreadPoolExecutor(max_workers=2 * size + 2, thread_name_prefix="hriplan-pipe")

    async def start(self) -> None:
        await asyncio.gather(*(self._add() for _ in range(self.size)))

    async def _add(self) -> None:
        worker = _Worker()
        self.workers.append(worker)
        try:
            await asyncio.get_running_loop().run_in_executor(self._threads, worker.wait_ready)
        except (EOFError, OSError):
            self.workers.remove(worker)
            raise
        self._idle.put_nowait(worker)

    def _replace(self, worker: _Worker) -> None:
        worker.kill()
        self.workers.remove(worker)
        task = asyncio.get_running_loop().create_task(self._add())
        self._starting.add(task)
        task.add_done_callback(self._starting.discard)

    def status(self) -> dict[str, Any]:
        return {
            "workers": [{"pid": w.process.pid, "ready": w.ready, "busy": w.busy} for w in self.workers],
            "in_flight": self._in_flight,
        }

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
            return await self._run((kind, payload), time_limit, disconnected)
        finally:
            self._in_flight -= 1

    async def _run(
        self, job: tuple[str, dict[str, Any]], time_limit: float, disconnected: Callable[[], Awaitable[bool]] | None
    ) -> tuple:
        loop = asyncio.get_running_loop()
        deadline = loop.time() + time_limit
        try:
            worker = await asyncio.wait_for(self._idle.get(), time_limit)
        except asyncio.TimeoutError:
            raise TimedOut(f"no worker became free within the request time limit of {time_limit:g} s") from None
        worker.busy = True
        call = loop.run_in_executor(self._threads, worker.call, job)
        watch = asyncio.ensure_future(_until_disconnected(disconnected))
        try:
            done, _ = await asyncio.wait(
                {call, watch}, timeout=max(deadline - loop.time(), 0.0), return_when=asyncio.FIRST_COMPLETED
            )
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
                code = worker.process.exitcode
                self._replace(worker)
                raise WorkerCrashed(
                    f"the worker serving this request died (exit code {code}); it has been replaced"
                ) from None
            worker.busy = False
            self._idle.put_nowait(worker)
            return reply
        self._replace(worker)
        if watch in done:
            raise Cancelled("the client disconnected; its request was cancelled")
        raise TimedOut(f"the request ran past its time limit of {time_limit:g} s and was stopped")

    async def close(self) -> None:
        for task in list(self._starting):
            task.cancel()
        for worker in list(self.workers):
            worker.kill()
        self.workers.clear()
        self._threads.shutdown(wait=False, cancel_futures=True)


async def _until_disconnected(disconnected: Callable[[], Awaitable[bool]] | None) -> None:
    if disconnected is None:
        await asyncio.Event().wait()
        return
    while not await disconnected():
        await asyncio.sleep(0.05)
