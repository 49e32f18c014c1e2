"""The store's webhooks and their outbox: receivers registered, events queued with their diagnosis,
deliveries claimed, attempted and logged.

A delivery is one event for one webhook. :func:`enqueue_events` writes the
deliveries of a diagnosis' new findings (:mod:`monitor.report.events`) in the
transaction that stores the diagnosis (:meth:`monitor.store.Store.complete`),
so an event exists exactly when its diagnosis does, and the unique key
(webhook, event id) keeps one delivery of an event per webhook however often
it is queued.

A sender takes a due delivery with :func:`claim` (a compare-and-set on its
attempts, which it counts, and which moves its next attempt past the claim's
lease, so two senders never post it at once and a sender that dies leaves it
to be taken again after the lease), posts it, and records the answer with
:func:`record_attempt`: delivered, or pending with its next attempt, or failed
for good. Each change is one transaction.
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from typing import Any

import sqlalchemy as sa
from sqlalchemy.engine import Connection

from monitor.report.events import diagnosis_event, event_body, new_drifts, new_findings, trend_event
from monitor.store.schema import fleets, recordings, results, webhook_deliveries, webhooks
from monitor.store.trends import DIAGNOSIS_KIND, _recording_time, read_trend

__all__ = [
    "DeliveryRow",
    "DueDelivery",
    "WebhookRow",
    "add_webhook",
    "claim",
    "deactivate_webhook",
    "deliveries",
    "due_deliveries",
    "enqueue_events",
    "record_attempt",
    "webhook",
    "webhooks_of",
]

log = logging.getLogger("engine_monitor.alerts")


def _now() -> datetime:
    return datetime.now(UTC)


def _utc(moment: datetime | None) -> datetime | None:
    """SQLite keeps no time zone: every stored time is UTC."""
    if moment is None:
        return None
    return moment if moment.tzinfo is not None else moment.replace(tzinfo=UTC)


@dataclass(frozen=True)
class WebhookRow:
    """A fleet's webhook: where its events go, and the secret they are signed with."""

    id: int
    fleet_id: int
    url: str
    secret: str
    created_at: datetime
    active: bool


@dataclass(frozen=True)
class DeliveryRow:
    """One event for one webhook: the body as sent, and where its delivery stands.

    ``state`` is pending (to be tried at ``next_attempt_at``), delivered, failed (given up) or
    cancelled (its webhook was deleted); ``last_status`` the receiver's last HTTP status (None when it
    never answered), ``last_error`` why the last attempt failed ("" when it did not).
    """

    id: int
    webhook_id: int
    event_id: str
    event_type: str
    body: str
    state: str
    attempts: int
    next_attempt_at: datetime
    last_attempt_at: datetime | None
    last_status: int | None
    last_error: str
    created_at: datetime
    delivered_at: datetime | None


@dataclass(frozen=True)
class DueDelivery:
    """A delivery a sender holds (claimed): the row, and the webhook's URL and secret."""

    delivery: DeliveryRow
    url: str
    secret: str


def _webhook(row: Any) -> WebhookRow:
    return WebhookRow(
        int(row.id), int(row.fleet_id), row.url, row.secret, _utc(row.created_at) or _now(), bool(row.active)
    )


def _delivery(row: Any) -> DeliveryRow:
    return DeliveryRow(
        int(row.id),
        int(row.webhook_id),
        row.event_id,
        row.event_type,
        row.body,
        row.state,
        int(row.attempts),
        _utc(row.next_attempt_at) or _now(),
        _utc(row.last_attempt_at),
        None if row.last_status is None else int(row.last_status),
        row.last_error,
        _utc(row.created_at) or _now(),
        _utc(row.delivered_at),
    )


# ------------------------------------------------------------------------------------- webhooks
def add_webhook(c: Connection, fleet_id: int, url: str, secret: str) -> WebhookRow:
    """Register a webhook of a fleet (active from now on).

    Parameters
    ----------
    c : Connection
        In a transaction.
    fleet_id : int
    url : str
        Validated by the caller (http or https, a host).
    secret : str
        The key its events are signed with.
    """
    now = _now()
    created = c.execute(
        sa.insert(webhooks)
        .values(fleet_id=fleet_id, url=url, secret=secret, created_at=now, active=True)
        .returning(webhooks.c.id)
    ).scalar_one()
    return WebhookRow(int(created), fleet_id, url, secret, now, True)


def webhooks_of(c: Connection, fleet_id: int) -> list[WebhookRow]:
    """A fleet's active webhooks, by id.

    Parameters
    ----------
    c : Connection
    fleet_id : int
    """
    rows = c.execute(
        sa.select(webhooks)
        .where((webhooks.c.fleet_id == fleet_id) & webhooks.c.active)
        .order_by(webhooks.c.id)
    )
    return [_webhook(r) for r in rows]


def webhook(c: Connection, fleet_id: int, webhook_id: int) -> WebhookRow | None:
    """A fleet's active webhook by id; None for another fleet's, a deleted one or an unknown one.

    Parameters
    ----------
    c : Connection
    fleet_id, webhook_id : int
    """
    row = c.execute(
        sa.select(webhooks).where(
            (webhooks.c.id == webhook_id) & (webhooks.c.fleet_id == fleet_id) & webhooks.c.active
        )
    ).first()
    return None if row is None else _webhook(row)


def deactivate_webhook(c: Connection, fleet_id: int, webhook_id: int) -> bool:
    """Delete a fleet's webhook: it gets no more events, and its pending deliveries are cancelled (its
    delivery log is kept). False for another fleet's, a deleted one or an unknown one.

    Parameters
    ----------
    c : Connection
        In a transaction.
    fleet_id, webhook_id : int
    """
    changed = c.execute(
        sa.update(webhooks)
        .where((webhooks.c.id == webhook_id) & (webhooks.c.fleet_id == fleet_id) & webhooks.c.active)
        .values(active=False)
    ).rowcount
    if changed != 1:
        return False
    c.execute(
        sa.update(webhook_deliveries)
        .where((webhook_deliveries.c.webhook_id == webhook_id) & (webhook_deliveries.c.state == "pending"))
        .values(state="cancelled", last_error="the webhook was deleted")
    )
    return True


def deliveries(
    c: Connection, fleet_id: int, webhook_id: int, *, before: int | None = None, limit: int = 50
) -> list[DeliveryRow] | None:
    """A fleet's webhook's deliveries, newest first; None for a webhook the fleet does not have.

    Parameters
    ----------
    c : Connection
    fleet_id, webhook_id : int
    before : int, optional
        Only deliveries with a smaller id (the next page after the one that ended with that id).
    limit : int, optional
    """
    if webhook(c, fleet_id, webhook_id) is None:
        return None
    where = webhook_deliveries.c.webhook_id == webhook_id
    if before is not None:
        where &= webhook_deliveries.c.id < before
    rows = c.execute(
        sa.select(webhook_deliveries).where(where).order_by(webhook_deliveries.c.id.desc()).limit(limit)
    )
    return [_delivery(r) for r in rows]


# ---------------------------------------------------------------------------------------- events
def _insert_ignoring_existing(c: Connection, rows: list[dict[str, Any]]) -> None:
    if not rows:
        return
    if c.dialect.name == "postgresql":
        from sqlalchemy.dialects.postgresql import insert
    else:
        from sqlalchemy.dialects.sqlite import insert  # type: ignore[assignment]
    keys = ["webhook_id", "event_id"]
    c.execute(insert(webhook_deliveries).on_conflict_do_nothing(index_elements=keys), rows)


def _previous_findings(
    c: Connection, fleet_id: int, engine_id: str, recording_id: int, analysis_version: str, when: datetime
) -> list[dict[str, Any]] | None:
    """The findings of the engine's diagnosis just before the recording (by time, then id), or None."""
    rows = c.execute(
        sa.select(results.c.recording_id, recordings.c.recorded_at, recordings.c.uploaded_at)
        .join(recordings, recordings.c.id == results.c.recording_id)
        .where(
            (recordings.c.fleet_id == fleet_id)
            & (recordings.c.engine_id == engine_id)
            & (results.c.analysis_version == analysis_version)
            & (results.c.kind == DIAGNOSIS_KIND)
            & (results.c.recording_id != recording_id)
        )
    ).all()
    earlier = [
        (_recording_time(r.recorded_at, r.uploaded_at), int(r.recording_id))
        for r in rows
        if (_recording_time(r.recorded_at, r.uploaded_at), int(r.recording_id)) < (when, recording_id)
    ]
    if not earlier:
        return None
    _, previous = max(earlier)
    stored = c.execute(
        sa.select(results.c.document).where(
            (results.c.recording_id == previous)
            & (results.c.analysis_version == analysis_version)
            & (results.c.kind == DIAGNOSIS_KIND)
        )
    ).scalar_one()
    document = json.loads(stored) if isinstance(stored, str) else stored
    found = document.get("findings") if isinstance(document, dict) else None
    return list(found) if isinstance(found, list) else []


def _events(
    c: Connection, recording_id: int, analysis_version: str, document: dict[str, Any], fleet_id: int
) -> list[dict[str, Any]]:
    """The events of a diagnosis' new findings (module :mod:`monitor.report.events`)."""
    row = c.execute(
        sa.select(
            recordings.c.engine_id,
            recordings.c.filename,
            recordings.c.recorded_at,
            recordings.c.uploaded_at,
            fleets.c.name,
        )
        .join(fleets, fleets.c.id == recordings.c.fleet_id)
        .where(recordings.c.id == recording_id)
    ).one()
    when = _recording_time(row.recorded_at, row.uploaded_at)
    previous = _previous_findings(c, fleet_id, row.engine_id, recording_id, analysis_version, when)
    findings = document.get("findings")
    fresh = new_findings(findings if isinstance(findings, list) else [], previous)
    series: dict[str, list[tuple[int, datetime, float]]] = {}
    units: dict[str, str] = {}
    for point in read_trend(c, fleet_id, row.engine_id, analysis_version=analysis_version):
        if (point.recorded_at, point.recording_id) <= (when, recording_id):
            series.setdefault(point.quantity, []).append((point.recording_id, point.recorded_at, point.value))
            units[point.quantity] = point.unit
    drifts = new_drifts(series, recording_id, units=units)
    recording = {
        "id": recording_id,
        "filename": row.filename,
        "recorded_at": row.recorded_at,
        "fleet": row.name,
        "engine_id": row.engine_id,
    }
    status, now = str(document.get("status", "")), _now()
    return [
        diagnosis_event(
            f, recording=recording, analysis_version=analysis_version, diagnosis_status=status, created_at=now
        )
        for f in fresh
    ] + [
        trend_event(
            d, recording=recording, analysis_version=analysis_version, diagnosis_status=status, created_at=now
        )
        for d in drifts
    ]


def enqueue_events(c: Connection, recording_id: int, analysis_version: str, document: dict[str, Any]) -> int:
    """Queue the events of a stored diagnosis' new findings for every active webhook of its fleet.

    Called in the transaction that stores the diagnosis and its trend points. A failure to work out
    the events (a document of an unexpected shape) is logged and queues none: an alert never keeps a
    diagnosis from being stored.

    Parameters
    ----------
    c : Connection
        In the transaction that stores the diagnosis (after its trend points).
    recording_id : int
    analysis_version : str
    document : dict
        The diagnosis document.

    Returns
    -------
    int
        Deliveries given to the store (one per webhook and event; those already queued are kept).
    """
    fleet = c.execute(sa.select(recordings.c.fleet_id).where(recordings.c.id == recording_id)).first()
    if fleet is None:
        return 0
    hooks = webhooks_of(c, int(fleet.fleet_id))
    if not hooks:
        return 0
    try:
        events = _events(c, recording_id, analysis_version, document, int(fleet.fleet_id))
    except Exception:
        log.exception("recording %d: its alerts could not be worked out; none queued", recording_id)
        return 0
    now = _now()
    rows = [
        {
            "webhook_id": hook.id,
            "event_id": event["id"],
            "event_type": event["type"],
            "body": event_body(event),
            "state": "pending",
            "attempts": 0,
            "next_attempt_at": now,
            "last_error": "",
            "created_at": now,
        }
        for hook in hooks
        for event in events
    ]
    _insert_ignoring_existing(c, rows)
    return len(rows)


# ------------------------------------------------------------------------------------ deliveries
def due_deliveries(
    c: Connection, *, fleet_id: int | None = None, without: set[int] | None = None, limit: int = 100
) -> list[tuple[int, int]]:
    """The pending deliveries of active webhooks due now: (delivery id, webhook id), oldest due first.

    Parameters
    ----------
    c : Connection
    fleet_id : int, optional
        Only this fleet's.
    without : set of int, optional
        Leave out these webhooks' deliveries.
    limit : int, optional
    """
    where = (
        (webhook_deliveries.c.state == "pending")
        & (webhook_deliveries.c.next_attempt_at <= _now())
        & webhooks.c.active
    )
    if fleet_id is not None:
        where &= webhooks.c.fleet_id == fleet_id
    if without:
        where &= webhook_deliveries.c.webhook_id.not_in(sorted(without))
    rows = c.execute(
        sa.select(webhook_deliveries.c.id, webhook_deliveries.c.webhook_id)
        .join(webhooks, webhooks.c.id == webhook_deliveries.c.webhook_id)
        .where(where)
        .order_by(webhook_deliveries.c.next_attempt_at, webhook_deliveries.c.id)
        .limit(limit)
    ).all()
    return [(int(r.id), int(r.webhook_id)) for r in rows]


def claim(c: Connection, delivery_id: int, lease: timedelta) -> DueDelivery | None:
    """Take a due delivery to post it now: its attempts counted, its next attempt moved ``lease`` on.

    None when another sender took it first, or it is no longer pending and due.

    Parameters
    ----------
    c : Connection
        In a transaction.
    delivery_id : int
    lease : timedelta
        How long the sender may take before another may take the delivery again (more than a post's
        timeout).
    """
    now = _now()
    row = c.execute(
        sa.select(webhook_deliveries, webhooks.c.url, webhooks.c.secret)
        .join(webhooks, webhooks.c.id == webhook_deliveries.c.webhook_id)
        .where(
            (webhook_deliveries.c.id == delivery_id)
            & (webhook_deliveries.c.state == "pending")
            & (webhook_deliveries.c.next_attempt_at <= now)
            & webhooks.c.active
        )
    ).first()
    if row is None:
        return None
    taken = c.execute(
        sa.update(webhook_deliveries)
        .where(
            (webhook_deliveries.c.id == delivery_id)
            & (webhook_deliveries.c.state == "pending")
            & (webhook_deliveries.c.attempts == row.attempts)
        )
        .values(attempts=row.attempts + 1, next_attempt_at=now + lease, last_attempt_at=now)
    ).rowcount
    if taken != 1:
        return None
    held = c.execute(sa.select(webhook_deliveries).where(webhook_deliveries.c.id == delivery_id)).one()
    return DueDelivery(_delivery(held), row.url, row.secret)


def record_attempt(
    c: Connection,
    held: DeliveryRow,
    *,
    status: int | None,
    error: str,
    delivered: bool,
    retry_at: datetime | None,
) -> str:
    """Record the answer to a claimed delivery's attempt; its new state.

    Parameters
    ----------
    c : Connection
        In a transaction.
    held : DeliveryRow
        As :func:`claim` returned it (its attempts identify this attempt: a sender whose lease ran out
        and whose delivery was taken again records nothing).
    status : int or None
        The receiver's HTTP status; None when it never answered.
    error : str
        Why the attempt failed ("" when it did not).
    delivered : bool
        Whether the receiver took it (a 2xx answer).
    retry_at : datetime or None
        When to try again after a failure; None: give up (failed).

    Returns
    -------
    str
        "delivered", "pending", "failed"; or the state another sender left it in.
    """
    now = _now()
    if delivered:
        values: dict[str, Any] = {"state": "delivered", "delivered_at": now, "next_attempt_at": now}
    elif retry_at is not None:
        values = {"state": "pending", "next_attempt_at": retry_at}
    else:
        values = {"state": "failed", "next_attempt_at": now}
    mine = (
        (webhook_deliveries.c.id == held.id)
        & (webhook_deliveries.c.state == "pending")
        & (webhook_deliveries.c.attempts == held.attempts)
    )
    changed = c.execute(
        sa.update(webhook_deliveries)
        .where(mine)
        .values(last_status=status, last_error=error[:2000], **values)
    ).rowcount
    if changed != 1:
        state = c.execute(
            sa.select(webhook_deliveries.c.state).where(webhook_deliveries.c.id == held.id)
        ).scalar_one()
        return str(state)
    return str(values["state"])
