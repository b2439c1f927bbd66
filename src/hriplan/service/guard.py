"""The server's edge (plain ASGI): bearer token, body size limit, one reader for bodies.

It runs before routing, so an oversized or unauthorised request is refused before anything
parses it. JSON and YAML bodies (`application/yaml`) are read here by the reader `hriplan` uses
for files and handed on as JSON, so each route has one schema (the file format) and a body gets
the same one-line message as the same text in a file (a key given twice included).
"""

from __future__ import annotations

import hmac
import json

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from hriplan import HriplanError
from hriplan.files import parse_data

YAML_TYPES = ("application/yaml", "application/x-yaml", "text/yaml", "text/x-yaml")


def body_as_json(body: bytes, syntax: str) -> bytes:
    """A JSON or YAML request body as JSON bytes, read by the same reader as files (a key given
    twice, a value JSON has no type for, deep nesting: one line); YAML aliases are refused, since a
    few bytes of them can expand to gigabytes. A ValueError says what is wrong."""
    try:
        text = body.decode("utf-8")
    except UnicodeDecodeError:
        raise ValueError("body: not UTF-8 text") from None
    try:
        return json.dumps(parse_data(text, syntax, aliases=False)).encode()
    except HriplanError as exc:
        raise ValueError(f"body: {exc}") from None


async def _refuse(send: Send, status: int, message: str, headers: list[tuple[bytes, bytes]] = ()) -> None:  # type: ignore[assignment]
    body = json.dumps({"error": message, "field": None}).encode()
    await send(
        {
            "type": "http.response.start",
            "status": status,
            "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode()), *headers],
        }
    )
    await send({"type": "http.response.body", "body": body})


class Guard:
    def __init__(self, app: ASGIApp, body_limit: int, token: str | None) -> None:
        self.app, self.body_limit, self.token = app, body_limit, token

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope["headers"]}
        if self.token is not None and not self._authorised(headers.get("authorization", "")):
            await _refuse(
                send,
                401,
                "a bearer token is required (Authorization: Bearer TOKEN)",
                [(b"www-authenticate", b"Bearer")],
            )
            return
        declared = headers.get("content-length", "")
        if declared.isdigit() and int(declared) > self.body_limit:
            await _refuse(send, 413, f"the request body is larger than the limit of {self.body_limit} bytes")
            return
        body, more = bytearray(), True
        while more:
            message = await receive()
            if message["type"] == "http.disconnect":
                return
            body += message.get("body", b"")
            more = message.get("more_body", False)
            if len(body) > self.body_limit:
                await _refuse(send, 413, f"the request body is larger than the limit of {self.body_limit} bytes")
                return
        content_type = headers.get("content-type", "").split(";")[0].strip().lower()
        if content_type in YAML_TYPES or (content_type == "application/json" and body.strip()):
            try:
                body = bytearray(body_as_json(bytes(body), "json" if content_type == "application/json" else "yaml"))
            except ValueError as exc:
                await _refuse(send, 400, str(exc))
                return
            scope = dict(
                scope,
                headers=[(k, v) for k, v in scope["headers"] if k.lower() not in (b"content-type", b"content-length")]
                + [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())],
            )
        await self.app(scope, _replay(bytes(body), receive), send)

    def _authorised(self, header: str) -> bool:
        scheme, _, credential = header.partition(" ")
        return scheme.lower() == "bearer" and hmac.compare_digest(credential.strip().encode(), self.token.encode())  # type: ignore[union-attr]


def _replay(body: bytes, receive: Receive) -> Receive:
    """Hand the buffered body to the app once, then the real channel (to see a disconnect)."""
    sent = False

    async def replayed() -> Message:
        nonlocal sent
        if not sent:
            sent = True
            return {"type": "http.request", "body": body, "more_body": False}
        return await receive()

    return replayed
