"""The server's edge (plain ASGI): bearer token, body size limit, YAML bodies as JSON.

It runs before routing, so an oversized or unauthorised request is refused before anything
parses it. YAML bodies (`application/yaml`) become JSON here, so each route has one schema
(the file format) and YAML errors get the same one-line message as `hriplan` on a file.
"""

from __future__ import annotations

import hmac
import json

import yaml
from starlette.types import ASGIApp, Message, Receive, Scope, Send

YAML_TYPES = ("application/yaml", "application/x-yaml", "text/yaml", "text/x-yaml")


class _NoAliases(yaml.SafeLoader):
    """YAML without anchors and aliases: a few bytes of aliases can expand to gigabytes."""

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):
            event = self.peek_event()
            raise yaml.MarkedYAMLError(
                problem="aliases are not accepted in request bodies", problem_mark=event.start_mark
            )
        return super().compose_node(parent, index)


def yaml_to_json(body: bytes) -> bytes:
    """A YAML document as JSON bytes; a ValueError says where it is not valid YAML."""
    try:
        data = yaml.load(body.decode("utf-8"), Loader=_NoAliases)
    except UnicodeDecodeError:
        raise ValueError("body: not UTF-8 text") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        raise ValueError(
            f"body: line {mark.line + 1 if mark else '?'}: not valid YAML ({getattr(exc, 'problem', exc)})"
        ) from None
    return json.dumps(data).encode()


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
        if headers.get("content-type", "").split(";")[0].strip().lower() in YAML_TYPES:
            try:
                body = bytearray(yaml_to_json(bytes(body)))
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
