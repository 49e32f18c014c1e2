"""The store's trend points: written with each diagnosis result, read by engine, quantity and time.

A diagnosis result's quantities (:func:`monitor.diagnosis.trends.trend_points`) go into
``trend_points`` in the transaction that stores the result, at the recording's
time: the start time the recording states, or its upload time for a recording
stored without one. Results stored before the table existed are filled in by
:func:`fill_trend_points`, which the trend reads call first (idempotent: the
unique key refuses a second row for the same recording, version and quantity).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

import sqlalchemy as sa
from sqlalchemy.engine import Connection

from monitor.diagnosis.trends import (
    BASELINE_RECORDINGS,
    DECISION,
    LAG,
    REFERENCE,
    ROBUST_SIGMAS,
    Drift,
    drift,
    judged,
)
from monitor.diagnosis.trends import trend_points as quantities_of
from monitor.store.schema import recordings, results, trend_points
from monitor.store.sql import insert_ignoring_existing, utc

__all__ = [
    "DIAGNOSIS_KIND",
    "EngineSummary",
    "TrendRow",
    "fill_trend_points",
    "fleet_summary",
    "parse_since",
    "read_trend",
    "recording_time",
    "trend_document",
    "write_trend_points",
]

DIAGNOSIS_KIND = "diagnosis"  # the result kind whose document the quantities come from
_FILL_BATCH = 200  # results read at a time when filling in


@dataclass(frozen=True)
class TrendRow:
    """One quantity of one diagnosis, as stored.

    Attributes
    ----------
    recording_id : int
    recorded_at : datetime
        The recording's time (UTC).
    quantity : str
    value : float
    standard_error : float or None
    unit : str
    """

    recording_id: int
    recorded_at: datetime
    quantity: str
    value: float
    standard_error: float | None
    unit: str


def parse_since(text: str) -> datetime:
    """The time a trend starts from: ISO 8601, ``Z`` for UTC, UTC when it names no zone; a ValueError
    for any other text (the trend's ``since``, of ``GET /engines/{engine_id}/trend`` as of
    ``engine-monitor trend --since``).

    Parameters
    ----------
    text : str

    Returns
    -------
    datetime
        Aware: the zone given, else UTC.
    """
    when = datetime.fromisoformat(text.replace("Z", "+00:00"))
    return when if when.tzinfo is not None else when.replace(tzinfo=UTC)


def recording_time(recorded_at: str, uploaded_at: datetime) -> datetime:
    """The recording's start (ISO 8601, UTC) if it states one, else its upload time; aware, UTC.

    Parameters
    ----------
    recorded_at : str
        The start the recording states, ISO 8601, or empty.
    uploaded_at : datetime
        When it was uploaded.

    Returns
    -------
    datetime
    """
    if recorded_at:
        try:
            parsed = datetime.fromisoformat(recorded_at.replace("Z", "+00:00"))
        except ValueError:
            parsed = None
        if parsed is not None:
            return utc(parsed)
    return utc(uploaded_at)


def write_trend_points(
    c: Connection, recording_id: int, analysis_version: str, document: dict[str, Any]
) -> int:
    """Store a diagnosis document's quantities for its recording (in the caller's transaction).

    Parameters
    ----------
    c : Connection
        In the transaction that stores the result.
    recording_id : int
    analysis_version : str
    document : dict
        The diagnosis document.

    Returns
    -------
    int
        Quantities given (those already stored are kept as they are).
    """
    row = c.execute(
        sa.select(
            recordings.c.fleet_id, recordings.c.engine_id, recordings.c.recorded_at, recordings.c.uploaded_at
        ).where(recordings.c.id == recording_id)
    ).first()
    if row is None:
        return 0
    when = recording_time(row.recorded_at, row.uploaded_at)
    points = quantities_of(document)
    insert_ignoring_existing(
        c,
        trend_points,
        [
            {
                "recording_id": recording_id,
                "analysis_version": analysis_version,
                "fleet_id": row.fleet_id,
                "engine_id": row.engine_id,
                "recorded_at": when,
                "quantity": p.quantity,
                "value": p.value,
                "standard_error": p.standard_error,
                "unit": p.unit,
            }
            for p in points
        ],
        ["recording_id", "analysis_version", "quantity"],
    )
    return len(points)


def fill_trend_points(c: Connection, fleet_id: int) -> int:
    """Fill in the trend points of a fleet's diagnosis results that have none (stored before them).

    Parameters
    ----------
    c : Connection
        In a transaction.
    fleet_id : int

    Returns
    -------
    int
        Results filled in.
    """
    have = sa.select(trend_points.c.id).where(
        (trend_points.c.recording_id == results.c.recording_id)
        & (trend_points.c.analysis_version == results.c.analysis_version)
    )
    filled, last = 0, 0
    while True:
        rows = c.execute(
            sa.select(results.c.id, results.c.recording_id, results.c.analysis_version, results.c.document)
            .join(recordings, recordings.c.id == results.c.recording_id)
            .where(
                (recordings.c.fleet_id == fleet_id)
                & (results.c.kind == DIAGNOSIS_KIND)
                & (results.c.id > last)
                & ~sa.exists(have)
            )
            .order_by(results.c.id)
            .limit(_FILL_BATCH)
        ).all()
        if not rows:
            return filled
        for r in rows:
            document = json.loads(r.document) if isinstance(r.document, str) else r.document
            if not isinstance(document, dict):
                continue
            if write_trend_points(c, r.recording_id, r.analysis_version, document):
                filled += 1
        last = rows[-1].id


def read_trend(
    c: Connection,
    fleet_id: int,
    engine_id: str,
    *,
    analysis_version: str,
    quantities: list[str] | None = None,
    since: datetime | None = None,
) -> list[TrendRow]:
    """An engine's trend points of one analysis version, by recording time then quantity.

    Parameters
    ----------
    c : Connection
    fleet_id : int
    engine_id : str
    analysis_version : str
    quantities : list of str, optional
        Only these; default: all.
    since : datetime, optional
        Only recordings from then on (UTC if naive).
    """
    where = (
        (trend_points.c.fleet_id == fleet_id)
        & (trend_points.c.engine_id == engine_id)
        & (trend_points.c.analysis_version == analysis_version)
    )
    if quantities:
        where &= trend_points.c.quantity.in_(quantities)
    if since is not None:
        where &= trend_points.c.recorded_at >= utc(since)
    rows = c.execute(
        sa.select(
            trend_points.c.recording_id,
            trend_points.c.recorded_at,
            trend_points.c.quantity,
            trend_points.c.value,
            trend_points.c.standard_error,
            trend_points.c.unit,
        )
        .where(where)
        .order_by(trend_points.c.recorded_at, trend_points.c.recording_id, trend_points.c.quantity)
    ).all()
    return [
        TrendRow(
            r.recording_id,
            utc(r.recorded_at),
            r.quantity,
            float(r.value),
            None if r.standard_error is None else float(r.standard_error),
            r.unit,
        )
        for r in rows
    ]


def trend_document(
    rows: list[TrendRow],
    *,
    engine_id: str,
    fleet: str,
    analysis_version: str,
    since: datetime | None = None,
) -> tuple[dict[str, Any], dict[str, list[TrendRow]], list[Drift]]:
    """An engine's trend as a document (``trend --json`` and ``GET /engines/{id}/trend``).

    Parameters
    ----------
    rows : list of TrendRow
        From :func:`read_trend`.
    engine_id, fleet, analysis_version : str
    since : datetime, optional
        The start of the span read, if any.

    Returns
    -------
    document : dict
        ``rule``, each quantity's ``unit``, ``judged``, ``points`` and ``drift``, and the ``findings``
        in words in the order they were found.
    series : dict of str to list of TrendRow
        The rows by quantity.
    findings : list of Drift
        In the order they were found.
    """
    series: dict[str, list[TrendRow]] = {}
    for row in rows:
        series.setdefault(row.quantity, []).append(row)
    document: dict[str, Any] = {
        "engine_id": engine_id,
        "fleet": fleet,
        "analysis_version": analysis_version,
        "since": since.isoformat() if since else None,
        "rule": {
            "method": "two-sided CUSUM, each value standardised by the values up to lag recordings before "
            "it, those beyond robust_sigmas of their median left out",
            "lag_recordings": LAG,
            "robust_sigmas": ROBUST_SIGMAS,
            "baseline_recordings": BASELINE_RECORDINGS,
            "reference_sigmas": REFERENCE,
            "decision_sigmas": DECISION,
        },
        "quantities": {},
        "findings": [],
    }
    findings: list[Drift] = []
    for quantity, points in series.items():
        found = (
            drift(
                [p.recorded_at for p in points],
                [p.value for p in points],
                quantity=quantity,
                unit=points[0].unit,
            )
            if judged(quantity)
            else None
        )
        if found is not None:
            findings.append(found)
        document["quantities"][quantity] = {
            "unit": points[0].unit,
            "judged": judged(quantity),
            "points": [
                {
                    "recording_id": p.recording_id,
                    "recorded_at": p.recorded_at.isoformat(),
                    "value": p.value,
                    "standard_error": p.standard_error,
                }
                for p in points
            ],
            "drift": None
            if found is None
            else {
                "direction": found.direction,
                "since": found.since.isoformat(),
                "found_at": found.found_at.isoformat(),
                "shift": found.shift,
                "shift_sigmas": found.shift_sigmas,
                "baseline_mean": found.baseline_mean,
                "baseline_sigma": found.baseline_sigma,
                "summary": found.summary,
            },
        }
    findings.sort(key=lambda f: (f.found_at, f.quantity))
    document["findings"] = [f.summary for f in findings]
    return document, series, findings


@dataclass(frozen=True)
class EngineSummary:
    """An engine of a fleet at a glance: its diagnosed recordings and the latest one's verdict.

    Attributes
    ----------
    engine_id : str
    recordings : int
        Recordings with a diagnosis at this analysis version.
    alarms, warnings : int
        Of those, the ones whose diagnosis raised an alarm, a warning.
    latest_recording_id : int
    latest_recorded_at : datetime
        The latest recording's time (its start, else its upload).
    latest_status : str
        Its diagnosis's status.
    latest_filename : str
    """

    engine_id: str
    recordings: int
    alarms: int
    warnings: int
    latest_recording_id: int
    latest_recorded_at: datetime
    latest_status: str
    latest_filename: str


def fleet_summary(c: Connection, fleet_id: int, *, analysis_version: str) -> list[EngineSummary]:
    """Each engine of a fleet with a diagnosed recording, by engine id.

    Parameters
    ----------
    c : Connection
    fleet_id : int
    analysis_version : str

    Returns
    -------
    list of EngineSummary
    """
    rows = c.execute(
        sa.select(
            recordings.c.id,
            recordings.c.engine_id,
            recordings.c.filename,
            recordings.c.recorded_at,
            recordings.c.uploaded_at,
            results.c.status,
        )
        .join(results, results.c.recording_id == recordings.c.id)
        .where(
            (recordings.c.fleet_id == fleet_id)
            & (results.c.kind == DIAGNOSIS_KIND)
            & (results.c.analysis_version == analysis_version)
        )
    ).all()
    by_engine: dict[str, list[Any]] = {}
    for r in rows:
        by_engine.setdefault(r.engine_id, []).append(r)
    summaries = []
    for engine_id, found in sorted(by_engine.items()):
        latest = max(found, key=lambda r: (recording_time(r.recorded_at, r.uploaded_at), r.id))
        summaries.append(
            EngineSummary(
                engine_id,
                len(found),
                sum(1 for r in found if r.status == "alarm"),
                sum(1 for r in found if r.status == "warning"),
                int(latest.id),
                recording_time(latest.recorded_at, latest.uploaded_at),
                str(latest.status),
                str(latest.filename),
            )
        )
    return summaries
