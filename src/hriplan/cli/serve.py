"""`hriplan serve`: the HTTP planning service and SPARQL endpoint (needs the `server` extra)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from hriplan import HriplanError


def serve(
    host: Annotated[str, typer.Option(help="Address to listen on; off loopback a token is required.")] = "127.0.0.1",
    port: Annotated[int, typer.Option(help="Port to listen on.")] = 8000,
    workers: Annotated[int, typer.Option(help="Planning worker processes (requests planned at once).")] = 2,
    query_workers: Annotated[int, typer.Option(help="SPARQL worker processes, apart from planning.")] = 1,
    kernels: Annotated[
        bool,
        typer.Option(
            help="Plan with the compiled kernels (numba, the `fast` extra), loaded as each planning worker starts."
        ),
    ] = True,
    token: Annotated[
        str | None,
        typer.Option(
            envvar="HRIPLAN_TOKEN",
            help="Bearer token every request must carry (16+ characters); --token-file keeps it out of `ps`.",
        ),
    ] = None,
    token_file: Annotated[
        Path | None, typer.Option(help="Read the bearer token from this file (its first line).")
    ] = None,
    allowed_host: Annotated[
        list[str], typer.Option(help="Without a token, a Host name served besides loopback (repeatable).")
    ] = [],  # noqa: B006
    queue: Annotated[int, typer.Option(help="Requests that may wait for a worker; more get 503 + Retry-After.")] = 32,
    request_time_limit: Annotated[
        float, typer.Option(help="Seconds a request may take, waiting included (then 504).")
    ] = 120.0,
    body_limit: Annotated[int, typer.Option(help="Largest request body, bytes (then 413).")] = 1 << 20,
    query_time_limit: Annotated[float, typer.Option(help="Seconds a SPARQL query may run.")] = 10.0,
    row_limit: Annotated[int, typer.Option(help="Rows (or triples) a SPARQL answer may have.")] = 10_000,
    response_limit: Annotated[int, typer.Option(help="Bytes a SPARQL answer may have.")] = 16 << 20,
    query_memory: Annotated[int, typer.Option(help="Megabytes a SPARQL query may add to its worker.")] = 512,
    max_connections: Annotated[int, typer.Option(help="Open connections at once (more: 503 and closed).")] = 200,
    header_timeout: Annotated[float, typer.Option(help="Seconds a client has to send a request's head.")] = 10.0,
    body_timeout: Annotated[
        float, typer.Option(help="Seconds a client has to send a request's body (then 408).")
    ] = 30.0,
    rules_dir: Annotated[
        Path | None, typer.Option(help="The folder a task's rule_files may name files in (else none).")
    ] = None,
    robot_file: Annotated[
        list[Path], typer.Option(help="A robot file requests may name by robot_file (repeatable; else none).")
    ] = [],  # noqa: B006
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
        raise HriplanError(f"the server needs the `server` extra ({install_hint()}): {exc.name} is missing") from None
    from hriplan.files import read_text
    from hriplan.service.connections import guarded_protocol

    if token_file is not None:
        if token is not None:
            raise HriplanError("give the token once: --token (or HRIPLAN_TOKEN) or --token-file")
        token = (read_text(token_file, "token file").splitlines() or [""])[0].strip()
        if not token:
            raise HriplanError(f"--token-file {token_file}: the first line holds no token")
    try:
        config = ServiceConfig(
            host=host,
            port=port,
            workers=workers,
            query_workers=query_workers,
            kernels=kernels,
            query_memory=query_memory,
            token=token,
            queue_limit=queue,
            request_time_limit=request_time_limit,
            body_limit=body_limit,
            query={"time_limit": query_time_limit, "row_limit": row_limit, "byte_limit": response_limit},
            rules_dir=rules_dir,
            robot_files=robot_file,
            cors_origins=cors_origin,
            allowed_hosts=allowed_host,
            max_connections=max_connections,
            header_timeout=header_timeout,
            body_timeout=body_timeout,
        )
    except ValidationError as exc:
        first = exc.errors()[0]
        field = ".".join(str(p) for p in first["loc"])
        option = OPTIONS.get(field, field.replace("_", "-"))
        raise HriplanError(f"--{option}: {first['msg'].removeprefix('Value error, ')}") from None
    from hriplan.collector import freeze_what_lives
    from hriplan.robots.descriptions.registry import load_robot_file

    for path in config.robot_files:  # a bad robot file is one line now, not at a request
        try:
            load_robot_file(path)
        except HriplanError as exc:
            raise HriplanError(f"--robot-file: {exc}") from None
    config.check_binding()
    _enough_file_descriptors(config.max_connections)
    app = create_app(config)
    freeze_what_lives()  # the server's ~100 000 objects (FastAPI, the schemas) out of its collections
    uvicorn.run(
        app,
        host=config.host,
        port=config.port,
        log_level="info",
        access_log=False,
        http=guarded_protocol(config.max_connections, config.header_timeout),
        timeout_keep_alive=5,
    )


OPTIONS = {  # a ServiceConfig field -> the option that sets it, where the names differ
    "query.time_limit": "query-time-limit",
    "query.row_limit": "row-limit",
    "query.byte_limit": "response-limit",
    "queue_limit": "queue",
    "cors_origins": "cors-origin",
    "allowed_hosts": "allowed-host",
}


def install_hint() -> str:
    """How to install the server extra into the Python that runs hriplan (a bare `pip` may be
    the system's): from the checkout if hriplan runs from one."""
    checkout = Path(__file__).resolve().parents[3]
    if (checkout / "pyproject.toml").is_file():
        return f"{sys.executable} -m pip install -e '{checkout}[server]'"
    return f"{sys.executable} -m pip install 'hriplan[server]'"


def _enough_file_descriptors(connections: int) -> None:
    """Room for every allowed connection plus the workers' pipes and files: raise the soft limit
    if the hard one allows, so the connection cap is met before the descriptor limit."""
    import resource

    needed = connections + 128
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft != resource.RLIM_INFINITY and soft < needed:
        if hard != resource.RLIM_INFINITY and hard < needed:
            raise HriplanError(
                f"--max-connections {connections} needs {needed} file descriptors; the limit is {hard} (ulimit -n)"
            )
        resource.setrlimit(resource.RLIMIT_NOFILE, (needed, hard))
