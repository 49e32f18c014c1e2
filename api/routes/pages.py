"""The web pages (a browser without a session is sent to the login, then back): ``/ui`` the fleet,
``/ui/engines/{engine_id}`` an engine (latest verdict and findings, trend findings, cylinder balance,
each quantity against time), ``/ui/recordings/{recording_id}`` a recording (status and findings on
top, measured against predicted orders, spectra); their scripts and styles from the installed
package under ``/ui/static/``, nothing from elsewhere.

Another fleet's engine or recording answers 404, as an unknown one.
"""

from __future__ import annotations

import asyncio
import html
from urllib.parse import quote

from fastapi import APIRouter, FastAPI
from fastapi.responses import HTMLResponse
from fastapi.staticfiles import StaticFiles

from api.auth import PageFleet
from api.dependencies import ServiceStore
from api.errors import ApiError
from api.schemas import EngineId, RecordingId
from api.trends import blocking, engine_trend, fleet_engines
from monitor.diagnosis import ANALYSIS_VERSION
from monitor.report.web import STATIC, engine_page, fleet_page, recording_page
from monitor.store.trends import trend_document

__all__ = ["add_pages", "router"]

router = APIRouter(include_in_schema=False)
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


@router.get("/ui", response_class=HTMLResponse)
async def fleet_view(fleet_id: PageFleet, store: ServiceStore) -> HTMLResponse:
    """The fleet page."""
    engines = await blocking(fleet_engines, store, fleet_id)
    name = await blocking(store.fleet_label, fleet_id)
    return _page(fleet_page(name, engines, links=_Links, assets=STATIC_URL))


@router.get("/ui/engines/{engine_id}", response_class=HTMLResponse)
async def engine_view(fleet_id: PageFleet, engine_id: EngineId, store: ServiceStore) -> HTMLResponse:
    """An engine's page: 404 for an engine without a diagnosed recording in this fleet."""
    rows = await blocking(engine_trend, store, fleet_id, engine_id, None, None)
    if not rows:
        raise ApiError(404, "not_found", f"no diagnosed recording of engine {engine_id!r} in this fleet")
    document, _, _ = trend_document(
        rows, engine_id=engine_id, fleet=str(fleet_id), analysis_version=ANALYSIS_VERSION
    )
    latest_id = max(rows, key=lambda r: (r.recorded_at, r.recording_id)).recording_id
    latest = await blocking(store.result, latest_id, ANALYSIS_VERSION, "diagnosis")
    return _page(
        engine_page(engine_id, document, latest, latest_id=latest_id, links=_Links, assets=STATIC_URL)
    )


@router.get("/ui/recordings/{recording_id}", response_class=HTMLResponse)
async def recording_view(fleet_id: PageFleet, recording_id: RecordingId, store: ServiceStore) -> HTMLResponse:
    """A recording's page: its diagnosis when there is one, else its analysis's state."""
    found = await blocking(store.recording_summary, fleet_id, recording_id, ANALYSIS_VERSION)
    if found is None:
        raise ApiError(404, "not_found", f"no recording {recording_id}")
    diagnosis, spectrum = await asyncio.gather(
        blocking(store.result, recording_id, ANALYSIS_VERSION, "diagnosis"),
        blocking(store.result, recording_id, ANALYSIS_VERSION, "spectrum"),
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


def add_pages(app: FastAPI) -> None:
    """Add the pages and their static files to the service."""
    app.include_router(router)
    app.mount(STATIC_URL, StaticFiles(directory=STATIC), name="ui-static")
