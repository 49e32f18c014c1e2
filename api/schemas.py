"""The service's request and response models, and the path parameters every route checks alike.

Each model is a schema of the OpenAPI document (its docstring and field descriptions are shown on the
docs page); answers are built as plain JSON from the store's rows and match these fields.
"""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Any, Literal

from fastapi import Path as FastPath
from pydantic import BaseModel, Field, model_validator

from api.engines import Source

MAX_POINTS = 8  # recordings one baseline is calibrated on at once (each a calibration of its own)

__all__ = [
    "ERRORS",
    "MAX_URL",
    "PRINTABLE",
    "READ",
    "BaselineIn",
    "BaselineOut",
    "DeliveryOut",
    "EngineId",
    "EngineIn",
    "EngineOut",
    "EngineSummaryOut",
    "ErrorBody",
    "ErrorResponse",
    "FleetOut",
    "Health",
    "LatestOut",
    "RecordingId",
    "RecordingOut",
    "RecordingPage",
    "UploadOut",
    "WebhookCreated",
    "WebhookId",
    "WebhookIn",
    "WebhookOut",
]

#: The longest webhook URL [characters].
MAX_URL = 2048

# printable text: a NUL or a control character in an id is refused (422) before it reaches a store
PRINTABLE = r"^[^\x00-\x1f\x7f]+$"
EngineId = Annotated[
    str, FastPath(min_length=1, max_length=200, pattern=PRINTABLE, description="the engine's id")
]
RecordingId = Annotated[int, FastPath(ge=1, le=2**31 - 1, description="the recording's id")]
WebhookId = Annotated[int, FastPath(ge=1, le=2**31 - 1, description="the webhook's id")]


class ErrorBody(BaseModel):
    status: int
    code: str
    message: str


class ErrorResponse(BaseModel):
    error: ErrorBody


ERRORS: dict[int | str, dict[str, Any]] = {
    code: {"model": ErrorResponse} for code in (400, 401, 404, 409, 413, 422, 503, 507)
}
#: the errors of a read, and its answer to a client whose copy is current
READ: dict[int | str, dict[str, Any]] = {
    **ERRORS,
    304: {"description": "not modified: the ETag sent in If-None-Match is the current one (no body)"},
}


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


class EngineIn(BaseModel):
    description: dict[str, Any] = Field(description="the engine description (the TOML's content as JSON)")


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


class BaselineIn(BaseModel):
    """One stored recording (``recording_id``, at ``load``), or several at different loads
    (``recording_ids``, each at its ``loads`` entry, or each load estimated when ``loads`` is left out)."""

    recording_id: int | None = Field(
        default=None,
        ge=1,
        le=2**31 - 1,
        description="the fleet's stored recording of this engine, healthy, at a steady speed",
    )
    load: float = Field(default=1.0, gt=0.0, le=1.5, description="the load it ran at [-] (1: rated)")
    recording_ids: list[Annotated[int, Field(ge=1, le=2**31 - 1)]] | None = Field(
        default=None,
        min_length=1,
        max_length=MAX_POINTS,
        description="several stored healthy recordings of this engine, one operating point (load) each",
    )
    loads: list[Annotated[float, Field(gt=0.0, le=1.1)]] | None = Field(
        default=None,
        description="the load of each of recording_ids, in the same order [-]; left out: estimated",
    )

    @model_validator(mode="after")
    def _one_way(self) -> BaselineIn:
        if (self.recording_id is None) == (self.recording_ids is None):
            raise ValueError("give recording_id, or recording_ids for several operating points")
        if self.loads is not None and (
            self.recording_ids is None or len(self.loads) != len(self.recording_ids)
        ):
            raise ValueError("loads needs recording_ids, one load each, in the same order")
        if self.recording_ids is not None and len(set(self.recording_ids)) != len(self.recording_ids):
            raise ValueError("recording_ids names a recording twice")
        return self

    def recordings(self) -> tuple[list[int], list[float] | None]:
        """The recordings' ids and their loads (None: each estimated)."""
        if self.recording_ids is None:
            assert self.recording_id is not None
            return [self.recording_id], [self.load]
        return list(self.recording_ids), None if self.loads is None else list(self.loads)


class BaselineOut(BaseModel):
    engine_id: str
    recording_id: int = Field(description="the recording it was calibrated on")
    analysis_version: str = Field(description="the analysis version that calibrated it")
    created_at: str
    baseline: dict[str, Any] = Field(description="the calibration (the document of engine-monitor calibrate)")


class WebhookIn(BaseModel):
    url: str = Field(
        min_length=1,
        max_length=MAX_URL,
        description="where the events are posted: http or https, with a host",
        examples=["https://alerts.example.com/engine-monitor"],
    )
    secret: str | None = Field(
        default=None,
        min_length=16,
        max_length=256,
        pattern=r"^[\x21-\x7e]+$",
        description="the key the events are signed with (HMAC-SHA256); made by the service when not given. "
        "Answered once, in this request's answer, and never again",
    )


class WebhookOut(BaseModel):
    id: int
    url: str
    created_at: str
    active: bool


class WebhookCreated(WebhookOut):
    secret: str = Field(description="the signing secret: answered this once, never again")


class DeliveryOut(BaseModel):
    id: int = Field(
        description="the delivery's id: the X-Engine-Monitor-Delivery header of its every attempt"
    )
    event_id: str = Field(description="the event's id (its body's id; X-Engine-Monitor-Event)")
    event_type: str = Field(description="diagnosis.finding or trend.finding")
    state: Literal["pending", "delivered", "failed", "cancelled"] = Field(
        description="pending (to be tried at next_attempt_at), delivered, failed (given up), cancelled "
        "(the webhook was deleted)"
    )
    attempts: int
    created_at: str
    last_attempt_at: str | None
    next_attempt_at: str | None = Field(description="while pending: when it is tried next")
    last_status: int | None = Field(
        description="the receiver's last HTTP status; null when it never answered"
    )
    last_error: str = Field(description="why the last attempt failed; empty when it did not")
    delivered_at: str | None
    body: str = Field(description="the event as sent, byte for byte (what the signature is of)")


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
