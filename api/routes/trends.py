"""Trends and the fleet at a glance, as JSON (with the API key, or a browser's session):

- ``GET /fleet``: each engine of the fleet with a diagnosed recording, its
  counts of alarms and warnings and its latest recording's verdict;
- ``GET /engines/{engine_id}/trend``: the engine's quantities over time and
  the drift found in them, the document of ``engine-monitor trend --json``
  (docs/trends.md); ``since`` and ``quantity`` narrow it.

The web pages show the same (:mod:`api.routes.pages`). Another fleet's engine
answers 404, as an unknown one.
"""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Query

from api import parameters
from api.auth import Fleet
from api.dependencies import ServiceStore
from api.errors import ApiError
from api.schemas import EngineId, ErrorResponse, FleetOut
from api.trends import blocking, engine_trend, fleet_engines
from monitor.diagnosis import ANALYSIS_VERSION
from monitor.store.trends import trend_document

__all__ = ["router"]

router = APIRouter(tags=["trends"])

_RESPONSES: dict[int | str, dict[str, Any]] = {
    401: {"model": ErrorResponse, "description": "no API key or session, or an unknown one"},
    404: {"model": ErrorResponse, "description": "no such engine or recording in this fleet"},
    422: {"model": ErrorResponse, "description": "a malformed parameter"},
}


@router.get("/fleet", response_model=FleetOut, responses=_RESPONSES)
async def get_fleet(fleet_id: Fleet, store: ServiceStore) -> dict[str, Any]:
    """Each engine of the fleet at a glance: its diagnosed recordings and its latest recording's verdict."""
    engines = await blocking(fleet_engines, store, fleet_id)
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


@router.get("/engines/{engine_id}/trend", responses=_RESPONSES)
async def get_trend(
    fleet_id: Fleet,
    engine_id: EngineId,
    store: ServiceStore,
    since: Annotated[
        str | None, Query(max_length=64, description="recordings from then on (ISO 8601)")
    ] = None,
    quantity: Annotated[
        list[str] | None, Query(max_length=20, description="only these quantities (docs/trends.md)")
    ] = None,
) -> dict[str, Any]:
    """The engine's quantities over time and the drift found in them (``engine-monitor trend --json``)."""
    start = parameters.since(since)
    rows = await blocking(engine_trend, store, fleet_id, engine_id, quantity or None, start)
    if not rows:
        raise ApiError(404, "not_found", f"no diagnosed recording of engine {engine_id!r} in this fleet")
    document, _, _ = trend_document(
        rows,
        engine_id=engine_id,
        fleet=str(fleet_id),
        analysis_version=ANALYSIS_VERSION,
        since=start,
    )
    return document
