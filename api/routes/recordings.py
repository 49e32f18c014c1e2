"""Recordings: ``POST /recordings`` uploads one (:mod:`api.uploads`), ``GET /recordings`` pages the
fleet's, ``GET /recordings/{recording_id}`` reads one's metadata and the state of its analysis.

Another fleet's recording answers 404, as an unknown one.
"""

from __future__ import annotations

from functools import partial
from typing import Annotated, Any

from fastapi import APIRouter, Query, Request
from fastapi.responses import Response
from starlette.concurrency import run_in_threadpool

from api import parameters
from api.auth import Fleet
from api.dependencies import ServiceStore, ServiceUploads, wake_worker
from api.errors import ApiError
from api.reads import conditional, json_body, json_time, read
from api.schemas import (
    ERRORS,
    PRINTABLE,
    READ,
    ErrorResponse,
    RecordingId,
    RecordingOut,
    RecordingPage,
    UploadOut,
)
from monitor.diagnosis import ANALYSIS_VERSION
from monitor.store import RecordingSummary, Store

__all__ = ["recording_out", "router"]

router = APIRouter(tags=["recordings"])


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


def _own(store: Store, fleet_id: int, recording_id: int) -> RecordingSummary:
    found = store.recording_summary(fleet_id, recording_id, ANALYSIS_VERSION)
    if found is None:
        raise ApiError(404, "not_found", f"no recording {recording_id}")
    return found


@router.post(
    "/recordings",
    status_code=201,
    response_model=UploadOut,
    responses={
        **ERRORS,
        200: {"model": UploadOut, "description": "the same content was stored before"},
        415: {"model": ErrorResponse, "description": "the body's bytes are neither HDF5 nor MCAP"},
    },
)
async def upload(
    request: Request,
    fleet_id: Fleet,
    filename: Annotated[str, Query(min_length=1, max_length=1024, description="the file's name")],
    store: ServiceStore,
    uploads: ServiceUploads,
) -> Response:
    """Upload a recording (HDF5 or MCAP) as the request body; its analysis is queued. The bytes tell
    the format, whatever the content type says (curl --data-binary sends a form's); a multipart form
    (curl -F) is refused."""
    name = parameters.filename(filename)
    row, created = await uploads.take(request, store, fleet_id, name)
    wake_worker(request)
    view = await run_in_threadpool(_own, store, fleet_id, row.id)
    return Response(
        json_body({**recording_out(view), "created": created}),
        status_code=201 if created else 200,
        media_type="application/json",
    )


@router.get("/recordings", response_model=RecordingPage, responses=ERRORS)
async def list_recordings(
    request: Request,
    fleet_id: Fleet,
    store: ServiceStore,
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
    offset: Annotated[int, Query(ge=0, le=10**9, description="recordings skipped (after the cursor)")] = 0,
    limit: Annotated[int, Query(ge=1, le=500)] = 50,
) -> Response:
    """The fleet's recordings, newest first; filter by engine and upload time; page by cursor."""
    after = parameters.cursor(cursor) if cursor is not None else None
    found = await read(
        request,
        partial(
            store.recording_summaries,
            fleet_id,
            ANALYSIS_VERSION,
            engine_id=engine_id,
            since=parameters.moment("since", since),
            until=parameters.moment("until", until),
            after=after,
            offset=offset,
            limit=limit + 1,
        ),
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
                "next_cursor": parameters.next_cursor(last.uploaded_at, last.id)
                if last is not None
                else None,
            }
        ),
        media_type="application/json",
    )


@router.get("/recordings/{recording_id}", response_model=RecordingOut, responses=READ)
async def get_recording(
    request: Request, fleet_id: Fleet, recording_id: RecordingId, store: ServiceStore
) -> Response:
    """A recording's metadata and the state of its analysis (ETag: 304 while it is unchanged)."""
    view = await read(request, _own, store, fleet_id, recording_id)
    return conditional(request.headers.get("if-none-match"), json_body(recording_out(view)))
