"""The HTTP service: upload recordings, read their spectra and diagnoses, manage engines.

Thin: it validates, stores, queues and serves; all computing is in ``monitor``.

- Every route but ``/health`` and the login needs an API key (header
  ``X-API-Key``) or a browser's session (``POST /login``, :mod:`api.auth`); a
  key sees only its fleet's engines, recordings and baselines, and the bundled
  engines, and another fleet's id answers 404 as an unknown one.
- ``GET /engines`` lists the fleet's own engine descriptions and the bundled
  engines (:mod:`api.engines`); ``POST /engines/{id}/baseline`` calibrates an
  engine's baseline on a stored recording, which later analyses use
  (:mod:`api.baselines`).
- ``POST /recordings?filename=NAME`` takes the file as the request body
  (``application/octet-stream``), streamed to a temporary file on disk
  (never whole in memory) up to :attr:`Settings.max_upload_bytes`, validated
  by the product's readers in a child process with memory and time limits,
  then stored whole or not at all: fsync, atomic rename to its content hash,
  fsync of the folder. The same content uploaded twice is stored once.
- Every error has one body shape: ``{"error": {"status", "code", "message"}}``.
- Reads cost a key lookup and a stored document (:mod:`api.reads`): one
  indexed query each, results answered as the stored JSON text with an entity
  tag, 304 for a client that has it, keys remembered for a second.

Run it with ``engine-monitor serve`` (uvicorn); the OpenAPI document is at
``/openapi.json``, and its page at ``/docs`` (:mod:`api.login`), both with a
key or a session.
"""

from __future__ import annotations

import asyncio
import base64
import gc
import hashlib
import json
import logging
import os
import re
import tempfile
import time
from collections import Counter, defaultdict
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from functools import partial
from pathlib import Path
from typing import Annotated, Any, TypeVar
from urllib.parse import urlencode

import sqlalchemy as sa
from anyio import CapacityLimiter, to_thread
from fastapi import FastAPI, Query, Request
from fastapi import Path as FastPath
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, JSONResponse, RedirectResponse, Response
from fastapi.routing import APIRoute
from pydantic import BaseModel, Field
from starlette.concurrency import run_in_threadpool
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.requests import ClientDisconnect

from api import login
from api.auth import SESSION_S, Fleet, LoginRequired, Sessions, session_secret
from api.baselines import calibration_limits
from api.baselines import router as baselines_router
from api.engines import Source, visible_engine
from api.errors import ApiError, ErrorResponse
from api.outage import DataFolder, Placing, dependency_error, disk_full, remove_unregistered
from api.reads import KEY_TTL_S, KeyCache, conditional, json_body, json_time
from api.validate import MAX_EXPANSION, Validation, format_refusal, validate
from api.views import add_views
from api.webhooks import router as webhooks_router
from monitor.diagnosis import ANALYSIS_VERSION
from monitor.jobs.delivery import DeliveryPolicy
from monitor.jobs.worker import Worker
from monitor.model.engine import bundled_engines
from monitor.store import RecordingRow, RecordingSummary, Store, StoredResult, open_store

log = logging.getLogger("engine_monitor.api")
T = TypeVar("T")

__all__ = ["ApiError", "Settings", "create_app"]


@dataclass
class Settings:
    """The service's settings (``engine-monitor serve`` fills them from its options).

    Attributes
    ----------
    store_url : str
    data_dir : Path
        Stored recordings (``recordings/``), uploads in progress (``incoming/``), plots.
    max_upload_bytes : int
    validation_memory_bytes, validation_timeout_s : int, float
        Limits of the validating child process.
    validations, validations_per_fleet : int
        Files validated at once, in all and per fleet (a fleet's next waits, without a thread, so one
        fleet never takes every slot and reads never wait for validations).
    uploads_per_fleet : int
        A fleet's uploads in progress at once; one more is refused with 429.
    upload_idle_s : float
        Longest wait for the next bytes of an upload's body [s]; then 408.
    upload_min_rate : float
        Slowest average rate of an upload's body after its first ``upload_idle_s`` [bytes/s]; a
        slower one (a trickle that holds a connection and a file open) is cut off with 408.
    max_expansion : float
        Declared samples [bytes] per byte of file beyond which an upload is refused unread.
    workers : int
        Analysis processes in this server (0: none; a separate worker runs them).
    lease_s : float
        A running analysis whose worker has been silent this long is taken back [s].
    retry_backoff_s : float
        Wait before an analysis that failed for a passing reason is tried again, doubled after each
        attempt [s].
    key_ttl_s : float
        How long a key found in the store is trusted without asking again [s]: a revoked key is
        refused at most this long after (0: every request asks the store).
    calibrations : int
        Baselines calibrated at once (``POST /engines/{id}/baseline``; a fleet has one at a time, its
        next is refused with 429 meanwhile; another fleet's waits its turn).
    calibration_memory_bytes, calibration_timeout_s : int, float
        Limits of the calibrating child process (its request waits for it).
    session_s : float
        How long a browser's session lasts after its login (``POST /login``) [s].
    read_threads : int
        Threads that run the reads' queries at once on PostgreSQL (each holds a connection; more would
        only take turns at the interpreter's lock, fewer would leave the round trips unoverlapped). On
        SQLite a read's query runs on the event loop.
    alerts : DeliveryPolicy
        How the webhooks' events are posted and retried (:mod:`api.webhooks`).
    """

    store_url: str
    data_dir: Path
    max_upload_bytes: int = 4 << 30
    validation_memory_bytes: int = 2 << 30
    validation_timeout_s: float = 120.0
    validations: int = 2
    validations_per_fleet: int = 1
    uploads_per_fleet: int = 4
    upload_idle_s: float = 30.0
    upload_min_rate: float = 1024.0
    max_expansion: float = MAX_EXPANSION
    workers: int = 1
    lease_s: float = 30.0
    retry_backoff_s: float = 10.0
    key_ttl_s: float = KEY_TTL_S
    calibrations: int = 1
    calibration_memory_bytes: int = 4 << 30
    calibration_timeout_s: float = 300.0
    session_s: float = SESSION_S
    read_threads: int = 8
    alerts: DeliveryPolicy = field(default_factory=DeliveryPolicy)


def _error(status: int, code: str, message: str, headers: dict[str, str] | None = None) -> JSONResponse:
    return JSONResponse(
        {"error": {"status": status, "code": code, "message": message}}, status_code=status, headers=headers
    )


class RecordingOut(BaseModel):
    id: int
    engine_id: str
    filename: str
    content_hash: str
    size_bytes: int
    recorded_at: str
    uploaded_at: datetime
    analysis_version: str
    status: str = Field(description="the analysis: queued, running, done, failed (retried), set_aside")
    attempts: int
    error: str
    retry_after: datetime | None = Field(
        default=None, description="queued again after a passing failure: not tried before this time"
    )
    diagnosis_status: str = Field(description="healthy, warning or alarm once done; empty before")


class UploadOut(RecordingOut):
    created: bool = Field(description="false when the same content was stored before")


class RecordingPage(BaseModel):
    items: list[RecordingOut]
    offset: int
    limit: int
    next_offset: int | None = Field(description="the offset of the next page (paging by offset), else null")
    next_cursor: str | None = Field(
        description="the cursor of the next page (null on the last): pass it as ?cursor= for the page after"
    )


class EngineOut(BaseModel):
    engine_id: str
    description: dict[str, Any]
    source: Source = Field(
        description="fleet: the fleet's own description; bundled: shipped with the product (read-only). A "
        "fleet's own description of a bundled id takes precedence, in the analyses too"
    )


class Health(BaseModel):
    """The service answers, with its store and its data folder (else 503, which says which does not)."""

    status: str
    store: str
    analysis_version: str


# a plain file name: no folder separators, no C0 or C1 controls, no line or paragraph separators and no
# bidirectional overrides (a name that displays as another), matched whole (``$`` would allow a final "\n")
_NAME = re.compile("[^/\\\\\x00-\x1f\x7f-\x9f\u2028\u2029\u202a-\u202e\u2066-\u2069]{1,255}")
ERRORS: dict[int | str, dict[str, Any]] = {
    code: {"model": ErrorResponse} for code in (400, 401, 404, 409, 413, 422, 503, 507)
}
#: the errors of a read, and its answer to a client whose copy is current
READ: dict[int | str, dict[str, Any]] = {
    **ERRORS,
    304: {"description": "not modified: the ETag sent in If-None-Match is the current one (no body)"},
}


def _sync(out: Any) -> None:
    out.flush()
    os.fsync(out.fileno())


def _filename(name: str) -> str:
    """A plain file name, or a clear 400: no folders, no control characters, at most 255 bytes."""
    if not _NAME.fullmatch(name) or name in (".", "..") or len(name.encode("utf-8")) > 255:
        raise ApiError(
            400,
            "bad_filename",
            "filename: expected a plain file name of 1 to 255 bytes, without '/', '\\', NUL or control "
            "characters, and not '.' or '..'",
        )
    return name


async def _read(app: FastAPI, function: Callable[..., T], *args: Any) -> T:
    """``function(*args)``, a read's one indexed query. On SQLite it runs here, on the event loop: an
    in-process lookup of tens of microseconds that never waits for the writer (WAL), cheaper than
    the hand-over to a thread and back, which would cost more than the query. It first gives the loop
    one turn: a request answered whole in the step that began it let the loop serve the connections
    unevenly under load (50 readers: p99 280 to 480 ms at a p50 of 30 ms; with the turn, 90 to 160
    ms). On PostgreSQL, a round trip to a server, it runs in one of the reads' threads, so the loop
    serves others meanwhile."""
    if app.state.store.dialect == "sqlite":
        await asyncio.sleep(0)
        return function(*args)
    return await to_thread.run_sync(function, *args, limiter=app.state.readers)


RecordingId = Annotated[int, FastPath(ge=1, le=2**31 - 1, description="the recording's id")]
# printable text: a NUL or a control character in an id is refused (422) before it reaches a store
PRINTABLE = r"^[^\x00-\x1f\x7f]+$"
EngineId = Annotated[
    str, FastPath(min_length=1, max_length=200, pattern=PRINTABLE, description="the engine's id")
]


def _moment(name: str, text: str | None) -> datetime | None:
    """An ISO 8601 time (UTC if it has no zone), or a clear 422."""
    if text is None:
        return None
    try:
        moment = datetime.fromisoformat(text)
        if moment.tzinfo is not None:  # the store compares in UTC; at the calendar's ends that overflows
            moment = moment.astimezone(UTC)
        return moment
    except (ValueError, OverflowError):
        raise ApiError(
            422, "invalid_request", f"{name}: expected an ISO 8601 date or time in years 1-9999, got {text!r}"
        ) from None


def _next_cursor(uploaded_at: datetime, recording_id: int) -> str:
    """The cursor of the page after a recording: its upload time and id, opaque to clients."""
    text = json.dumps([uploaded_at.isoformat(), recording_id], separators=(",", ":"))
    return base64.urlsafe_b64encode(text.encode("utf-8")).decode("ascii").rstrip("=")


def _cursor(text: str) -> tuple[datetime, int]:
    """The upload time and id a cursor stands for, or a clear 422."""
    try:
        moment, recording_id = json.loads(base64.urlsafe_b64decode(text + "=" * (-len(text) % 4)))
        uploaded_at = datetime.fromisoformat(moment)
        if uploaded_at.tzinfo is None or type(recording_id) is not int or not 0 < recording_id < 2**31:
            raise ValueError(text)
        return uploaded_at.astimezone(UTC), recording_id
    except (ValueError, TypeError, OverflowError):
        raise ApiError(
            422, "invalid_request", "cursor: expected the next_cursor of a previous page, unchanged"
        ) from None


class EngineIn(BaseModel):
    description: dict[str, Any] = Field(description="the engine description (the TOML's content as JSON)")


async def _receive(request: Request, out: Any, settings: Settings) -> tuple[int, str]:
    """Stream an upload's body to ``out``: its size and SHA-256, or a 413 / 408 ApiError.

    Each piece must come within ``upload_idle_s``, and after that long the body must have come at
    ``upload_min_rate`` on average: a client that trickles bytes to hold a connection and an open
    file is cut off.
    """
    digest = hashlib.sha256()
    size = 0
    started = time.monotonic()
    pieces = request.stream().__aiter__()
    while True:
        try:
            chunk = await asyncio.wait_for(pieces.__anext__(), settings.upload_idle_s)
        except StopAsyncIteration:
            break
        except TimeoutError:
            raise ApiError(
                408, "upload_timeout", f"no bytes of the upload came for {settings.upload_idle_s:g} s"
            ) from None
        size += len(chunk)
        if size > settings.max_upload_bytes:
            raise ApiError(
                413, "too_large", f"the file is over the limit of {settings.max_upload_bytes} bytes"
            )
        elapsed = time.monotonic() - started
        if elapsed > settings.upload_idle_s and size < settings.upload_min_rate * elapsed:
            raise ApiError(
                408,
                "upload_too_slow",
                f"the upload came at {size / elapsed:.0f} bytes/s over {elapsed:.0f} s, slower than the "
                f"{settings.upload_min_rate:g} bytes/s the service needs",
            )
        digest.update(chunk)
        await run_in_threadpool(out.write, chunk)  # the disk never blocks the event loop
    await run_in_threadpool(_sync, out)
    return size, digest.hexdigest()


def create_app(settings: Settings) -> FastAPI:
    """The FastAPI application for these settings."""
    state: dict[str, Any] = {}

    @asynccontextmanager
    async def lifespan(_: FastAPI) -> AsyncIterator[None]:
        store = open_store(settings.store_url)
        for folder in ("recordings", "incoming", "plots"):
            (settings.data_dir / folder).mkdir(parents=True, exist_ok=True)
        for leftover in (settings.data_dir / "incoming").glob("*.part"):  # uploads a killed server left
            leftover.unlink(missing_ok=True)
        state["store"] = store
        app.state.store = store
        app.state.keys = KeyCache(settings.key_ttl_s)
        app.state.sessions = Sessions(session_secret(settings.data_dir), settings.session_s)
        app.state.settings = settings
        app.state.data_folder = DataFolder(settings.data_dir)
        app.state.calibrations, app.state.calibrating = calibration_limits(settings.calibrations)
        app.state.readers = CapacityLimiter(settings.read_threads)
        worker = (
            Worker(
                store,
                settings.data_dir,
                settings.workers,
                lease=timedelta(seconds=settings.lease_s),
                backoff=timedelta(seconds=settings.retry_backoff_s),
            )
            if settings.workers > 0
            else None
        )
        state["worker"] = worker
        if worker is not None:
            worker.start()
        # What the started service holds (modules, the app, the store) lives as long as it does: set
        # apart from the garbage collector, a full collection scans only what requests made, in a few
        # milliseconds, instead of ~100 ms (measured with this app loaded) during which no request
        # is answered.
        gc.freeze()
        try:
            yield
        finally:
            if worker is not None:
                worker.stop()
            store.close()

    app = FastAPI(
        title="engine-monitor",
        summary="Condition monitoring of large reciprocating engines",
        description=__doc__,
        version=ANALYSIS_VERSION,
        lifespan=lifespan,
        openapi_url=None,  # served below, behind the key like every route but /health
        docs_url=None,
        redoc_url=None,
    )

    @app.exception_handler(ApiError)
    async def api_error(_: Request, error: ApiError) -> JSONResponse:
        return _error(error.status, error.code, error.message, error.headers)

    @app.exception_handler(LoginRequired)
    async def login_first(_: Request, needed: LoginRequired) -> RedirectResponse:
        return RedirectResponse(f"/login?{urlencode({'next': needed.path})}", status_code=303)

    @app.exception_handler(StarletteHTTPException)
    async def http_error(request: Request, error: StarletteHTTPException) -> JSONResponse:
        code = {404: "not_found", 405: "method_not_allowed"}.get(error.status_code, "http_error")
        answer = _error(error.status_code, code, str(error.detail))
        answer.headers.update(error.headers or {})
        if error.status_code == 405:  # Allow: every method of every route of this path, not the first's
            allowed = {
                method
                for route in app.routes
                if isinstance(route, APIRoute) and route.path_regex.match(request.url.path)
                for method in route.methods or ()
            }
            answer.headers["Allow"] = ", ".join(sorted(allowed))
        return answer

    @app.exception_handler(RequestValidationError)
    async def invalid(_: Request, error: RequestValidationError) -> JSONResponse:
        parts = [f"{'.'.join(str(p) for p in e['loc'])}: {e['msg']}" for e in error.errors()]
        return _error(422, "invalid_request", "; ".join(parts))

    @app.exception_handler(sa.exc.DBAPIError)
    @app.exception_handler(OSError)
    async def dependency_failed(request: Request, error: Exception) -> JSONResponse:
        """The store unreachable or full, the disk full: 503 or 507 (api.outage), logged once per
        outage; any other error of these kinds, as every unexpected one: 500, with its traceback."""
        found = dependency_error(error, store(), app.state.data_folder, settings.data_dir)
        if found is None:
            log.error("%s %s: the service failed", request.method, request.url.path, exc_info=error)
            return await unexpected(request, error)
        return _error(found.status, found.code, found.message, found.headers)

    @app.exception_handler(Exception)
    async def unexpected(_: Request, error: Exception) -> JSONResponse:
        return _error(500, "internal_error", f"the service failed ({type(error).__name__}); it was logged")

    def store() -> Store:
        found: Store = state["store"]
        return found

    async def read(function: Callable[..., T], *args: Any) -> T:
        """``function(*args)``, a read's one query: see :func:`_read`."""
        return await _read(app, function, *args)

    def recording_out(found: RecordingSummary) -> dict[str, Any]:
        """A recording as the service answers it (the fields of :class:`RecordingOut`, as JSON), built
        straight from the store's summary: no model validates it on the way out."""
        return {
            "id": found.id,
            "engine_id": found.engine_id,
            "filename": found.filename,
            "content_hash": found.content_hash,
            "size_bytes": found.size_bytes,
            "recorded_at": found.recorded_at,
            "uploaded_at": json_time(found.uploaded_at),
            "analysis_version": ANALYSIS_VERSION,
            "status": found.status,
            "attempts": found.attempts,
            "error": found.error,
            "retry_after": None if found.retry_after is None else json_time(found.retry_after),
            "diagnosis_status": found.diagnosis_status,
        }

    def own(fleet_id: int, recording_id: int) -> RecordingSummary:
        found = store().recording_summary(fleet_id, recording_id, ANALYSIS_VERSION)
        if found is None:
            raise ApiError(404, "not_found", f"no recording {recording_id}")
        return found

    plain_openapi = app.openapi

    def openapi_markdown() -> dict[str, Any]:
        """The OpenAPI document, its descriptions (from docstrings) as the Markdown the docs page renders."""
        return login.markdown_descriptions(plain_openapi())

    app.openapi = openapi_markdown  # type: ignore[method-assign]

    @app.get("/openapi.json", include_in_schema=False)
    def openapi(_: Fleet) -> JSONResponse:
        """The OpenAPI document (with a key or a session, as every route but /health)."""
        return JSONResponse(app.openapi())

    @app.get("/", include_in_schema=False, response_model=None)
    def root(request: Request) -> Response:
        """Where to go (no key needed): a browser is sent to the web pages, any other client is answered
        the service's entry points."""
        if "text/html" in request.headers.get("accept", ""):
            return RedirectResponse("/ui", status_code=303)
        return JSONResponse(
            {
                "service": "engine-monitor",
                "ui": "/ui",
                "docs": "/docs",
                "openapi": "/openapi.json",
                "health": "/health",
                "message": "the web pages are at /ui and the API's documentation at /docs (in a browser, "
                "after the login); the OpenAPI document at /openapi.json (with an X-API-Key); /health "
                "needs no key",
            }
        )

    app.include_router(login.router)
    app.include_router(baselines_router)
    app.include_router(webhooks_router)
    add_views(app)

    @app.get("/health", response_model=Health, responses={503: {"model": ErrorResponse}}, tags=["service"])
    def health() -> dict[str, str]:
        """Whether the service, its store and its data folder answer (no key needed); else 503, whose
        code says which does not: ``store_unavailable`` or ``data_folder_full``."""
        store().count("fleets")
        store().outage.back()
        if not app.state.data_folder.has_room():
            raise ApiError(
                503,
                "data_folder_full",
                f"the service's data folder is full: uploads are refused until space is freed there "
                f"({app.state.data_folder.free()} bytes free)",
                headers={"Retry-After": "60"},
            )
        return {"status": "ok", "store": store().dialect, "analysis_version": ANALYSIS_VERSION}

    slots = asyncio.Semaphore(settings.validations)  # each child may take validation_memory_bytes
    fleet_slots: dict[int, asyncio.Semaphore] = defaultdict(
        lambda: asyncio.Semaphore(settings.validations_per_fleet)
    )
    uploading: Counter[int] = Counter()  # uploads in progress per fleet
    placing = Placing()  # contents whose files uploads are moving in and registering now

    async def checked(fleet_id: int, name: str, temporary: Path) -> Validation:
        """The validator's verdict on an uploaded file, awaited in the fleet's turn (no thread held)."""
        async with fleet_slots[fleet_id], slots:
            verdict = await validate(
                temporary,
                memory_bytes=settings.validation_memory_bytes,
                timeout_s=settings.validation_timeout_s,
                max_expansion=settings.max_expansion,
            )
        if not verdict.ok:
            message = verdict.message.replace(str(temporary), name)  # the reader names the file it read
            raise ApiError(422, "not_a_recording", message if name in message else f"{name}: {message}")
        return verdict

    def keep(
        fleet_id: int, name: str, temporary: Path, content: str, size: int, checked: Validation
    ) -> tuple[RecordingRow, bool]:
        """Move a validated upload to its content's name, register it and queue its analysis."""
        if checked.engine_id not in bundled_engines() and store().engine(fleet_id, checked.engine_id) is None:
            raise ApiError(
                422,
                "unknown_engine",
                f"{name}: engine {checked.engine_id!r} is neither bundled nor among the fleet's engines: "
                "add its description (POST /engines), then upload the recording again",
            )
        with open(temporary, "rb") as fh:
            suffix = ".mcap" if fh.read(8).startswith(b"\x89MCAP") else ".h5"
        final = settings.data_dir / "recordings" / f"{content}{suffix}"
        with placing.hold(content):
            moved = not final.exists()
            try:
                if moved:
                    os.replace(temporary, final)
                    directory = os.open(final.parent, os.O_RDONLY)
                    try:
                        os.fsync(directory)
                    finally:
                        os.close(directory)
                row, created = store().add_recording(  # the row and its queued job, in one transaction
                    fleet_id,
                    content_hash=content,
                    engine_id=checked.engine_id,
                    filename=name,
                    path=str(final),
                    size_bytes=size,
                    recorded_at=checked.start_time,
                    queue=ANALYSIS_VERSION,
                )
            except BaseException:  # no file without its row: the one this upload moved in goes
                if moved:
                    remove_unregistered(final, content, store(), placing)
                raise
        app.state.data_folder.has_room()  # a folder full before: logs once it has room again
        return row, created

    @app.post(
        "/recordings",
        status_code=201,
        response_model=UploadOut,
        responses={
            **ERRORS,
            200: {"model": UploadOut, "description": "the same content was stored before"},
            415: {"model": ErrorResponse, "description": "the body's bytes are neither HDF5 nor MCAP"},
        },
        tags=["recordings"],
    )
    async def upload(
        request: Request,
        fleet_id: Fleet,
        filename: Annotated[str, Query(min_length=1, max_length=1024, description="the file's name")],
    ) -> Response:
        """Upload a recording (HDF5 or MCAP) as the request body; its analysis is queued. The bytes tell
        the format, whatever the content type says (curl --data-binary sends a form's); a multipart form
        (curl -F) is refused."""
        name = _filename(filename)
        kind = request.headers.get("content-type", "").split(";")[0].strip().lower()
        if kind.startswith("multipart/"):
            raise ApiError(
                400,
                "form_upload",
                f"the file came as a form ({kind}): send it as the request body itself, e.g. "
                "curl --data-binary @FILE -H 'Content-Type: application/octet-stream', not curl -F",
            )
        declared = request.headers.get("content-length")
        if declared is not None and declared.isdigit() and int(declared) > settings.max_upload_bytes:
            raise ApiError(
                413, "too_large", f"the file is over the limit of {settings.max_upload_bytes} bytes"
            )
        if uploading[fleet_id] >= settings.uploads_per_fleet:
            raise ApiError(
                429,
                "too_many_uploads",
                f"this fleet has {uploading[fleet_id]} uploads in progress, the most it may have at once: "
                "send the next when one has finished",
                headers={"Retry-After": "5"},
            )
        uploading[fleet_id] += 1
        incoming = settings.data_dir / "incoming"
        handle, temporary = tempfile.mkstemp(dir=incoming, suffix=".part")
        try:
            with os.fdopen(handle, "wb") as out:
                try:
                    size, content = await _receive(request, out, settings)
                except ClientDisconnect:  # the client went away: nothing to answer, nothing kept
                    log.info(
                        "upload fleet=%d filename=%r: the client went away; nothing kept", fleet_id, name
                    )
                    return _error(400, "disconnected", "the client disconnected before the end of the body")
            if size == 0:
                raise ApiError(400, "empty", "the request body is empty: send the recording's bytes")
            refusal = await run_in_threadpool(format_refusal, Path(temporary))
            if refusal is not None:
                raise ApiError(415, "unsupported_format", f"{name}: {refusal}")
            verdict = await checked(fleet_id, name, Path(temporary))
            row, created = await run_in_threadpool(
                keep, fleet_id, name, Path(temporary), content, size, verdict
            )
        except OSError as error:  # the data folder full: it is so until it has room for this upload
            if disk_full(error):
                app.state.data_folder.filled(int(declared) if declared and declared.isdigit() else 0)
            raise
        finally:
            uploading[fleet_id] -= 1
            if os.path.exists(temporary):
                os.unlink(temporary)
        if state["worker"] is not None:
            state["worker"].wake()
        view = await run_in_threadpool(own, fleet_id, row.id)
        return Response(
            json_body({**recording_out(view), "created": created}),
            status_code=201 if created else 200,
            media_type="application/json",
        )

    @app.get("/recordings", response_model=RecordingPage, responses=ERRORS, tags=["recordings"])
    async def list_recordings(
        fleet_id: Fleet,
        engine_id: Annotated[str | None, Query(min_length=1, max_length=200, pattern=PRINTABLE)] = None,
        since: Annotated[
            str | None,
            Query(description="uploaded at or after (ISO 8601)", json_schema_extra={"format": "date-time"}),
        ] = None,
        until: Annotated[
            str | None,
            Query(description="uploaded before (ISO 8601)", json_schema_extra={"format": "date-time"}),
        ] = None,
        cursor: Annotated[
            str | None,
            Query(
                max_length=200,
                description="the next_cursor of the previous page: the page after it, read off an index "
                "however deep (prefer it to offset)",
            ),
        ] = None,
        offset: Annotated[
            int, Query(ge=0, le=10**9, description="recordings skipped (after the cursor)")
        ] = 0,
        limit: Annotated[int, Query(ge=1, le=500)] = 50,
    ) -> Response:
        """The fleet's recordings, newest first; filter by engine and upload time; page by cursor."""
        after = _cursor(cursor) if cursor is not None else None
        found = await read(
            partial(
                store().recording_summaries,
                fleet_id,
                ANALYSIS_VERSION,
                engine_id=engine_id,
                since=_moment("since", since),
                until=_moment("until", until),
                after=after,
                offset=offset,
                limit=limit + 1,
            )
        )
        more = len(found) > limit
        last = found[limit - 1] if more else None
        return Response(
            json_body(
                {
                    "items": [recording_out(r) for r in found[:limit]],
                    "offset": offset,
                    "limit": limit,
                    "next_offset": offset + limit if more and cursor is None else None,
                    "next_cursor": _next_cursor(last.uploaded_at, last.id) if last is not None else None,
                }
            ),
            media_type="application/json",
        )

    @app.get("/recordings/{recording_id}", response_model=RecordingOut, responses=READ, tags=["recordings"])
    async def get_recording(request: Request, fleet_id: Fleet, recording_id: RecordingId) -> Response:
        """A recording's metadata and the state of its analysis (ETag: 304 while it is unchanged)."""
        view = await read(own, fleet_id, recording_id)
        return conditional(request.headers.get("if-none-match"), json_body(recording_out(view)))

    def result(fleet_id: int, recording_id: int, kind: str) -> StoredResult:
        """A fleet's recording's stored result, or the 404, 409 or 422 that says why there is none."""
        found = store().stored_result(fleet_id, recording_id, ANALYSIS_VERSION, kind)
        if found is None:
            raise ApiError(404, "not_found", f"no recording {recording_id}")
        if found.result is None:
            job = found.job
            state_now = job.state if job is not None else "none"
            detail = f" ({job.error})" if job is not None and job.error else ""
            if state_now == "set_aside":  # no result will come: not something to wait for
                raise ApiError(
                    422, "analysis_failed", f"recording {recording_id}: its analysis was set aside{detail}"
                )
            raise ApiError(409, "not_ready", f"recording {recording_id}: its analysis is {state_now}{detail}")
        return found.result

    async def stored(request: Request, fleet_id: int, recording_id: int, kind: str) -> Response:
        """The stored result as it is stored (never parsed), tagged with its digest."""
        found = await read(result, fleet_id, recording_id, kind)
        return conditional(request.headers.get("if-none-match"), found.text.encode("utf-8"), found.digest)

    @app.get(
        "/recordings/{recording_id}/diagnosis",
        response_model=dict[str, Any],
        responses=READ,
        tags=["results"],
    )
    async def get_diagnosis(request: Request, fleet_id: Fleet, recording_id: RecordingId) -> Response:
        """The diagnosis (the document of ``engine-monitor compare --json``, docs/diagnosis.md), as stored;
        ETag: the digest of its text."""
        return await stored(request, fleet_id, recording_id, "diagnosis")

    @app.get(
        "/recordings/{recording_id}/spectrum", response_model=dict[str, Any], responses=READ, tags=["results"]
    )
    async def get_spectrum(request: Request, fleet_id: Fleet, recording_id: RecordingId) -> Response:
        """The measured order spectra of every channel (peak amplitudes, phases in degrees), as stored;
        ETag: the digest of its text."""
        return await stored(request, fleet_id, recording_id, "spectrum")

    @app.get(
        "/recordings/{recording_id}/plot",
        response_class=FileResponse,
        responses={**ERRORS, 200: {"content": {"image/png": {}}}},
        tags=["results"],
    )
    def get_plot(fleet_id: Fleet, recording_id: RecordingId) -> FileResponse:
        """The diagnosis plot (PNG): measured against predicted orders, cylinder strengths. It is served
        from the file the store recorded with the recording's diagnosis, and from nowhere else."""
        result(fleet_id, recording_id, "diagnosis")
        kept = store().plot(fleet_id, recording_id, ANALYSIS_VERSION)  # by id, never by a file's name
        path = settings.data_dir / kept if kept is not None else None
        if path is None or not path.is_file():
            raise ApiError(
                404,
                "not_found",
                f"recording {recording_id}: no plot is kept"
                + ("" if path is None else " in this server's data folder (its file is missing)"),
            )
        return FileResponse(path, media_type="image/png")

    def checked_engine(engine_id: str, description: dict[str, Any]) -> dict[str, Any]:
        from monitor.errors import MonitorError
        from monitor.model.engine import parse_engine

        try:
            engine = parse_engine(description, origin="engine")
        except (MonitorError, ValueError) as error:
            raise ApiError(422, "invalid_engine", str(error)) from error
        if len(engine.id) > 200:
            raise ApiError(422, "invalid_engine", f"id: at most 200 characters, got {len(engine.id)}")
        if engine.id != engine_id:
            raise ApiError(
                422, "invalid_engine", f"the description's id is {engine.id!r}, the path's {engine_id!r}"
            )
        return description

    @app.get("/engines", response_model=list[str], responses=ERRORS, tags=["engines"])
    def list_engines(
        fleet_id: Fleet,
        source: Annotated[
            Source | None,
            Query(description="only the fleet's own descriptions, or only the bundled engines"),
        ] = None,
    ) -> list[str]:
        """The ids of the engines the fleet's recordings may name, sorted: the fleet's own descriptions and
        the bundled engines (an id in both once; GET /engines/{engine_id} says which it is)."""
        own = store().engines(fleet_id) if source != "bundled" else []
        bundled = list(bundled_engines()) if source != "fleet" else []
        return sorted(set(own) | set(bundled))

    @app.post("/engines", status_code=201, response_model=EngineOut, responses=ERRORS, tags=["engines"])
    def create_engine(fleet_id: Fleet, body: EngineIn) -> dict[str, Any]:
        """Add an engine description (validated as an engine file is)."""
        engine_id = str(body.description.get("id", ""))
        description = checked_engine(engine_id, body.description)
        if store().engine(fleet_id, engine_id) is not None:
            raise ApiError(
                409, "exists", f"engine {engine_id!r} exists already: PUT /engines/{engine_id} replaces it"
            )
        store().put_engine(fleet_id, engine_id, description)
        return {"engine_id": engine_id, "description": description, "source": "fleet"}

    @app.get("/engines/{engine_id}", response_model=EngineOut, responses=ERRORS, tags=["engines"])
    def get_engine(fleet_id: Fleet, engine_id: EngineId) -> dict[str, Any]:
        """An engine's description: the fleet's own, else the bundled one (``source`` says which)."""
        found = visible_engine(store(), fleet_id, engine_id)
        if found is None:
            raise ApiError(404, "not_found", f"no engine {engine_id!r}")
        return {"engine_id": engine_id, "description": found[0], "source": found[1]}

    @app.put("/engines/{engine_id}", response_model=EngineOut, responses=ERRORS, tags=["engines"])
    def put_engine(fleet_id: Fleet, engine_id: EngineId, body: EngineIn) -> dict[str, Any]:
        """Replace an engine description (later analyses use it)."""
        if store().engine(fleet_id, engine_id) is None:
            read_only = " (a bundled engine is read-only: POST /engines adds the fleet's own)"
            hint = read_only if engine_id in bundled_engines() else ""
            raise ApiError(404, "not_found", f"no engine {engine_id!r} among the fleet's own{hint}")
        store().put_engine(fleet_id, engine_id, checked_engine(engine_id, body.description))
        return {"engine_id": engine_id, "description": body.description, "source": "fleet"}

    return app
