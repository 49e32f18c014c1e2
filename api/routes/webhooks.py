"""Alerts: a fleet's webhooks, ``POST, GET /webhooks``, ``GET, DELETE /webhooks/{id}``, and their
delivery log, ``GET /webhooks/{id}/deliveries``.

Each new finding of a diagnosis of the fleet's recordings (a warning or an
alarm the engine's previous diagnosis did not have, or a trend finding found
at that recording: :mod:`monitor.report.events`) is posted to every active webhook
of the fleet as one signed JSON event (:mod:`monitor.jobs.delivery`), by a
deliverer this router runs beside the service (started and stopped with it),
and retried with back-off while the receiver does not take it.

The URL must be ``http`` or ``https`` with a host, in ASCII, without user and
password (they would be shown in every listing), at most 2048 characters. The secret
(16 to 256 printable ASCII characters, or made by the service when none is
given) is answered once, by ``POST``, and never again. A fleet has at most
:data:`MAX_WEBHOOKS` webhooks. ``DELETE`` stops its events and cancels those
still pending; another fleet's webhook, a deleted one, answers 404 as an
unknown one.
"""

from __future__ import annotations

import secrets
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Annotated, Any
from urllib.parse import urlsplit

from fastapi import APIRouter, FastAPI, Query, Response
from starlette.concurrency import run_in_threadpool

from api.auth import Fleet
from api.dependencies import ServiceStore
from api.errors import ApiError
from api.reads import json_time
from api.schemas import MAX_URL, DeliveryOut, ErrorResponse, WebhookCreated, WebhookId, WebhookIn, WebhookOut
from monitor.jobs.delivery import Deliverer, DeliveryPolicy
from monitor.store.webhooks import (
    DeliveryRow,
    WebhookRow,
    add_webhook,
    deactivate_webhook,
    deliveries,
    webhook,
    webhooks_of,
)

__all__ = ["MAX_WEBHOOKS", "router"]

MAX_WEBHOOKS = 20  # a fleet's active webhooks at most


@asynccontextmanager
async def _deliverer(app: FastAPI) -> AsyncIterator[None]:
    """The service's deliverer: started with the service (after its store opens), stopped before the
    store closes."""
    policy: DeliveryPolicy = app.state.settings.alerts
    running = Deliverer(app.state.store, policy)
    running.start()
    try:
        yield
    finally:
        await run_in_threadpool(running.stop)


router = APIRouter(tags=["webhooks"], lifespan=_deliverer)

_RESPONSES: dict[int | str, dict[str, Any]] = {
    code: {"model": ErrorResponse} for code in (400, 401, 403, 404, 409, 422)
}


def _checked_url(url: str) -> str:
    """A URL the deliverer can post to, or a clear 422."""
    problem = ""
    try:
        parts = urlsplit(url)
        port = parts.port  # a port that is not a number, or out of range, raises
    except ValueError as error:
        parts, port, problem = None, None, str(error)
    if parts is not None and not problem:
        if parts.scheme not in ("http", "https"):
            problem = f"the scheme is {parts.scheme or 'missing'!r}"
        elif not parts.hostname:
            problem = "it names no host"
        elif parts.username is not None or parts.password is not None:
            problem = "it holds a user or password (it would be shown in every listing)"
        elif parts.fragment:
            problem = "it has a fragment (#...), which is never sent"
        elif any(ord(ch) <= 0x20 or ord(ch) == 0x7F for ch in url):
            problem = "it holds spaces or control characters"
        elif not url.isascii():
            problem = (
                "it holds characters outside ASCII (write the host in punycode, the path percent-encoded)"
            )
        elif port == 0:
            problem = "its port is 0"
    if problem:
        raise ApiError(
            422,
            "invalid_webhook",
            f"url: expected an http or https URL with a host, without user, password or fragment, at most "
            f"{MAX_URL} characters; {problem}",
        )
    return url


def _out(row: WebhookRow) -> dict[str, Any]:
    return {"id": row.id, "url": row.url, "created_at": json_time(row.created_at), "active": row.active}


def _delivery_out(row: DeliveryRow) -> dict[str, Any]:
    return {
        "id": row.id,
        "event_id": row.event_id,
        "event_type": row.event_type,
        "state": row.state,
        "attempts": row.attempts,
        "created_at": json_time(row.created_at),
        "last_attempt_at": None if row.last_attempt_at is None else json_time(row.last_attempt_at),
        "next_attempt_at": json_time(row.next_attempt_at) if row.state == "pending" else None,
        "last_status": row.last_status,
        "last_error": row.last_error,
        "delivered_at": None if row.delivered_at is None else json_time(row.delivered_at),
        "body": row.body,
    }


@router.post("/webhooks", status_code=201, response_model=WebhookCreated, responses=_RESPONSES)
def create_webhook(fleet_id: Fleet, body: WebhookIn, store: ServiceStore) -> dict[str, Any]:
    """Register a webhook: each new finding of the fleet's diagnoses is posted to it as a signed event.
    The answer holds the signing secret, this once."""
    url = _checked_url(body.url)
    secret = body.secret if body.secret is not None else secrets.token_urlsafe(32)
    with store.transaction() as c:
        if len(webhooks_of(c, fleet_id)) >= MAX_WEBHOOKS:
            raise ApiError(
                409,
                "too_many_webhooks",
                f"this fleet has {MAX_WEBHOOKS} webhooks, the most it may have: delete one first",
            )
        row = add_webhook(c, fleet_id, url, secret)
    return {**_out(row), "secret": secret}


@router.get("/webhooks", response_model=list[WebhookOut], responses=_RESPONSES)
def list_webhooks(fleet_id: Fleet, store: ServiceStore) -> list[dict[str, Any]]:
    """The fleet's webhooks (never their secrets), by id."""
    with store.db.connect() as c:
        return [_out(row) for row in webhooks_of(c, fleet_id)]


@router.get("/webhooks/{webhook_id}", response_model=WebhookOut, responses=_RESPONSES)
def get_webhook(fleet_id: Fleet, webhook_id: WebhookId, store: ServiceStore) -> dict[str, Any]:
    """One of the fleet's webhooks (never its secret)."""
    with store.db.connect() as c:
        row = webhook(c, fleet_id, webhook_id)
    if row is None:
        raise ApiError(404, "not_found", f"no webhook {webhook_id}")
    return _out(row)


@router.delete("/webhooks/{webhook_id}", status_code=204, response_class=Response, responses=_RESPONSES)
def delete_webhook(fleet_id: Fleet, webhook_id: WebhookId, store: ServiceStore) -> Response:
    """Delete a webhook: no more events go to it, and those still pending are cancelled."""
    with store.transaction() as c:
        if not deactivate_webhook(c, fleet_id, webhook_id):
            raise ApiError(404, "not_found", f"no webhook {webhook_id}")
    return Response(status_code=204)


@router.get("/webhooks/{webhook_id}/deliveries", response_model=list[DeliveryOut], responses=_RESPONSES)
def list_deliveries(
    fleet_id: Fleet,
    webhook_id: WebhookId,
    store: ServiceStore,
    before: Annotated[
        int | None,
        Query(ge=1, le=2**31 - 1, description="only deliveries of smaller id: the page after it"),
    ] = None,
    limit: Annotated[int, Query(ge=1, le=500)] = 50,
) -> list[dict[str, Any]]:
    """The webhook's delivery log, newest first: each event, its state, attempts and last answer."""
    with store.db.connect() as c:
        rows = deliveries(c, fleet_id, webhook_id, before=before, limit=limit)
    if rows is None:
        raise ApiError(404, "not_found", f"no webhook {webhook_id}")
    return [_delivery_out(row) for row in rows]
