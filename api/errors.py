"""The one place errors become answers: every error body is ``{"error": {"status", "code", "message"}}``.

- :class:`ApiError`, raised by a route, is answered as it says.
- The product's errors a request's input may cause (:mod:`monitor.errors`) are answered with
  their message and the status and code of :data:`PRODUCT_ERRORS`; the product's other errors are
  the service's fault (500).
- A page asked for without a session (:class:`LoginRequired`) sends the browser to the login.
- Starlette's and FastAPI's own (404, 405 with every method of the path in ``Allow``, a malformed
  parameter 422) are given the same body.
- The store unreachable or full, the disk full: 503 or 507 (:func:`dependency_error`, with
  :mod:`api.outage`), logged once per outage; any other error of these kinds, as every unexpected
  one: 500, with its traceback.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any
from urllib.parse import urlencode

import sqlalchemy as sa
from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse, RedirectResponse
from fastapi.routing import APIRoute, iter_route_contexts
from starlette.exceptions import HTTPException as StarletteHTTPException

from api.outage import MIN_ROOM, RETRY_AFTER_S, DataFolder, disk_full
from monitor.errors import EngineDescriptionError, MonitorError
from monitor.store import Store
from monitor.store.outage import fault_reason, store_fault

__all__ = [
    "PRODUCT_ERRORS",
    "ApiError",
    "LoginRequired",
    "add_error_handlers",
    "data_folder_full",
    "dependency_error",
    "error_response",
    "store_unavailable",
]

log = logging.getLogger("engine_monitor.api")

#: The product's errors that a request's input causes, and the status and code each is answered with
#: (its message is the product's): an engine description a fleet sends that breaks the format.
PRODUCT_ERRORS: dict[type[MonitorError], tuple[int, str]] = {
    EngineDescriptionError: (422, "invalid_engine"),
}


class ApiError(Exception):
    """An error answered with the service's one error body."""

    def __init__(self, status: int, code: str, message: str, headers: dict[str, str] | None = None) -> None:
        super().__init__(message)
        self.status, self.code, self.message, self.headers = status, code, message, headers


class LoginRequired(Exception):
    """A page was asked for without a session: the browser is sent to the login, then back."""

    def __init__(self, path: str) -> None:
        super().__init__(path)
        self.path = path


def error_response(
    status: int, code: str, message: str, headers: dict[str, str] | None = None
) -> JSONResponse:
    """The service's one error body."""
    return JSONResponse(
        {"error": {"status": status, "code": code, "message": message}}, status_code=status, headers=headers
    )


def store_unavailable() -> ApiError:
    """The 503 of a request the store could not serve now."""
    return ApiError(
        503,
        "store_unavailable",
        f"the service cannot reach its store (the database) just now: send the request again in "
        f"{RETRY_AFTER_S} s",
        headers={"Retry-After": str(RETRY_AFTER_S)},
    )


def data_folder_full() -> ApiError:
    """The 507 of a request that found the service's data folder full."""
    return ApiError(
        507,
        "data_folder_full",
        "the service's data folder is full: nothing of this request was kept; send it again once space "
        "is freed there (the service's operator frees it)",
    )


def dependency_error(error: Exception, store: Store, data: DataFolder, data_dir: Path) -> ApiError | None:
    """The answer to an error that is a dependency's fault (the store unreachable or full, the disk
    full), recorded as such; None for any other error (a fault of the service, to log as one).

    Parameters
    ----------
    error : Exception
    store : Store
    data : DataFolder
    data_dir : Path
        The data folder, where an SQLite store's file is by default.
    """
    if disk_full(error):
        data.filled(MIN_ROOM)
        return data_folder_full()
    fault = store_fault(error)
    if fault is None:
        return None
    store.outage.failed(error)
    if fault == "unavailable":
        return store_unavailable()
    database = store.db.url.database or ""
    if store.dialect == "sqlite" and Path(database).resolve().is_relative_to(data_dir.resolve()):
        data.filled(MIN_ROOM)
        return data_folder_full()
    log.warning("store full: %s", fault_reason(error))
    return ApiError(
        507,
        "store_full",
        "the disk of the service's store is full: nothing of this request was kept; send it again once "
        "space is freed there (the service's operator frees it)",
    )


async def _api_error(_: Request, error: ApiError) -> JSONResponse:
    return error_response(error.status, error.code, error.message, error.headers)


async def _product_error(_: Request, error: MonitorError) -> JSONResponse:
    status, code = next(PRODUCT_ERRORS[kind] for kind in type(error).__mro__ if kind in PRODUCT_ERRORS)
    return error_response(status, code, str(error))


async def _login_first(_: Request, needed: LoginRequired) -> RedirectResponse:
    return RedirectResponse(f"/login?{urlencode({'next': needed.path})}", status_code=303)


def _allowed(app: Any, path: str) -> set[str]:
    """Every method of every route of this path (the routers' routes included)."""
    return {
        method
        for route in iter_route_contexts(app.routes)
        if isinstance(route.original_route, APIRoute) and route.path_regex.match(path)
        for method in route.methods or ()
    }


async def _http_error(request: Request, error: StarletteHTTPException) -> JSONResponse:
    code = {404: "not_found", 405: "method_not_allowed"}.get(error.status_code, "http_error")
    answer = error_response(error.status_code, code, str(error.detail))
    answer.headers.update(error.headers or {})
    if error.status_code == 405:  # Allow: every method of every route of this path, not the first's
        answer.headers["Allow"] = ", ".join(sorted(_allowed(request.app, request.url.path)))
    return answer


async def _invalid(_: Request, error: RequestValidationError) -> JSONResponse:
    parts = [f"{'.'.join(str(p) for p in e['loc'])}: {e['msg']}" for e in error.errors()]
    return error_response(422, "invalid_request", "; ".join(parts))


async def _dependency_failed(request: Request, error: Exception) -> JSONResponse:
    """The store unreachable or full, the disk full: 503 or 507 (api.outage), logged once per
    outage; any other error of these kinds, as every unexpected one: 500, with its traceback."""
    state = request.app.state
    found = dependency_error(error, state.store, state.data_folder, state.settings.data_dir)
    if found is None:
        log.error("%s %s: the service failed", request.method, request.url.path, exc_info=error)
        return await _unexpected(request, error)
    return error_response(found.status, found.code, found.message, found.headers)


async def _unexpected(_: Request, error: Exception) -> JSONResponse:
    return error_response(
        500, "internal_error", f"the service failed ({type(error).__name__}); it was logged"
    )


def add_error_handlers(app: FastAPI) -> None:
    """Answer every error of ``app`` with the service's one error body (see the module docstring)."""
    app.exception_handler(ApiError)(_api_error)
    for kind in PRODUCT_ERRORS:
        app.exception_handler(kind)(_product_error)
    app.exception_handler(LoginRequired)(_login_first)
    app.exception_handler(StarletteHTTPException)(_http_error)
    app.exception_handler(RequestValidationError)(_invalid)
    app.exception_handler(sa.exc.DBAPIError)(_dependency_failed)
    app.exception_handler(OSError)(_dependency_failed)
    app.exception_handler(Exception)(_unexpected)
