"""Connections kept open for reads: one query, one round trip, no checkout.

A read taken through the engine's pool pays for more than its query: the checkout, on
PostgreSQL a ping before use (a round trip) and, at the return, the reset of
the transaction it began (a ROLLBACK, another round trip), and on SQLite the
pool's bookkeeping, a sizeable part of a 50 microsecond lookup. The reads the
service answers most (a key's fleet, a recording, a stored result, a page of a
listing) take instead a connection from :class:`ReadPool`, a stack of
connections in autocommit mode, each a single statement and nothing to undo,
and give it back after. psycopg prepares a statement a connection has run a
few times, so a kept connection also runs the reads' statements prepared.

A kept connection that the server dropped meanwhile (PostgreSQL restarted) is
found by the failure of the next query on it. The other kept connections are
as old as it and are dropped with it (they would fail the same way, one read
each), and that read is tried once more on a new connection, which the pool
checks before use. Any other failure closes the connection it came on.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import sqlalchemy as sa
from sqlalchemy.engine import Connection, CursorResult, Engine

__all__ = ["ReadPool"]

T = TypeVar("T")


class ReadPool:
    """Autocommit connections for single-statement reads, taken from and given back to a stack.

    Parameters
    ----------
    engine : sqlalchemy.engine.Engine
    keep : int
        Connections kept at most; one more in use at once is closed once used (a bound, not a
        limit: the engine's pool limits the connections open).
    """

    def __init__(self, engine: Engine, keep: int) -> None:
        self.engine = engine
        self.keep = keep
        self._kept: list[Connection] = []  # list.pop and list.append are atomic: threads share it

    def _connection(self, kept: bool = True) -> Connection:
        try:
            if kept:
                return self._kept.pop()
        except IndexError:
            pass
        return self.engine.connect().execution_options(isolation_level="AUTOCOMMIT")

    def read(self, statement: Any, values: dict[str, Any], rows: Callable[[CursorResult[Any]], T]) -> T:
        """``rows(result)`` of one statement, on a kept connection (or a new one)."""
        for attempt in (1, 2):
            connection = self._connection(kept=attempt == 1)
            try:
                found = rows(connection.execute(statement, values))
            except sa.exc.DBAPIError as error:
                connection.close()
                if attempt == 1 and error.connection_invalidated:
                    self.close()  # kept as long as the one the server dropped: dropped too
                    continue  # once more, on a new connection
                raise
            except BaseException:
                connection.close()
                raise
            if len(self._kept) < self.keep:
                self._kept.append(connection)
            else:
                connection.close()
            return found
        raise AssertionError("unreachable")  # pragma: no cover

    def close(self) -> None:
        """Close the kept connections (they return to the engine's pool)."""
        while self._kept:
            self._kept.pop().close()
