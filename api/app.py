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

import gc
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from datetime import timedelta

from anyio import CapacityLimiter
from fastapi import FastAPI

from api import login
from api.auth import Sessions, session_secret
from api.baselines import Calibrations
from api.errors import add_error_handlers
from api.openapi import openapi_in_markdown
from api.outage import DataFolder
from api.reads import KeyCache
from api.routes import baselines, engines, recordings, results, service, trends, webhooks
from api.routes.pages import add_pages
from api.settings import Settings
from api.uploads import Uploads
from monitor.diagnosis import ANALYSIS_VERSION
from monitor.jobs.worker import Worker
from monitor.store import open_store

__all__ = ["create_app"]


@asynccontextmanager
async def _lifespan(app: FastAPI) -> AsyncIterator[None]:
    """The service's store, folders, caches and limits for as long as it runs, and its own analysis
    worker (``Settings.workers`` processes; none: a separate worker runs them)."""
    settings: Settings = app.state.settings
    store = open_store(settings.store_url)
    for folder in ("recordings", "incoming", "plots"):
        (settings.data_dir / folder).mkdir(parents=True, exist_ok=True)
    for leftover in (settings.data_dir / "incoming").glob("*.part"):  # uploads a killed server left
        leftover.unlink(missing_ok=True)
    app.state.store = store
    app.state.keys = KeyCache(settings.key_ttl_s)
    app.state.sessions = Sessions(session_secret(settings.data_dir), settings.session_s)
    app.state.data_folder = DataFolder(settings.data_dir)
    app.state.uploads = Uploads(settings, app.state.data_folder)
    app.state.calibrations = Calibrations(settings.calibrations)
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
    app.state.worker = worker
    try:  # a start that fails halfway is stopped all the same: its analysis pool ended, not left
        if worker is not None:
            worker.start()
        # What the started service holds (modules, the app, the store) lives as long as it does: set
        # apart from the garbage collector, a full collection scans only what requests made, in a few
        # milliseconds, instead of ~100 ms (measured with this app loaded) during which no request
        # is answered.
        gc.freeze()
        yield
    finally:
        if worker is not None:
            worker.stop()
        store.close()


def create_app(settings: Settings) -> FastAPI:
    """The FastAPI application for these settings."""
    app = FastAPI(
        title="engine-monitor",
        summary="Condition monitoring of large reciprocating engines",
        description=__doc__,
        version=ANALYSIS_VERSION,
        lifespan=_lifespan,
        openapi_url=None,  # served by api.routes.service, behind the key like every route but /health
        docs_url=None,
        redoc_url=None,
    )
    app.state.settings = settings
    add_error_handlers(app)
    openapi_in_markdown(app)
    app.include_router(service.router)
    app.include_router(login.router)
    app.include_router(baselines.router)
    app.include_router(webhooks.router)
    app.include_router(trends.router)
    add_pages(app)
    app.include_router(recordings.router)
    app.include_router(results.router)
    app.include_router(engines.router)
    return app
