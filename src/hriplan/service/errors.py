"""Errors as JSON: `{"error": one line, "field": the field at fault or null}` with a status."""

from __future__ import annotations

from fastapi.responses import JSONResponse

from hriplan import HriplanError


class RequestError(HriplanError):
    """A refusal with its own HTTP status (404 unknown session, 409 conflict, 415, ...)."""

    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status


def error_response(
    status: int, message: str, field: str | None = None, headers: dict[str, str] | None = None
) -> JSONResponse:
    return JSONResponse({"error": message, "field": field}, status_code=status, headers=headers)
