"""What every part of a store stands on: its engine, the connections kept for its reads, whether it
is down, and its transactions."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import sqlalchemy as sa
from sqlalchemy.engine import Connection, Engine

from monitor.store.opening import POOL_SIZE
from monitor.store.outage import Outage
from monitor.store.pool import ReadPool
from monitor.store.schema import metadata

__all__ = ["StoreBase"]


class StoreBase:
    """The store behind one SQLAlchemy engine, without its tables' methods (the parts of
    :class:`monitor.store.Store` add them).

    Parameters
    ----------
    engine : sqlalchemy.engine.Engine
        Connected to a migrated database.

    Attributes
    ----------
    outage : monitor.store.outage.Outage
        Whether the store is down (callers report its failures); a new connection made to it ends an
        outage.
    """

    def __init__(self, engine: Engine) -> None:
        self.db = engine
        self.read_pool = ReadPool(engine, POOL_SIZE)  # the reads the service answers most
        self.outage = Outage()
        sa.event.listen(engine, "connect", lambda *_: self.outage.back())

    @property
    def dialect(self) -> str:
        """ "sqlite" or "postgresql"."""
        return str(self.db.dialect.name)

    @contextmanager
    def transaction(self) -> Iterator[Connection]:
        """A connection in one transaction: committed on success, rolled back on any error."""
        with self.db.begin() as connection:
            yield connection

    def close(self) -> None:
        """Release the connections."""
        self.read_pool.close()
        self.db.dispose()

    def count(self, table: str) -> int:
        """Rows in a table (for checks and summaries)."""
        with self.db.connect() as c:
            return int(c.execute(sa.select(sa.func.count()).select_from(metadata.tables[table])).scalar_one())
