"""Trends, the fleet at a glance, and the web pages that show them.

JSON (with the API key, or a browser's session):

- ``GET /fleet``: each engine of the fleet with a diagnosed recording, its
  counts of alarms and warnings and its latest recording's verdict;
- ``GET /engines/{engine_id}/trend``: the engine's quantities over time and
  the drift found in them, the document of ``engine-monitor trend --json``
  (docs/trends.md); ``since`` and ``quantity`` narrow it.

Pages (a browser without a session is sent to the login, then back): ``/ui``
the fleet, ``/ui/engines/{engine_id}`` an engine (latest verdict and
findings, trend findings, cylinder balance, each quantity against time),
``/ui/recordings/{recording_id}`` a recording (status and findings on top,
measured against predicted orders, spectra); their scripts and styles from
the installed package under ``/ui/static/``, nothing from elsewhere.

Another fleet's engine or recording answers 404, as an unknown one.
"""

from __future__ import annotations

import asyncio
import html
from collections.abc import Callable
from datetime import UTC, datetime
from typing import Annotated, Any, TypeVar
from urllib.parse import quote
from weakref import WeakKeyDictionary

from fastapi import APIRouter, FastAPI, Query, Request
from fastapi import Path as FastPath
from fastapi.responses import HTMLResponse
from fastapi.staticfiles import StaticFiles
from pydantic import BaseModel, Field
from starlette.concurrency import run_in_threadpool

from api.auth import Fleet, PageFleet
from api.errors import ApiError, ErrorResponse
from monitor.diagnosis import ANALYSIS_VERSION
from monitor.report.web import STATIC, engine_page, fleet_page, recording_page
from monitor.store import Store
from monitor.store.trends import fill_trend_points, fleet_summary, read_trend, trend_document

__all__ = ["add_views", "router"]

router = APIRouter()
T = TypeVar("T")
STATIC_URL = "/ui/static"
# the pages load their own scripts and styles and nothing else; their data is inline JSON, not a script
_CSP = (
    "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' data:; connect-src 'self'; "
    "form-action 'self'; base-uri 'none'; frame-ancestors 'none'"
)
_PAGE_HEADERS = {
    "Content-Security-Policy": _CSP,
    "Cache-Control": "no-store",
    "X-Content-Type-Options": "nosniff",
}
ERRORS: dict[int | str, dict[str, Any]] = {
    401: {"model": ErrorResponse, "description": "no API key or session, or an unknown one"},
    404: {"model": ErrorResponse, "description": "no such engine or recording in this fleet"},
    422: {"model": ErrorResponse, "description": "a malformed parameter"},
}
EngineId = Annotated[
    str, FastPath(min_length=1, max_length=200, pattern=r"^[^\x00-\x1f\x7f]+$", description="the engine's id")
]
RecordingId = Annotated[int, FastPath(ge=1, le=2**31 - 1, description="the recording's id")]


class LatestOut(BaseModel):
    recording_id: int
    filename: str
    recorded_at: str = Field(description="the recording's start (UTC; its upload time if it states none)")
    status: str = Field(description="its diagnosis: healthy, warning, alarm or inconclusive")


class EngineSummaryOut(BaseModel):
    engine_id: str
    recordings: int = Field(description="recordings with a diagnosis at the current analysis version")
    alarms: int
    warnings: int
    latest: LatestOut


class FleetOut(BaseModel):
    analysis_version: str
    engines: list[EngineSummaryOut]


async def _blocking(function: Callable[..., T], *args: Any) -> T:
    """A store read of several queries (a trend, a summary): in a worker thread, so the loop serves others."""
    return await run_in_threadpool(function, *args)


_FILLED: WeakKeyDictionary[Store, set[int]] = WeakKeyDictionary()  # fleets whose older results are filled


def _filled(store: Store, fleet_id: int, c: Any) -> None:
    """Fill in a fleet's trend points of results stored before them, once per store and fleet in this
    process: every result stored since comes with its points (Store.complete), so a read need not look
    again (the look is a query over all the fleet's results)."""
    done = _FILLED.setdefault(store, set())
    if fleet_id not in done:
        fill_trend_points(c, fleet_id)
        done.add(fleet_id)


def _summary(store: Store, fleet_id: int) -> list[Any]:
    with store.transaction() as c:
        _filled(store, fleet_id, c)
        return fleet_summary(c, fleet_id, analysis_version=ANALYSIS_VERSION)


def _trend(
    store: Store, fleet_id: int, engine_id: str, quantities: list[str] | None, since: datetime | None
) -> list[Any]:
    with store.transaction() as c:
        _filled(store, fleet_id, c)
        return read_trend(
            c, fleet_id, engine_id, analysis_version=ANALYSIS_VERSION, quantities=quantities, since=since
        )


def _since(text: str | None) -> datetime | None:
    if text is None:
        return None
    try:
        when = datetime.fromisoformat(text.replace("Z", "+00:00"))
    except ValueError:
        raise ApiError(422, "bad_since", f"since={text!r}: expected a date or time in ISO 8601") from None
    return when if when.tzinfo is not None else when.replace(tzinfo=UTC)


@router.get("/fleet", response_model=FleetOut, responses=ERRORS, tags=["trends"])
async def get_fleet(request: Request, fleet_id: Fleet) -> dict[str, Any]:
    """Each engine of the fleet at a glance: its diagnosed recordings and its latest recording's verdict."""
    engines = await _blocking(_summary, request.app.state.store, fleet_id)
    return {
        "analysis_version": ANALYSIS_VERSION,
        "engines": [
            {
                "engine_id": e.engine_id,
                "recordings": e.recordings,
                "alarms": e.alarms,
                "warnings": e.warnings,
                "latest": {
                    "recording_id": e.latest_recording_id,
                    "filename": e.latest_filename,
                    "recorded_at": e.latest_recorded_at.isoformat(),
                    "status": e.latest_status,
                },
            }
            for e in engines
        ],
    }


@router.get("/engines/{engine_id}/trend", responses=ERRORS, tags=["trends"])
async def get_trend(
    request: Request,
    fleet_id: Fleet,
    engine_id: EngineId,
    since: Annotated[
        str | None, Query(max_length=64, description="recordings from then on (ISO 8601)")
    ] = None,
    quantity: Annotated[
        list[str] | None, Query(max_length=20, description="only these quantities (docs/trends.md)")
    ] = None,
) -> dict[str, Any]:
    """The engine's quantities over time and the drift found in them (``engine-monitor trend --json``)."""
    rows = await _blocking(
        _trend, request.app.state.store, fleet_id, engine_id, quantity or None, _since(since)
    )
    if not rows:
        raise ApiError(404, "not_found", f"no diagnosed recording of engine {engine_id!r} in this fleet")
    document, _, _ = trend_document(
        rows, engine_id=engine_id, fleet=str(fleet_id), analysis_version=ANALYSIS_VERSION, since=_since(since)
    )
    return document


class _Links:
    """The pages' URLs."""

    fleet = "/ui"
    logout = "/logout"

    @staticmethod
    def engine(engine_id: str) -> str:
        return f"/ui/engines/{quote(engine_id, safe='')}"

    @staticmethod
    def recording(recording_id: int) -> str:
        return f"/ui/recordings/{int(recording_id)}"


def _page(text: str) -> HTMLResponse:
    return HTMLResponse(text, headers=_PAGE_HEADERS)


@router.get("/ui", response_class=HTMLResponse, include_in_schema=False)
async def fleet_view(request: Request, fleet_id: PageFleet) -> HTMLResponse:
    """The fleet page."""
    store: Store = request.app.state.store
    engines = await _blocking(_summary, store, fleet_id)
    name = await _blocking(store.fleet_label, fleet_id)
    return _page(fleet_page(name, engines, links=_Links, assets=STATIC_URL))


@router.get("/ui/engines/{engine_id}", response_class=HTMLResponse, include_in_schema=False)
async def engine_view(request: Request, fleet_id: PageFleet, engine_id: EngineId) -> HTMLResponse:
    """An engine's page: 404 for an engine without a diagnosed recording in this fleet."""
    store: Store = request.app.state.store
    rows = await _blocking(_trend, store, fleet_id, engine_id, None, None)
    if not rows:
        raise ApiError(404, "not_found", f"no diagnosed recording of engine {engine_id!r} in this fleet")
    document, _, _ = trend_document(
        rows, engine_id=engine_id, fleet=str(fleet_id), analysis_version=ANALYSIS_VERSION
    )
    latest_id = max(rows, key=lambda r: (r.recorded_at, r.recording_id)).recording_id
    latest = await _blocking(store.result, latest_id, ANALYSIS_VERSION, "diagnosis")
    return _page(
        engine_page(engine_id, document, latest, latest_id=latest_id, links=_Links, assets=STATIC_URL)
    )


@router.get("/ui/recordings/{recording_id}", response_class=HTMLResponse, include_in_schema=False)
async def recording_view(request: Request, fleet_id: PageFleet, recording_id: RecordingId) -> HTMLResponse:
    """A recording's page: its diagnosis when there is one, else its analysis's state."""
    store: Store = request.app.state.store
    found = await _blocking(store.recording_summary, fleet_id, recording_id, ANALYSIS_VERSION)
    if found is None:
        raise ApiError(404, "not_found", f"no recording {recording_id}")
    diagnosis, spectrum = await asyncio.gather(
        _blocking(store.result, recording_id, ANALYSIS_VERSION, "diagnosis"),
        _blocking(store.result, recording_id, ANALYSIS_VERSION, "spectrum"),
    )
    analysis = None
    if diagnosis is None:  # not analysed yet, or not to be: its state and why, in place of the findings
        diagnosis = {
            "recording": found.filename,
            "engine_id": found.engine_id,
            "analysis_version": ANALYSIS_VERSION,
        }
        analysis = {
            "state": found.status if found.status in ("queued", "running", "failed", "set_aside") else "none",
            "attempts": found.attempts,
            "error": found.error,
            "retry_after": found.retry_after,
        }
    navigation = (
        f'<nav><a href="{_Links.fleet}">Fleet</a> <a href="{_Links.engine(found.engine_id)}">'
        f"{html.escape(found.engine_id)}</a></nav>"
    )
    return _page(
        recording_page(diagnosis, spectrum, assets=STATIC_URL, navigation=navigation, analysis=analysis)
    )


def add_views(app: FastAPI) -> None:
    """Add the trend and fleet routes, the pages, and their static files to the service."""
    app.include_router(router)
    app.mount(STATIC_URL, StaticFiles(directory=STATIC), name="ui-static")
