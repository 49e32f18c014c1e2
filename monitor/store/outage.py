"""The store unreachable or full: which failures mean it, and one log line per outage.

A database that stops (restarted, its host down, its connections cut)
surfaces as the driver's errors on whichever query runs next. They are not
faults of the query nor of the product: the caller answers "try again
later" and does not log a traceback for each. :func:`store_fault` tells
them apart from the rest:

- ``"unavailable"``: the store cannot be reached or cannot serve now. On
  PostgreSQL every ``OperationalError`` or ``InterfaceError`` of the driver
  (the connection refused, closed or broken; the server shutting down or
  starting up, SQLSTATE classes 08, 57; out of connections or memory, 53),
  and any error on a connection the driver found broken. On SQLite a
  locked database (after its busy timeout), a file it cannot open, an I/O
  error: its ``OperationalError`` also reports errors of the statement
  itself, which are not outages, so it is told by its message;
- ``"full"``: the disk under the store is full (SQLite's "database or disk
  is full", PostgreSQL's ``disk_full``, SQLSTATE 53100);
- None: any other error, a fault to log with its traceback.

:class:`Outage` keeps whether the store is down: its first failure logs one
line (``store unreachable: REASON``), and the first connection made to it
again, or any caller's success it reports, logs one more (``store
reachable again after S s``), with the failures counted meanwhile. Failures
within :data:`STRAGGLERS_S` of its end are of requests that met the outage
before it ended (a query sent on a connection cut meanwhile): they are
not taken for a new outage (a store down again is logged at its
next failure after that). A store
has one (:attr:`monitor.store.Store.outage`), shared by every part of a
process that uses it (the service's requests and its analysis worker).
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Literal

import sqlalchemy as sa

__all__ = ["STRAGGLERS_S", "Fault", "Outage", "fault_reason", "store_fault"]

log = logging.getLogger("engine_monitor.store")

Fault = Literal["unavailable", "full"]

#: SQLite's messages of a store that cannot serve now (its other OperationalErrors are the statement's)
_SQLITE_UNAVAILABLE = ("database is locked", "unable to open database file", "disk i/o error")
_SQLITE_FULL = ("database or disk is full",)
_PG_DISK_FULL = "53100"
#: After the store is back, failures for this long are stragglers of the outage, not a new one [s].
STRAGGLERS_S = 2.0


def store_fault(error: BaseException) -> Fault | None:
    """Whether an error means the store unreachable (``"unavailable"``), its disk full (``"full"``),
    or neither (None). See the module docstring.

    Parameters
    ----------
    error : BaseException
        As raised by a store's method (SQLAlchemy's wrapper of the driver's error).
    """
    if not isinstance(error, sa.exc.DBAPIError):
        return None
    original = error.orig
    if type(original).__module__ == "sqlite3":
        text = str(original).lower()
        if any(message in text for message in _SQLITE_FULL):
            return "full"
        if any(message in text for message in _SQLITE_UNAVAILABLE):
            return "unavailable"
        return None
    if getattr(original, "sqlstate", None) == _PG_DISK_FULL:
        return "full"
    if error.connection_invalidated or isinstance(error, sa.exc.OperationalError | sa.exc.InterfaceError):
        return "unavailable"
    return None


def fault_reason(error: BaseException) -> str:
    """The driver's message of a store's error, on one line (no SQL, no parameters).

    Parameters
    ----------
    error : BaseException
    """
    original = getattr(error, "orig", None) or error
    lines = [line.strip() for line in str(original).splitlines() if line.strip()]
    return "; ".join(lines)[:300] or type(original).__name__


class Outage:
    """Whether a store is down now, logged once when an outage begins and once when it ends.

    Thread-safe; :meth:`back` costs one attribute read while the store is up (it is called on every
    new connection).
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.since: float | None = None  # time.monotonic() of the outage's first failure, None while up
        self.failures = 0  # failures reported during the current outage
        self._ended = -STRAGGLERS_S  # time.monotonic() when the last outage ended

    @property
    def down(self) -> bool:
        """Whether the last news of the store was a failure."""
        return self.since is not None

    def failed(self, error: BaseException) -> None:
        """A caller found the store unreachable (or full): logs the outage's beginning, once."""
        with self._lock:
            now = time.monotonic()
            if self.since is not None:
                self.failures += 1
                return
            if now - self._ended < STRAGGLERS_S:
                return
            self.since, self.failures = now, 1
        log.warning(
            "store unreachable: %s; answering 'try again later' until it is back",
            fault_reason(error),
        )

    def back(self) -> None:
        """The store answered (a new connection, a query that succeeded): logs the outage's end, once."""
        if self.since is None:
            return
        with self._lock:
            if self.since is None:
                return
            self._ended = time.monotonic()
            lasted, failures = self._ended - self.since, self.failures
            self.since, self.failures = None, 0
        log.warning("store reachable again after %.1f s (%d failures meanwhile)", lasted, failures)
