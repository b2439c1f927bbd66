"""How a server runs: where it listens, its workers, limits, token and rule folder."""

from __future__ import annotations

import ipaddress
from pathlib import Path

from pydantic import BaseModel, Field, field_validator

from hriplan import HriplanError
from hriplan.ontology.sparql import QueryLimits


class ServiceConfig(BaseModel):
    host: str = "127.0.0.1"
    port: int = Field(default=8000, ge=0, le=65535)
    workers: int = Field(default=2, ge=1, le=64)
    kernels: bool = Field(
        default=True,
        description="Planning workers plan with the compiled kernels (numba; off without it), loaded when a "
        "worker starts: ~1 s and ~130 MB more a worker, ~7 s the first start after installing; constrained "
        "solves x0.59-0.86 (benchmarks/REPORT-kernels.md).",
    )
    query_workers: int = Field(
        default=1, ge=1, le=64, description="Worker processes for SPARQL queries, apart from planning."
    )
    query_memory: int = Field(
        default=512, ge=16, description="Megabytes of memory a query may add to its worker (then 400)."
    )
    queue_limit: int = Field(default=32, ge=0, description="Requests that may wait for a worker; more get 503.")
    request_time_limit: float = Field(
        default=120.0, gt=0.0, description="Seconds a request may take, waiting included."
    )
    body_limit: int = Field(default=1 << 20, gt=0, description="Bytes a request body may have.")
    token: str | None = Field(default=None, min_length=16, description="Bearer token every request must carry.")
    allowed_hosts: list[str] = Field(
        default_factory=list,
        description="Without a token, names the Host header may carry besides loopback (DNS rebinding guard).",
    )
    max_connections: int = Field(
        default=200, ge=1, le=10_000, description="Open connections at once; more are answered 503 and closed."
    )
    header_timeout: float = Field(default=10.0, gt=0.0, description="Seconds a client has to send a request's head.")
    body_timeout: float = Field(default=30.0, gt=0.0, description="Seconds a client has to send a request's body.")
    cors_origins: list[str] = Field(default_factory=list, description="Origins allowed by CORS (none: CORS off).")
    rules_dir: Path | None = Field(
        default=None, description="The only folder `rule_files` of a task may name files in."
    )
    robot_files: list[Path] = Field(
        default_factory=list, description="The robot files a request's `robot_file` may name (else none)."
    )
    query: QueryLimits = Field(default_factory=QueryLimits)
    max_sessions: int = Field(default=64, ge=1)
    max_tasks: int = Field(default=64, ge=1)
    max_jobs: int = Field(default=64, ge=1, description="Background jobs kept, running or done.")

    @field_validator("token")
    @classmethod
    def _no_whitespace(cls, token: str | None) -> str | None:
        if token is not None and any(c.isspace() for c in token):
            raise ValueError("a token may not contain spaces or line breaks")
        return token

    def check_binding(self) -> None:
        """Off loopback, a token is required: nothing else stands between the network and the planner."""
        if not is_loopback(self.host) and self.token is None:
            raise HriplanError(f"binding to {self.host} (not loopback) needs a bearer token: --token or HRIPLAN_TOKEN")


def is_loopback(host: str) -> bool:
    """Whether a host name or address is this machine's loopback (localhost, 127.x, ::1)."""
    host = host.removeprefix("[").removesuffix("]")
    if host == "localhost" or host.endswith(".localhost"):
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False
