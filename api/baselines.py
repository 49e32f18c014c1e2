"""Baselines set from a stored recording: ``POST`` and ``GET /engines/{engine_id}/baseline``.

``POST`` calibrates a baseline on one of the fleet's stored recordings of that
engine, as ``engine-monitor calibrate`` does (:mod:`api.calibrate`: in a
process of its own at low priority, within a time and memory limit, one per
fleet at once), and stores it, replacing the engine's previous one; the
analyses that run after it compare that engine's bearing orders through it
(:class:`monitor.jobs.worker.Worker`). Results already stored are kept as they are.
A calibration the product refuses (an unhealthy recording, no bearing
channel, a faulty sensor) answers 422 with the product's message, and
nothing is stored. ``GET`` reads the stored baseline, 404 while there is none.

Another fleet's engine, recording or baseline answers 404, as an unknown one.
"""

from __future__ import annotations

import asyncio
from typing import Annotated, Any

from fastapi import APIRouter, Request
from fastapi import Path as FastPath
from pydantic import BaseModel, Field
from starlette.concurrency import run_in_threadpool

from api.auth import Fleet
from api.calibrate import calibrate_stored
from api.engines import visible_engine
from api.errors import ApiError, ErrorResponse
from api.reads import json_time
from monitor.diagnosis import ANALYSIS_VERSION
from monitor.store import BaselineRow, Store

__all__ = ["BaselineIn", "BaselineOut", "router"]

router = APIRouter(tags=["engines"])

EngineId = Annotated[
    str, FastPath(min_length=1, max_length=200, pattern=r"^[^\x00-\x1f\x7f]+$", description="the engine's id")
]


class BaselineIn(BaseModel):
    recording_id: int = Field(
        ge=1,
        le=2**31 - 1,
        description="the fleet's stored recording of this engine, healthy, at a steady speed",
    )
    load: float = Field(default=1.0, gt=0.0, le=1.5, description="the load it ran at [-] (1: rated)")


class BaselineOut(BaseModel):
    engine_id: str
    recording_id: int = Field(description="the recording it was calibrated on")
    analysis_version: str = Field(description="the analysis version that calibrated it")
    created_at: str
    baseline: dict[str, Any] = Field(description="the calibration (the document of engine-monitor calibrate)")


def _out(row: BaselineRow) -> dict[str, Any]:
    return {
        "engine_id": row.engine_id,
        "recording_id": row.recording_id,
        "analysis_version": row.analysis_version,
        "created_at": json_time(row.created_at),
        "baseline": row.document,
    }


def _engine(store: Store, fleet_id: int, engine_id: str) -> dict[str, Any] | None:
    """The fleet's own description (None for a bundled engine), or a 404 when the fleet has neither."""
    found = visible_engine(store, fleet_id, engine_id)
    if found is None:
        raise ApiError(404, "not_found", f"no engine {engine_id!r}")
    return found[0] if found[1] == "fleet" else None


_RESPONSES: dict[int | str, dict[str, Any]] = {
    code: {"model": ErrorResponse} for code in (400, 401, 403, 404, 422, 429)
}


@router.post(
    "/engines/{engine_id}/baseline", status_code=201, response_model=BaselineOut, responses=_RESPONSES
)
async def set_baseline(
    request: Request, fleet_id: Fleet, engine_id: EngineId, body: BaselineIn
) -> dict[str, Any]:
    """Calibrate the engine's baseline on one of the fleet's stored recordings of it, and store it (it
    replaces the engine's previous one); later analyses compare the bearing orders through it. A
    recording the calibration refuses answers 422 with the reason, and nothing is stored."""
    store: Store = request.app.state.store
    settings = request.app.state.settings
    description = await run_in_threadpool(_engine, store, fleet_id, engine_id)
    recording = await run_in_threadpool(store.recording, fleet_id, body.recording_id)
    if recording is None:
        raise ApiError(404, "not_found", f"no recording {body.recording_id}")
    if recording.engine_id != engine_id:
        raise ApiError(
            422,
            "engine_mismatch",
            f"recording {recording.id} is of engine {recording.engine_id!r}, not {engine_id!r}: calibrate "
            f"the baseline of {engine_id!r} on a recording of that engine",
        )
    running: set[int] = request.app.state.calibrating
    if fleet_id in running:
        raise ApiError(
            429,
            "calibration_in_progress",
            "this fleet has a calibration in progress: send the next when it has finished",
            headers={"Retry-After": "10"},
        )
    running.add(fleet_id)
    try:
        async with request.app.state.calibrations:
            calibration = await calibrate_stored(
                recording.path,
                description,
                load=body.load,
                name=recording.filename,
                memory_bytes=settings.calibration_memory_bytes,
                timeout_s=settings.calibration_timeout_s,
            )
    finally:
        running.discard(fleet_id)
    if not calibration.ok:
        raise ApiError(422, "calibration_failed", calibration.message)
    row = await run_in_threadpool(
        store.put_baseline, fleet_id, engine_id, recording.id, ANALYSIS_VERSION, calibration.document
    )
    return _out(row)


@router.get("/engines/{engine_id}/baseline", response_model=BaselineOut, responses=_RESPONSES)
def get_baseline(request: Request, fleet_id: Fleet, engine_id: EngineId) -> dict[str, Any]:
    """The engine's stored baseline (404 while none was set)."""
    store: Store = request.app.state.store
    _engine(store, fleet_id, engine_id)
    row = store.baseline(fleet_id, engine_id)
    if row is None:
        raise ApiError(
            404,
            "not_found",
            f"engine {engine_id!r} has no baseline: set one with POST /engines/{engine_id}/baseline",
        )
    return _out(row)


def calibration_limits(calibrations: int) -> tuple[asyncio.Semaphore, set[int]]:
    """The service's calibrations at once (a semaphore) and the fleets calibrating now (one each)."""
    return asyncio.Semaphore(calibrations), set()
