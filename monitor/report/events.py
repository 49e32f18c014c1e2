"""Alerts: the events a new finding makes, and how they are signed.

A fleet registers webhooks (``POST /webhooks``); each new finding of a stored
diagnosis becomes one event, posted to every active webhook of the fleet
(:mod:`monitor.jobs.delivery` sends them, with retries).

What is new.  The findings of a diagnosis of recording ``R`` are compared with
those of the *previous diagnosis of the same engine*: the fleet's diagnosed
recording of that engine just before ``R`` in recording time (its start, else
its upload; ties by id), at the same analysis version.

- A diagnosis finding (``severity`` warning or alarm) is new unless the
  previous diagnosis had a finding of the same ``kind`` and ``subject`` at the
  same or a higher severity: a cylinder that goes from warning to alarm alerts
  again, one that stays in alarm night after night does not, and one that
  eases from alarm to warning does not.
- A trend finding (:mod:`monitor.diagnosis.trends`) is new when the engine's trend of
  a quantity, over the recordings up to ``R``, finds drift, and the same trend
  without ``R`` finds none: the drift was found at ``R``.

The engine's first diagnosis has no previous one: each of its warning and
alarm findings is new.

One event per new finding, not one per diagnosis: each is one alert for a
receiver to route (a pager, a ticket), acknowledge and deduplicate on its
own, and a diagnosis seldom has more than one new finding. Events of the same
diagnosis carry the same recording, so a receiver can group them.

An event's id is a digest of the recording, the analysis version, the
event's type and the finding's key (kind, subject and severity; or the
trend's quantity), so the same finding of the same diagnosis is the same
event however often it is made: the store keeps one delivery per webhook and
event id (:mod:`monitor.store.webhooks`), and a job run twice never sends
twice.

The body is the event as compact ASCII JSON; its signature is HMAC-SHA256 of
those exact bytes with the webhook's secret, sent as
``X-Engine-Monitor-Signature: sha256=<hex>`` (:func:`sign`, :func:`verify`).
"""

from __future__ import annotations

import hashlib
import hmac
import json
import math
from collections.abc import Mapping, Sequence
from datetime import datetime
from typing import Any

from monitor.diagnosis.trends import Drift, drift, judged

__all__ = [
    "DELIVERY_HEADER",
    "EVENT_HEADER",
    "SIGNATURE_HEADER",
    "TIMESTAMP_HEADER",
    "diagnosis_event",
    "event_body",
    "event_id",
    "new_drifts",
    "new_findings",
    "sign",
    "trend_event",
    "verify",
]

SIGNATURE_HEADER = "X-Engine-Monitor-Signature"  # sha256=<hex of HMAC-SHA256(secret, body)>
EVENT_HEADER = "X-Engine-Monitor-Event"  # the event's id (the same for every webhook and attempt)
DELIVERY_HEADER = "X-Engine-Monitor-Delivery"  # the delivery's id (one webhook, one event; every attempt)
TIMESTAMP_HEADER = "X-Engine-Monitor-Timestamp"  # when this attempt was sent (Unix time, s)
SEVERITY_RANK = {"warning": 1, "alarm": 2}  # the severities that alert, in order


def _finite(value: Any) -> float | None:
    """A number as JSON may hold it: finite, else None."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        return None
    return number if math.isfinite(number) else None


def _key(finding: dict[str, Any]) -> tuple[str, str]:
    return str(finding.get("kind", "")), str(finding.get("subject", ""))


def new_findings(
    findings: Sequence[dict[str, Any]], previous: Sequence[dict[str, Any]] | None
) -> list[dict[str, Any]]:
    """The warning and alarm findings of a diagnosis that the previous diagnosis did not have.

    Parameters
    ----------
    findings : sequence of dict
        The diagnosis document's ``findings`` (each with ``kind``, ``subject``, ``severity``).
    previous : sequence of dict or None
        The previous diagnosis' findings (of the same engine, the recording just before); None when
        there is none.

    Returns
    -------
    list of dict
        The findings, in their order, of severity warning or alarm without a finding of the same kind
        and subject at the same or a higher severity in ``previous``.
    """
    before: dict[tuple[str, str], int] = {}
    for finding in previous or ():
        rank = SEVERITY_RANK.get(str(finding.get("severity")), 0)
        before[_key(finding)] = max(rank, before.get(_key(finding), 0))
    return [f for f in findings if SEVERITY_RANK.get(str(f.get("severity")), 0) > before.get(_key(f), 0)]


def new_drifts(
    series: Mapping[str, Sequence[tuple[int, datetime, float]]], recording_id: int, *, units: dict[str, str]
) -> list[Drift]:
    """The trend findings found at one recording: drift with it, none without it.

    Parameters
    ----------
    series : mapping of str to sequence of (int, datetime, float)
        Each quantity's points up to and including the recording, in recording order: the recording's
        id, its time and the value [the quantity's unit].
    recording_id : int
        The recording whose diagnosis was just stored.
    units : dict of str to str
        Each quantity's unit.

    Returns
    -------
    list of Drift
        By quantity; only the judged quantities (:func:`monitor.diagnosis.trends.judged`) whose last
        point is the recording's.
    """
    found: list[Drift] = []
    for quantity in sorted(series):
        points = series[quantity]
        if not judged(quantity) or not points or points[-1][0] != recording_id:
            continue
        times = [p[1] for p in points]
        values = [p[2] for p in points]
        with_it = drift(times, values, quantity=quantity, unit=units.get(quantity, ""))
        if with_it is not None and drift(times[:-1], values[:-1], quantity=quantity) is None:
            found.append(with_it)
    return found


def event_id(recording_id: int, analysis_version: str, event_type: str, key: Sequence[str]) -> str:
    """The id of the event a finding of a diagnosis makes: the same finding, the same id.

    Parameters
    ----------
    recording_id : int
    analysis_version : str
    event_type : str
        ``diagnosis.finding`` or ``trend.finding``.
    key : sequence of str
        What names the finding: its kind, subject and severity; or the trend's quantity.

    Returns
    -------
    str
        ``evt_`` and 32 hexadecimal digits.
    """
    text = "\n".join([str(recording_id), analysis_version, event_type, *key])
    return "evt_" + hashlib.sha256(text.encode("utf-8")).hexdigest()[:32]


def _envelope(
    event_type: str,
    identity: str,
    created_at: datetime,
    recording: dict[str, Any],
    analysis_version: str,
    diagnosis_status: str,
    finding: dict[str, Any],
) -> dict[str, Any]:
    return {
        "id": identity,
        "type": event_type,
        "created_at": created_at.isoformat().replace("+00:00", "Z"),
        "fleet": recording["fleet"],
        "engine_id": recording["engine_id"],
        "recording": {k: recording[k] for k in ("id", "filename", "recorded_at")},
        "analysis_version": analysis_version,
        "diagnosis_status": diagnosis_status,
        "finding": finding,
    }


def diagnosis_event(
    finding: dict[str, Any],
    *,
    recording: dict[str, Any],
    analysis_version: str,
    diagnosis_status: str,
    created_at: datetime,
) -> dict[str, Any]:
    """The event of a new diagnosis finding (type ``diagnosis.finding``).

    Parameters
    ----------
    finding : dict
        The finding, as in the diagnosis document.
    recording : dict
        ``id``, ``filename``, ``recorded_at`` (as the recording states it; "" when it does not),
        ``fleet`` (its name) and ``engine_id``.
    analysis_version : str
    diagnosis_status : str
        The diagnosis' status (healthy, warning, alarm, inconclusive).
    created_at : datetime
        When the event was made (UTC).

    Returns
    -------
    dict
        The event (docs/service.md, "Alerts (webhooks)").
    """
    kind, subject = _key(finding)
    severity = str(finding.get("severity", ""))
    body = {
        "kind": kind,
        "subject": subject,
        "severity": severity,
        "summary": str(finding.get("summary", "")),
        "confidence": _finite(finding.get("confidence")),
    }
    identity = event_id(recording["id"], analysis_version, "diagnosis.finding", (kind, subject, severity))
    return _envelope(
        "diagnosis.finding", identity, created_at, recording, analysis_version, diagnosis_status, body
    )


def trend_event(
    found: Drift,
    *,
    recording: dict[str, Any],
    analysis_version: str,
    diagnosis_status: str,
    created_at: datetime,
) -> dict[str, Any]:
    """The event of a new trend finding (type ``trend.finding``).

    Parameters
    ----------
    found : Drift
        The drift found at the recording.
    recording : dict
        As for :func:`diagnosis_event`.
    analysis_version : str
    diagnosis_status : str
    created_at : datetime

    Returns
    -------
    dict
    """
    body = {
        "kind": "trend",
        "subject": found.quantity,
        "unit": found.unit,
        "direction": found.direction,
        "since": found.since.isoformat(),
        "found_at": found.found_at.isoformat(),
        "shift": _finite(found.shift),
        "shift_sigmas": _finite(found.shift_sigmas),
        "baseline_mean": _finite(found.baseline_mean),
        "baseline_sigma": _finite(found.baseline_sigma),
        "summary": found.summary,
    }
    identity = event_id(recording["id"], analysis_version, "trend.finding", (found.quantity,))
    return _envelope(
        "trend.finding", identity, created_at, recording, analysis_version, diagnosis_status, body
    )


def event_body(event: dict[str, Any]) -> str:
    """An event as it is sent and stored: compact JSON, ASCII only (its UTF-8 bytes are its text).

    Parameters
    ----------
    event : dict
    """
    return json.dumps(event, separators=(",", ":"), ensure_ascii=True, allow_nan=False)


def sign(secret: str, body: bytes) -> str:
    """The signature header's value of a body: ``sha256=`` and HMAC-SHA256(secret, body) in hex.

    Parameters
    ----------
    secret : str
        The webhook's secret (its UTF-8 bytes are the key).
    body : bytes
        The exact bytes sent.
    """
    return "sha256=" + hmac.new(secret.encode("utf-8"), body, hashlib.sha256).hexdigest()


def verify(secret: str, body: bytes, signature: str) -> bool:
    """Whether a signature header's value is that of the body (compared in constant time).

    Parameters
    ----------
    secret : str
    body : bytes
        The bytes received, exactly.
    signature : str
        The ``X-Engine-Monitor-Signature`` header.
    """
    return hmac.compare_digest(sign(secret, body), signature)
