"""Delivery of alerts: each queued event posted to its webhook, signed, retried until it is taken.

The events wait in the store's outbox (:mod:`monitor.store.webhooks`), written
with the diagnoses that made them. A sender (:func:`deliver_due`) takes each
due delivery (a claim: never two senders at once), posts its body as it is
stored with the signature and delivery headers (:mod:`monitor.report.events`), with
a bounded timeout, and records the answer:

- a 2xx answer delivers it;
- anything else (another status, a redirect, no connection, no answer in
  time) is retried after a back-off that doubles with each attempt,
  ``backoff_s * 2**(attempts - 1)`` up to ``max_backoff_s``, until
  ``max_attempts`` attempts or ``max_age_s`` after the event was queued;
  then it is failed, and stays in the delivery log.

Delivery is at least once: a sender that dies after the receiver took an
event but before it recorded so leaves the delivery to be taken again after
its lease. Receivers deduplicate by the delivery's (or the event's) id, which
every attempt repeats.

In one pass, a webhook that failed once is not tried again for its other
events (they keep their time): a receiver that is down, or one that never
answers, costs each pass one attempt and one timeout, not one per event,
and the other webhooks' events go out in the same pass.

The service runs a :class:`Deliverer` (a thread that makes a pass every
``poll_s``); the batch makes one pass for its fleet before it exits
(:func:`deliver_due`), and what is still pending goes out with the next pass
of either.
"""

from __future__ import annotations

import logging
import threading
import time
import urllib.error
import urllib.request
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from typing import TYPE_CHECKING

from monitor.report.events import DELIVERY_HEADER, EVENT_HEADER, SIGNATURE_HEADER, TIMESTAMP_HEADER, sign
from monitor.store.outage import store_fault
from monitor.store.webhooks import DueDelivery, claim, due_deliveries, record_attempt

if TYPE_CHECKING:
    from monitor.store import Store

__all__ = ["Deliverer", "DeliveryPolicy", "Passed", "backoff", "deliver_due", "post"]

log = logging.getLogger("engine_monitor.alerts")

USER_AGENT = "engine-monitor-webhooks/1"
ANSWER_BYTES = 65536  # of a receiver's answer, read at most (and dropped)
ERROR_CHARACTERS = 500  # of an error, kept in the delivery log


@dataclass(frozen=True)
class DeliveryPolicy:
    """How alerts are posted and retried.

    Attributes
    ----------
    timeout_s : float
        Longest wait for a receiver to connect and answer [s].
    backoff_s : float
        Wait before the first retry; doubled after each attempt [s].
    max_backoff_s : float
        Longest wait between two attempts [s].
    max_attempts : int
        Attempts after which a delivery is failed.
    max_age_s : float
        Time after its event was queued after which a delivery that fails again is failed [s].
    poll_s : float
        Time between two passes of the service's deliverer [s].
    """

    timeout_s: float = 10.0
    backoff_s: float = 10.0
    max_backoff_s: float = 3600.0
    max_attempts: int = 12
    max_age_s: float = 86400.0
    poll_s: float = 1.0


def backoff(policy: DeliveryPolicy, attempts: int) -> float:
    """The wait after a delivery's ``attempts``-th failed attempt [s].

    Parameters
    ----------
    policy : DeliveryPolicy
    attempts : int
        Attempts made so far (at least 1).
    """
    return float(min(policy.backoff_s * 2.0 ** max(0, attempts - 1), policy.max_backoff_s))


class _NoRedirect(urllib.request.HTTPRedirectHandler):
    """A redirect is an answer that did not take the event: recorded, and retried like any other."""

    def redirect_request(self, *args: object, **kwargs: object) -> None:
        return None


_OPENER = urllib.request.build_opener(_NoRedirect)


def post(url: str, body: bytes, headers: dict[str, str], timeout_s: float) -> tuple[int | None, str]:
    """POST a body; the receiver's status (None when it never answered) and the error ("" on a 2xx).

    Parameters
    ----------
    url : str
    body : bytes
    headers : dict of str to str
    timeout_s : float
        Longest wait to connect, and then for each read of the answer [s].
    """
    request = urllib.request.Request(url, data=body, method="POST", headers=headers)
    try:
        with _OPENER.open(request, timeout=timeout_s) as answer:
            answer.read(ANSWER_BYTES)
            status = int(answer.status)
    except urllib.error.HTTPError as error:
        return int(error.code), f"the receiver answered HTTP {error.code} ({error.reason})"
    except urllib.error.URLError as error:
        reason = error.reason
        if isinstance(reason, TimeoutError):
            return None, f"no answer within {timeout_s:g} s"
        return None, f"no connection: {reason}"[:ERROR_CHARACTERS]
    except TimeoutError:
        return None, f"no answer within {timeout_s:g} s"
    except (OSError, ValueError) as error:  # reset, refused mid-answer, a malformed answer
        return None, f"{type(error).__name__}: {error}"[:ERROR_CHARACTERS]
    if 200 <= status < 300:
        return status, ""
    return status, f"the receiver answered HTTP {status}"


@dataclass
class Passed:
    """What one pass did: deliveries delivered, to be retried, failed for good."""

    delivered: int = 0
    retrying: int = 0
    failed: int = 0


def _attempt(store: Store, policy: DeliveryPolicy, due: DueDelivery) -> str:
    held = due.delivery
    body = held.body.encode("utf-8")
    headers = {
        "Content-Type": "application/json",
        "User-Agent": USER_AGENT,
        SIGNATURE_HEADER: sign(due.secret, body),
        EVENT_HEADER: held.event_id,
        DELIVERY_HEADER: str(held.id),
        TIMESTAMP_HEADER: str(int(time.time())),
    }
    status, error = post(due.url, body, headers, policy.timeout_s)
    delivered = not error
    now = datetime.now(UTC)
    retry_at = None
    if not delivered and held.attempts < policy.max_attempts:
        retry_at = now + timedelta(seconds=backoff(policy, held.attempts))
        if retry_at - held.created_at > timedelta(seconds=policy.max_age_s):
            retry_at = None
    with store.transaction() as c:
        state = record_attempt(c, held, status=status, error=error, delivered=delivered, retry_at=retry_at)
    log.log(
        logging.INFO if delivered else logging.WARNING,  # a receiver that does not take its events is seen
        "delivery=%d webhook=%d event=%s attempt=%d state=%s%s",
        held.id,
        held.webhook_id,
        held.event_id,
        held.attempts,
        state,
        f" error={error!r}" if error else "",
    )
    return state


def deliver_due(
    store: Store,
    policy: DeliveryPolicy,
    *,
    fleet_id: int | None = None,
    stop: threading.Event | None = None,
) -> Passed:
    """One pass: post every delivery due now, once each (a webhook that fails is left for the next pass).

    Parameters
    ----------
    store : Store
    policy : DeliveryPolicy
    fleet_id : int, optional
        Only this fleet's deliveries (the batch's).
    stop : threading.Event, optional
        Once set, the pass ends after the post in progress.

    Returns
    -------
    Passed
    """
    passed = Passed()
    lease = timedelta(seconds=2 * policy.timeout_s + 30.0)
    seen: set[int] = set()
    failing: set[int] = set()  # webhooks that failed in this pass
    while stop is None or not stop.is_set():
        with store.db.connect() as c:
            due = [d for d in due_deliveries(c, fleet_id=fleet_id, without=failing) if d[0] not in seen]
        if not due:
            break
        for delivery_id, webhook_id in due:
            if webhook_id in failing or (stop is not None and stop.is_set()):
                continue
            seen.add(delivery_id)
            with store.transaction() as c:
                held = claim(c, delivery_id, lease)
            if held is None:  # another sender took it
                continue
            state = _attempt(store, policy, held)
            if state == "delivered":
                passed.delivered += 1
            else:
                failing.add(webhook_id)
                passed.retrying += state == "pending"
                passed.failed += state == "failed"
    return passed


class Deliverer:
    """A thread that delivers the due alerts every ``policy.poll_s``, until stopped.

    Parameters
    ----------
    store : Store
    policy : DeliveryPolicy
    """

    def __init__(self, store: Store, policy: DeliveryPolicy) -> None:
        self.store = store
        self.policy = policy
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        """Start the passes."""
        self._thread = threading.Thread(target=self._loop, name="alerts", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Stop after the post in progress, if any (at most its timeout); what is pending stays queued."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=self.policy.timeout_s + 5.0)

    def _loop(self) -> None:
        while not self._stop.is_set():
            try:
                deliver_due(self.store, self.policy, stop=self._stop)
            except Exception as error:  # never stop the loop: log, wait, go on
                if store_fault(error) is None:
                    log.exception("alerts: a pass failed; trying again")
                else:  # the store away: the outage's one line (monitor.store.outage), not a traceback a pass
                    self.store.outage.failed(error)
            self._stop.wait(self.policy.poll_s)
