"""The store's webhooks and their outbox: receivers registered, deliveries claimed, attempted and
logged.

A delivery is one event for one webhook. The deliveries of a diagnosis' new
findings are queued with the diagnosis (:func:`monitor.store.alerts.enqueue_events`),
and the unique key (webhook, event id) keeps one delivery of an event per
webhook however often it is queued.

A sender takes a due delivery with :func:`claim` (a compare-and-set on its
attempts, which it counts, and which moves its next attempt past the claim's
lease, so two senders never post it at once and a sender that dies leaves it
to be taken again after the lease), posts it, and records the answer with
:func:`record_attempt`: delivered, or pending with its next attempt, or failed
for good. Each change is one transaction.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timedelta
from typing import Any

import sqlalchemy as sa
from sqlalchemy.engine import Connection

from monitor.store.schema import webhook_deliveries, webhooks
from monitor.store.sql import now, utc

__all__ = [
    "DeliveryRow",
    "DueDelivery",
    "WebhookRow",
    "add_webhook",
    "claim",
    "deactivate_webhook",
    "deliveries",
    "due_deliveries",
    "record_attempt",
    "webhook",
    "webhooks_of",
]


def _utc_or_none(moment: datetime | None) -> datetime | None:
    return None if moment is None else utc(moment)


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
        int(row.id), int(row.fleet_id), row.url, row.secret, utc(row.created_at), bool(row.active)
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
        utc(row.next_attempt_at),
        _utc_or_none(row.last_attempt_at),
        None if row.last_status is None else int(row.last_status),
        row.last_error,
        utc(row.created_at),
        _utc_or_none(row.delivered_at),
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
    moment = now()
    created = c.execute(
        sa.insert(webhooks)
        .values(fleet_id=fleet_id, url=url, secret=secret, created_at=moment, active=True)
        .returning(webhooks.c.id)
    ).scalar_one()
    return WebhookRow(int(created), fleet_id, url, secret, moment, True)


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
        & (webhook_deliveries.c.next_attempt_at <= now())
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
    moment = now()
    row = c.execute(
        sa.select(webhook_deliveries, webhooks.c.url, webhooks.c.secret)
        .join(webhooks, webhooks.c.id == webhook_deliveries.c.webhook_id)
        .where(
            (webhook_deliveries.c.id == delivery_id)
            & (webhook_deliveries.c.state == "pending")
            & (webhook_deliveries.c.next_attempt_at <= moment)
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
        .values(attempts=row.attempts + 1, next_attempt_at=moment + lease, last_attempt_at=moment)
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
    moment = now()
    if delivered:
        values: dict[str, Any] = {"state": "delivered", "delivered_at": moment, "next_attempt_at": moment}
    elif retry_at is not None:
        values = {"state": "pending", "next_attempt_at": retry_at}
    else:
        values = {"state": "failed", "next_attempt_at": moment}
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
