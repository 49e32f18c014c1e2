"""The alerts of a stored diagnosis: the events of its new findings and drifts, queued for its fleet's
webhooks.

:func:`enqueue_events` works out the events of a diagnosis' new findings
(:mod:`monitor.report.events`) and writes their deliveries to the outbox
(:mod:`monitor.store.webhooks`) in the transaction that stores the diagnosis
(:meth:`monitor.store.results.ResultStore.complete`), so an event exists exactly
when its diagnosis does, and the unique key (webhook, event id) keeps one
delivery of an event per webhook however often it is queued.
"""

from __future__ import annotations

import json
import logging
from datetime import datetime
from typing import Any

import sqlalchemy as sa
from sqlalchemy.engine import Connection

from monitor.report.events import diagnosis_event, event_body, new_drifts, new_findings, trend_event
from monitor.store.schema import fleets, recordings, results, webhook_deliveries
from monitor.store.sql import insert_ignoring_existing, now
from monitor.store.trends import DIAGNOSIS_KIND, read_trend, recording_time
from monitor.store.webhooks import webhooks_of

__all__ = ["enqueue_events"]

log = logging.getLogger("engine_monitor.alerts")


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
        (recording_time(r.recorded_at, r.uploaded_at), int(r.recording_id))
        for r in rows
        if (recording_time(r.recorded_at, r.uploaded_at), int(r.recording_id)) < (when, recording_id)
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
    when = recording_time(row.recorded_at, row.uploaded_at)
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
    status, moment = str(document.get("status", "")), now()
    return [
        diagnosis_event(
            f,
            recording=recording,
            analysis_version=analysis_version,
            diagnosis_status=status,
            created_at=moment,
        )
        for f in fresh
    ] + [
        trend_event(
            d,
            recording=recording,
            analysis_version=analysis_version,
            diagnosis_status=status,
            created_at=moment,
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
    moment = now()
    rows = [
        {
            "webhook_id": hook.id,
            "event_id": event["id"],
            "event_type": event["type"],
            "body": event_body(event),
            "state": "pending",
            "attempts": 0,
            "next_attempt_at": moment,
            "last_error": "",
            "created_at": moment,
        }
        for hook in hooks
        for event in events
    ]
    insert_ignoring_existing(c, webhook_deliveries, rows, ["webhook_id", "event_id"])
    return len(rows)
