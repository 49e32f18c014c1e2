"""An engine's baseline: ``POST /engines/{engine_id}/baseline`` calibrates one on a stored recording
and stores it (:mod:`api.baselines`); ``GET`` reads the stored baseline, 404 while there is none.

Another fleet's engine, recording or baseline answers 404, as an unknown one.
"""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter

from api.auth import Fleet
from api.baselines import baseline_out, calibrate_baseline, fleet_description
from api.dependencies import ServiceCalibrations, ServiceSettings, ServiceStore
from api.errors import ApiError
from api.schemas import BaselineIn, BaselineOut, EngineId, ErrorResponse

__all__ = ["router"]

router = APIRouter(tags=["engines"])

_RESPONSES: dict[int | str, dict[str, Any]] = {
    code: {"model": ErrorResponse} for code in (400, 401, 403, 404, 422, 429)
}


@router.post(
    "/engines/{engine_id}/baseline", status_code=201, response_model=BaselineOut, responses=_RESPONSES
)
async def set_baseline(
    fleet_id: Fleet,
    engine_id: EngineId,
    body: BaselineIn,
    store: ServiceStore,
    settings: ServiceSettings,
    calibrations: ServiceCalibrations,
) -> dict[str, Any]:
    """Calibrate the engine's baseline on one of the fleet's stored recordings of it, or on several at
    different loads (``recording_ids``, with ``loads`` or each load estimated), and store it (it
    replaces the engine's previous one); later analyses compare through it at their own load. A
    recording the calibration refuses answers 422 with the reason, and nothing is stored."""
    ids, loads = body.recordings()
    row = await calibrate_baseline(store, settings, calibrations, fleet_id, engine_id, ids, loads)
    return baseline_out(row)


@router.get("/engines/{engine_id}/baseline", response_model=BaselineOut, responses=_RESPONSES)
def get_baseline(fleet_id: Fleet, engine_id: EngineId, store: ServiceStore) -> dict[str, Any]:
    """The engine's stored baseline (404 while none was set)."""
    fleet_description(store, fleet_id, engine_id)
    row = store.baseline(fleet_id, engine_id)
    if row is None:
        raise ApiError(
            404,
            "not_found",
            f"engine {engine_id!r} has no baseline: set one with POST /engines/{engine_id}/baseline",
        )
    return baseline_out(row)
