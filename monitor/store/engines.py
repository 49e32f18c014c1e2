"""A fleet's engine descriptions in the store, by engine id."""

from __future__ import annotations

from typing import Any

import sqlalchemy as sa

from monitor.store.base import StoreBase
from monitor.store.schema import engines
from monitor.store.sql import insert_new, now

__all__ = ["EngineStore"]


class EngineStore(StoreBase):
    """The engine descriptions of a :class:`monitor.store.Store`."""

    def put_engine(
        self, fleet_id: int, engine_id: str, description: dict[str, Any], *, replace: bool = True
    ) -> bool:
        """Store a fleet's engine description; True if it was new. With ``replace=False`` an existing
        one is kept (and False returned): concurrent creations store one."""
        moment = now()
        with self.transaction() as c:
            created = insert_new(
                c,
                engines,
                {
                    "fleet_id": fleet_id,
                    "engine_id": engine_id,
                    "description": description,
                    "created_at": moment,
                    "updated_at": moment,
                },
                ["fleet_id", "engine_id"],
            )
            if not created and replace:
                c.execute(
                    sa.update(engines)
                    .where((engines.c.fleet_id == fleet_id) & (engines.c.engine_id == engine_id))
                    .values(description=description, updated_at=moment)
                )
            return created

    def engine(self, fleet_id: int, engine_id: str) -> dict[str, Any] | None:
        """A fleet's engine description, or None."""
        with self.db.connect() as c:
            row = c.execute(
                sa.select(engines.c.description).where(
                    (engines.c.fleet_id == fleet_id) & (engines.c.engine_id == engine_id)
                )
            ).first()
        return None if row is None else dict(row.description)

    def engines(self, fleet_id: int) -> list[str]:
        """A fleet's engine ids, sorted."""
        with self.db.connect() as c:
            rows = c.execute(
                sa.select(engines.c.engine_id)
                .where(engines.c.fleet_id == fleet_id)
                .order_by(engines.c.engine_id)
            )
            return [r.engine_id for r in rows]
