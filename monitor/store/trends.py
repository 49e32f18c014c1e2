"""The store's trend points: written with each diagnosis result, read by engine, quantity and time.

A diagnosis result's quantities (:func:`monitor.trends.trend_points`) go into
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

from monitor.store.schema import recordings, results, trend_points
from monitor.trends import trend_points as quantities_of

__all__ = ["DIAGNOSIS_KIND", "TrendRow", "fill_trend_points", "read_trend", "write_trend_points"]

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


def _recording_time(recorded_at: str, uploaded_at: datetime) -> datetime:
    """The recording's start (ISO 8601, UTC) if it states one, else its upload time; aware, UTC."""
    if recorded_at:
        try:
            parsed = datetime.fromisoformat(recorded_at.replace("Z", "+00:00"))
        except ValueError:
            parsed = None
        if parsed is not None:
            return parsed if parsed.tzinfo is not None else parsed.replace(tzinfo=UTC)
    return uploaded_at if uploaded_at.tzinfo is not None else uploaded_at.replace(tzinfo=UTC)


def _insert_ignoring_existing(c: Connection, rows: list[dict[str, Any]]) -> None:
    if not rows:
        return
    if c.dialect.name == "postgresql":
        from sqlalchemy.dialects.postgresql import insert
    else:
        from sqlalchemy.dialects.sqlite import insert  # type: ignore[assignment]
    keys = ["recording_id", "analysis_version", "quantity"]
    c.execute(insert(trend_points).on_conflict_do_nothing(index_elements=keys), rows)


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
    when = _recording_time(row.recorded_at, row.uploaded_at)
    points = quantities_of(document)
    _insert_ignoring_existing(
        c,
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
        where &= trend_points.c.recorded_at >= (since if since.tzinfo else since.replace(tzinfo=UTC))
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
            r.recorded_at if r.recorded_at.tzinfo else r.recorded_at.replace(tzinfo=UTC),
            r.quantity,
            float(r.value),
            None if r.standard_error is None else float(r.standard_error),
            r.unit,
        )
        for r in rows
    ]
