"""The service's one error: answered as ``{"error": {"status", "code", "message"}}`` by one handler."""

from __future__ import annotations

from pydantic import BaseModel

__all__ = ["ApiError", "ErrorBody", "ErrorResponse"]


class ApiError(Exception):
    """An error answered with the service's one error body."""

    def __init__(self, status: int, code: str, message: str, headers: dict[str, str] | None = None) -> None:
        super().__init__(message)
        self.status, self.code, self.message, self.headers = status, code, message, headers


class ErrorBody(BaseModel):
    status: int
    code: str
    message: str


class ErrorResponse(BaseModel):
    error: ErrorBody
