"""Connections from slow or hostile clients: a cap on open connections and a deadline for a
request's head, in uvicorn's h11 protocol (uvicorn has neither: idle sockets pile up until the
file-descriptor limit locks every client out). The body's deadline is the Guard's (guard.py).
"""

from __future__ import annotations

import asyncio
import json

import h11
from uvicorn.protocols.http.h11_impl import H11Protocol

FULL = json.dumps(
    {"error": "the server has as many connections open as it allows; retry shortly", "field": None}
).encode()
REFUSAL = (
    b"HTTP/1.1 503 Service Unavailable\r\ncontent-type: application/json\r\nretry-after: 1\r\n"
    b"connection: close\r\ncontent-length: " + str(len(FULL)).encode() + b"\r\n\r\n" + FULL
)


def guarded_protocol(max_connections: int, header_timeout: float) -> type[asyncio.Protocol]:
    """uvicorn's h11 protocol that answers 503 and closes a connection beyond `max_connections`,
    and closes one whose request head has not arrived `header_timeout` s after it opened or
    after its last answer (keep-alive). Neither writes to the log: a flood would fill it."""

    class GuardedH11Protocol(H11Protocol):
        refused = False
        head_timer: asyncio.TimerHandle | None = None

        def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
            if len(self.connections) >= max_connections:
                self.refused = True
                transport.write(REFUSAL)
                transport.close()
                return
            super().connection_made(transport)
            self._arm()

        def connection_lost(self, exc: Exception | None) -> None:
            if self.refused:
                return
            self._disarm()
            super().connection_lost(exc)

        def data_received(self, data: bytes) -> None:
            if self.refused:
                return
            super().data_received(data)
            if self.conn.their_state is not h11.IDLE:  # the head has arrived
                self._disarm()

        def on_response_complete(self) -> None:
            super().on_response_complete()
            self._arm()

        def _arm(self) -> None:
            self._disarm()
            self.head_timer = self.loop.call_later(header_timeout, self._head_late)

        def _disarm(self) -> None:
            if self.head_timer is not None:
                self.head_timer.cancel()
                self.head_timer = None

        def _head_late(self) -> None:
            self.head_timer = None
            if self.conn.their_state is h11.IDLE and not self.transport.is_closing():
                self.transport.close()

    return GuardedH11Protocol
