"""A recording's results: its diagnosis and spectra as stored (never parsed, tagged with their digest),
and its diagnosis plot.

A result not there yet answers 409 with the state of its analysis; one that will never come (the
analysis was set aside) 422; another fleet's recording 404, as an unknown one.
"""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Request
from fastapi.responses import FileResponse, Response

from api.auth import Fleet
from api.dependencies import ServiceSettings, ServiceStore
from api.errors import ApiError
from api.reads import conditional, read
from api.schemas import ERRORS, READ, RecordingId
from monitor.diagnosis import ANALYSIS_VERSION
from monitor.store import Store, StoredResult

__all__ = ["router"]

router = APIRouter(tags=["results"])


def _result(store: Store, fleet_id: int, recording_id: int, kind: str) -> StoredResult:
    """A fleet's recording's stored result, or the 404, 409 or 422 that says why there is none."""
    found = store.stored_result(fleet_id, recording_id, ANALYSIS_VERSION, kind)
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


async def _stored(request: Request, store: Store, fleet_id: int, recording_id: int, kind: str) -> Response:
    """The stored result as it is stored (never parsed), tagged with its digest."""
    found = await read(request, _result, store, fleet_id, recording_id, kind)
    return conditional(request.headers.get("if-none-match"), found.text.encode("utf-8"), found.digest)


@router.get("/recordings/{recording_id}/diagnosis", response_model=dict[str, Any], responses=READ)
async def get_diagnosis(
    request: Request, fleet_id: Fleet, recording_id: RecordingId, store: ServiceStore
) -> Response:
    """The diagnosis (the document of ``engine-monitor compare --json``, docs/diagnosis.md), as stored;
    ETag: the digest of its text."""
    return await _stored(request, store, fleet_id, recording_id, "diagnosis")


@router.get("/recordings/{recording_id}/spectrum", response_model=dict[str, Any], responses=READ)
async def get_spectrum(
    request: Request, fleet_id: Fleet, recording_id: RecordingId, store: ServiceStore
) -> Response:
    """The measured order spectra of every channel (peak amplitudes, phases in degrees), as stored;
    ETag: the digest of its text."""
    return await _stored(request, store, fleet_id, recording_id, "spectrum")


@router.get(
    "/recordings/{recording_id}/plot",
    response_class=FileResponse,
    responses={**ERRORS, 200: {"content": {"image/png": {}}}},
)
def get_plot(
    fleet_id: Fleet, recording_id: RecordingId, store: ServiceStore, settings: ServiceSettings
) -> FileResponse:
    """The diagnosis plot (PNG): measured against predicted orders, cylinder strengths. It is served
    from the file the store recorded with the recording's diagnosis, and from nowhere else."""
    _result(store, fleet_id, recording_id, "diagnosis")
    kept = store.plot(fleet_id, recording_id, ANALYSIS_VERSION)  # by id, never by a file's name
    path = settings.data_dir / kept if kept is not None else None
    if path is None or not path.is_file():
        raise ApiError(
            404,
            "not_found",
            f"recording {recording_id}: no plot is kept"
            + ("" if path is None else " in this server's data folder (its file is missing)"),
        )
    return FileResponse(path, media_type="image/png")
