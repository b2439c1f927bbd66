"""The server's edge (plain ASGI): bearer token, Host and Origin, body size and time limits,
one reader for bodies.

It runs before routing, so an oversized or unauthorised request is refused before anything
parses it. Without a token (the loopback default) the Host header must name loopback at the
server's port (or a configured name) and a browser's Origin must be the server's own: a web
page can neither rebind a name to 127.0.0.1 nor send a form POST to the planner. JSON and YAML bodies (`application/yaml`) are read here by the reader `hriplan` uses
for files and handed on as JSON, so each route has one schema (the file format) and a body gets
the same one-line message as the same text in a file (a key given twice included).
"""

from __future__ import annotations

import asyncio
import hmac
import json
from pathlib import Path

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from hriplan import HriplanError
from hriplan.files import parse_data
from hriplan.service.config import is_loopback

YAML_TYPES = ("application/yaml", "application/x-yaml", "text/yaml", "text/x-yaml")


def robot_files_named(data: object) -> list[str]:
    """Every non-empty `robot_file` in a parsed body (tasks, problems and trajectories carry one)."""
    if isinstance(data, dict):
        own = [data["robot_file"]] if isinstance(data.get("robot_file"), str) and data["robot_file"] else []
        return own + [f for value in data.values() for f in robot_files_named(value)]
    if isinstance(data, list):
        return [f for value in data for f in robot_files_named(value)]
    return []


def refuse_robot_files(data: object, allowed: frozenset[str]) -> None:
    """A robot file is a file on the server: a request may name only those it was started with
    (--robot-file), else reading it would tell a client about any file the server can read."""
    for named in robot_files_named(data):
        if str(Path(named).resolve()) not in allowed:
            raise ValueError(
                f"robot_file {named!r} is not one of the robot files this server was started with "
                "(hriplan serve --robot-file FILE); name a built-in robot or one of those"
            )


def body_as_json(body: bytes, syntax: str, robot_files: frozenset[str] = frozenset()) -> bytes:
    """A JSON or YAML request body as JSON bytes, read by the same reader as files (a key given
    twice, a value JSON has no type for, deep nesting: one line); YAML aliases are refused, since a
    few bytes of them can expand to gigabytes; a robot file not in `robot_files` (absolute paths)
    is refused. A ValueError says what is wrong."""
    try:
        text = body.decode("utf-8")
    except UnicodeDecodeError:
        raise ValueError("body: not UTF-8 text") from None
    try:
        data = parse_data(text, syntax, aliases=False)
    except HriplanError as exc:
        raise ValueError(f"body: {exc}") from None
    refuse_robot_files(data, robot_files)
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


def _split_host(value: str) -> tuple[str, int | None]:
    """A Host header's name and port ("[::1]:8000" -> ("::1", 8000)); port None if absent or bad."""
    if value.startswith("["):
        name, _, rest = value[1:].partition("]")
        port = rest.removeprefix(":")
    else:
        name, _, port = value.partition(":")
    return name.lower(), int(port) if port.isdigit() else None


class Guard:
    def __init__(
        self,
        app: ASGIApp,
        body_limit: int,
        token: str | None,
        body_timeout: float = 30.0,
        allowed_hosts: list[str] | tuple[str, ...] = (),
        allowed_origins: list[str] | tuple[str, ...] = (),
        robot_files: list[Path] | tuple[Path, ...] = (),
    ) -> None:
        self.app, self.body_limit, self.token, self.body_timeout = app, body_limit, token, body_timeout
        self.robot_files = frozenset(str(Path(f).resolve()) for f in robot_files)
        self.allowed_hosts = {h.lower() for h in allowed_hosts}
        self.allowed_origins = set(allowed_origins)

    def _foreign(self, scope: Scope, headers: dict[str, str]) -> str | None:
        """Why a request without a token comes from somewhere it may not (None: it may)."""
        host = headers.get("host", "")
        name, port = _split_host(host)
        server_port = (scope.get("server") or ("", None))[1]
        if not (
            (is_loopback(name) and (port or 80) == server_port)
            or name in self.allowed_hosts
            or host.lower() in self.allowed_hosts
        ):
            return f"the Host header {host!r} is not this server (loopback at port {server_port}); serve another name with --allowed-host NAME"
        origin = headers.get("origin")
        if origin is not None and origin not in self.allowed_origins and origin != f"http://{host}":
            return f"requests from the web page at {origin} are refused (not this server's origin; allow one with --cors-origin)"
        return None

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
        if self.token is None and (why := self._foreign(scope, headers)):
            await _refuse(send, 403, why)
            return
        declared = headers.get("content-length", "")
        if declared.isdigit() and int(declared) > self.body_limit:
            await _refuse(send, 413, f"the request body is larger than the limit of {self.body_limit} bytes")
            return
        body, more = bytearray(), True
        deadline = asyncio.get_running_loop().time() + self.body_timeout
        while more:
            try:
                message = await asyncio.wait_for(receive(), max(deadline - asyncio.get_running_loop().time(), 0.0))
            except asyncio.TimeoutError:
                await _refuse(send, 408, f"the request body did not arrive within {self.body_timeout:g} s")
                return
            if message["type"] == "http.disconnect":
                return
            body += message.get("body", b"")
            more = message.get("more_body", False)
            if len(body) > self.body_limit:
                await _refuse(send, 413, f"the request body is larger than the limit of {self.body_limit} bytes")
                return
        content_type = headers.get("content-type", "").split(";")[0].strip().lower()
        # FastAPI reads a body without a content type as JSON too: it goes through the same reader
        if content_type in YAML_TYPES or (content_type in ("application/json", "") and body.strip()):
            try:
                syntax = "yaml" if content_type in YAML_TYPES else "json"
                body = bytearray(body_as_json(bytes(body), syntax, self.robot_files))
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
