"""What the code of every table shares: the store's clock, its times read back in UTC, and the
inserts that keep a row already there, alike on SQLite and PostgreSQL."""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any

import sqlalchemy as sa
from sqlalchemy.dialects import postgresql, sqlite
from sqlalchemy.engine import Connection

__all__ = ["insert_ignoring_existing", "insert_new", "now", "utc"]


def now() -> datetime:
    """The time now, in UTC (every time the store writes)."""
    return datetime.now(UTC)


def utc(moment: datetime) -> datetime:
    """A stored time, aware: SQLite keeps no time zone, and every stored time is UTC.

    Parameters
    ----------
    moment : datetime
        As read back, naive from SQLite, aware from PostgreSQL.

    Returns
    -------
    datetime
    """
    return moment if moment.tzinfo is not None else moment.replace(tzinfo=UTC)


def _insert(c: Connection, table: sa.Table) -> Any:
    """An INSERT of the connection's dialect, which can skip a row that conflicts with one stored."""
    return (postgresql.insert if c.dialect.name == "postgresql" else sqlite.insert)(table)


def insert_new(c: Connection, table: sa.Table, values: dict[str, Any], keys: list[str]) -> bool:
    """Insert a row unless one with the same unique ``keys`` exists (atomic, for concurrent writers).

    Parameters
    ----------
    c : Connection
        The caller's transaction.
    table : sqlalchemy.Table
    values : dict
        The row's column values.
    keys : list of str
        The columns of the unique constraint that decides "exists".

    Returns
    -------
    bool
        Whether the row went in.
    """
    statement = _insert(c, table).values(**values).on_conflict_do_nothing(index_elements=keys)
    # RETURNING says whether a row went in (rowcount is not reliable for this on every driver)
    return c.execute(statement.returning(table.c.id)).first() is not None


def insert_ignoring_existing(
    c: Connection, table: sa.Table, rows: list[dict[str, Any]], keys: list[str]
) -> None:
    """Insert rows, each unless one with the same unique ``keys`` exists (nothing for no rows).

    Parameters
    ----------
    c : Connection
        The caller's transaction.
    table : sqlalchemy.Table
    rows : list of dict
        Column values, one dict per row.
    keys : list of str
        The columns of the unique constraint that decides "exists".
    """
    if not rows:
        return
    c.execute(_insert(c, table).on_conflict_do_nothing(index_elements=keys), rows)
