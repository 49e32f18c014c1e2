"""Baselines set from a stored recording (the routes: :mod:`api.routes.baselines`).

A baseline is calibrated on one of the fleet's stored recordings of that
engine, or on several at different loads (one operating point each, the
document of several points stored whole: the store keeps the first
recording's id beside it), as ``engine-monitor calibrate`` does (:mod:`api.calibrate`: in a
process of its own at low priority, within a time and memory limit, one per
fleet at once, :class:`Calibrations`), and stored, replacing the engine's
previous one; the analyses that run after it compare that engine's bearing
orders through it (:class:`monitor.jobs.worker.Worker`). Results already
stored are kept as they are. A calibration the product refuses (an unhealthy
recording, one with neither a bearing channel nor crank-speed orders, a faulty
sensor) answers 422 with the product's message, and nothing is stored; a
recording of the crank speed alone gives a baseline without sensors.

Another fleet's engine, recording or baseline answers 404, as an unknown one.
"""

from __future__ import annotations

import asyncio
from typing import Any

from starlette.concurrency import run_in_threadpool

from api.calibrate import calibrate_stored
from api.engines import visible_engine
from api.errors import ApiError
from api.reads import json_time
from api.settings import Settings
from monitor.diagnosis import ANALYSIS_VERSION
from monitor.store import BaselineRow, Store

__all__ = ["Calibrations", "baseline_out", "calibrate_baseline", "fleet_description"]


class Calibrations:
    """The service's calibrations at once (a semaphore) and the fleets calibrating now (one each).

    Parameters
    ----------
    calibrations : int
        Baselines calibrated at once.
    """

    def __init__(self, calibrations: int) -> None:
        self.slots = asyncio.Semaphore(calibrations)
        self.running: set[int] = set()


def baseline_out(row: BaselineRow) -> dict[str, Any]:
    """A stored baseline as the service answers it (the fields of :class:`api.schemas.BaselineOut`)."""
    return {
        "engine_id": row.engine_id,
        "recording_id": row.recording_id,
        "analysis_version": row.analysis_version,
        "created_at": json_time(row.created_at),
        "baseline": row.document,
    }


def fleet_description(store: Store, fleet_id: int, engine_id: str) -> dict[str, Any] | None:
    """The fleet's own description (None for a bundled engine), or a 404 when the fleet has neither."""
    found = visible_engine(store, fleet_id, engine_id)
    if found is None:
        raise ApiError(404, "not_found", f"no engine {engine_id!r}")
    return found[0] if found[1] == "fleet" else None


async def calibrate_baseline(
    store: Store,
    settings: Settings,
    calibrations: Calibrations,
    fleet_id: int,
    engine_id: str,
    recording_ids: list[int],
    loads: list[float] | None,
) -> BaselineRow:
    """Calibrate the engine's baseline on the fleet's stored recordings (one operating point each) and
    store it: the stored row, or the ApiError that says why there is none (404, 422, 429 while the fleet
    calibrates another)."""
    description = await run_in_threadpool(fleet_description, store, fleet_id, engine_id)
    recordings = []
    for recording_id in recording_ids:
        recording = await run_in_threadpool(store.recording, fleet_id, recording_id)
        if recording is None:
            raise ApiError(404, "not_found", f"no recording {recording_id}")
        if recording.engine_id != engine_id:
            raise ApiError(
                422,
                "engine_mismatch",
                f"recording {recording.id} is of engine {recording.engine_id!r}, not {engine_id!r}: "
                f"calibrate the baseline of {engine_id!r} on recordings of that engine",
            )
        recordings.append(recording)
    running = calibrations.running
    if fleet_id in running:
        raise ApiError(
            429,
            "calibration_in_progress",
            "this fleet has a calibration in progress: send the next when it has finished",
            headers={"Retry-After": "10"},
        )
    running.add(fleet_id)
    try:
        async with calibrations.slots:
            calibration = await calibrate_stored(
                [r.path for r in recordings],
                description,
                loads=loads,
                names=[r.filename for r in recordings],
                memory_bytes=settings.calibration_memory_bytes,
                timeout_s=settings.calibration_timeout_s * len(recordings),
            )
    finally:
        running.discard(fleet_id)
    if not calibration.ok:
        raise ApiError(422, "calibration_failed", calibration.message)
    return await run_in_threadpool(
        store.put_baseline, fleet_id, engine_id, recordings[0].id, ANALYSIS_VERSION, calibration.document
    )
