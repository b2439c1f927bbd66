"""`hriplan serve`: the HTTP planning service and SPARQL endpoint (needs the `server` extra)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from hriplan import HriplanError


def serve(
    host: Annotated[str, typer.Option(help="Address to listen on; off loopback a token is required.")] = "127.0.0.1",
    port: Annotated[int, typer.Option(help="Port to listen on.")] = 8000,
    workers: Annotated[int, typer.Option(help="Planning worker processes (requests planned at once).")] = 2,
    token: Annotated[
        str | None, typer.Option(envvar="HRIPLAN_TOKEN", help="Bearer token every request must carry (16+ characters).")
    ] = None,
    queue: Annotated[int, typer.Option(help="Requests that may wait for a worker; more get 503 + Retry-After.")] = 32,
    request_time_limit: Annotated[
        float, typer.Option(help="Seconds a request may take, waiting included (then 504).")
    ] = 120.0,
    body_limit: Annotated[int, typer.Option(help="Largest request body, bytes (then 413).")] = 1 << 20,
    query_time_limit: Annotated[float, typer.Option(help="Seconds a SPARQL query may run.")] = 10.0,
    row_limit: Annotated[int, typer.Option(help="Rows (or triples) a SPARQL answer may have.")] = 10_000,
    rules_dir: Annotated[
        Path | None, typer.Option(help="The folder a task's rule_files may name files in (else none).")
    ] = None,
    cors_origin: Annotated[
        list[str], typer.Option(help="Allow this browser origin (repeatable; default: CORS off).")
    ] = [],  # noqa: B006
) -> None:
    """Serve planning (tasks, problems, sessions) over HTTP and SPARQL 1.1 Protocol endpoints."""
    from pydantic import ValidationError

    try:
        import uvicorn

        from hriplan.service.app import create_app
        from hriplan.service.config import ServiceConfig
    except ImportError as exc:
        raise HriplanError(
            f"the server needs the `server` extra (pip install 'hriplan[server]'): {exc.name} is missing"
        ) from None
    try:
        config = ServiceConfig(
            host=host,
            port=port,
            workers=workers,
            token=token,
            queue_limit=queue,
            request_time_limit=request_time_limit,
            body_limit=body_limit,
            query={"time_limit": query_time_limit, "row_limit": row_limit},
            rules_dir=rules_dir,
            cors_origins=cors_origin,
        )
    except ValidationError as exc:
        first = exc.errors()[0]
        raise HriplanError(f"--{'-'.join(str(p) for p in first['loc']).replace('_', '-')}: {first['msg']}") from None
    config.check_binding()
    uvicorn.run(create_app(config), host=config.host, port=config.port, log_level="info", access_log=False)
