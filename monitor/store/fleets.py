"""A store's fleets and their API keys: a key is kept only as its digest, and names the fleet whose
data it reads and writes."""

from __future__ import annotations

import hashlib
import secrets
from dataclasses import dataclass
from datetime import datetime

import sqlalchemy as sa
from sqlalchemy.engine import CursorResult

from monitor.errors import StoreError
from monitor.names import check_name
from monitor.store.base import StoreBase
from monitor.store.queries import KEY_FLEET
from monitor.store.schema import api_keys, fleets
from monitor.store.sql import now, utc

__all__ = ["FleetStore", "KeyRow", "key_digest"]


def key_digest(key: str) -> str:
    """The stored form of an API key: its SHA-256 digest (hex).

    Parameters
    ----------
    key : str
    """
    return hashlib.sha256(key.encode("utf-8")).hexdigest()


@dataclass(frozen=True)
class KeyRow:
    """An API key as listed: its id, fleet, label and creation time (the key itself is never kept)."""

    id: int
    fleet: str
    label: str
    created_at: datetime


class FleetStore(StoreBase):
    """The fleets and keys of a :class:`monitor.store.Store`."""

    def create_fleet(self, name: str) -> int:
        """A new fleet's id (a fleet of that name already there is refused, and so is a name that is
        not 1 to 200 printable characters without white space at either end:
        :func:`monitor.names.check_name`)."""
        check_name("fleet name", name)
        with self.transaction() as c:
            if c.execute(sa.select(fleets.c.id).where(fleets.c.name == name)).first() is not None:
                raise StoreError(f"fleet {name!r} exists already")
            c.execute(sa.insert(fleets).values(name=name, created_at=now()))
            return int(c.execute(sa.select(fleets.c.id).where(fleets.c.name == name)).scalar_one())

    def fleet_label(self, fleet_id: int) -> str:
        """The name of a fleet by id (the pages' heading)."""
        with self.db.connect() as c:
            row = c.execute(sa.select(fleets.c.name).where(fleets.c.id == fleet_id)).first()
        if row is None:
            raise StoreError(f"no fleet {fleet_id}")
        return str(row.name)

    def fleet_names(self) -> list[str]:
        """The names of the store's fleets, sorted."""
        with self.db.connect() as c:
            return sorted(str(name) for name in c.execute(sa.select(fleets.c.name)).scalars())

    def fleet_id(self, name: str) -> int:
        """The id of a fleet by name."""
        with self.db.connect() as c:
            row = c.execute(sa.select(fleets.c.id).where(fleets.c.name == name)).first()
        if row is None:
            raise StoreError(f"no fleet {name!r}")
        return int(row.id)

    def create_key(self, fleet_id: int, label: str = "") -> str:
        """A new API key for a fleet; only its digest is stored, so this is the one time it is seen.

        A label, if given, is a name as a fleet's is (:func:`monitor.names.check_name`). Key ids are
        never reused: a revoked key's id names no later key (on SQLite too, migration 0007).
        """
        if label:
            check_name("key label", label)
        key = secrets.token_urlsafe(32)
        with self.transaction() as c:
            c.execute(
                sa.insert(api_keys).values(
                    fleet_id=fleet_id, digest=key_digest(key), label=label, created_at=now()
                )
            )
        return key

    def list_keys(self, fleet: str | None = None) -> list[KeyRow]:
        """The API keys (never the keys themselves, only their ids, fleets, labels and times).

        Parameters
        ----------
        fleet : str, optional
            Only this fleet's (by name).

        Returns
        -------
        list of KeyRow
            By id.
        """
        query = (
            sa.select(api_keys.c.id, fleets.c.name, api_keys.c.label, api_keys.c.created_at)
            .join(fleets, fleets.c.id == api_keys.c.fleet_id)
            .order_by(api_keys.c.id)
        )
        if fleet is not None:
            query = query.where(fleets.c.name == fleet)
        with self.db.connect() as c:
            return [KeyRow(int(r.id), str(r.name), str(r.label), utc(r.created_at)) for r in c.execute(query)]

    def revoke_key(self, key_id: int) -> bool:
        """Delete an API key: refused from the next request on. False if there is no such key.

        Parameters
        ----------
        key_id : int
        """
        with self.transaction() as c:
            return c.execute(sa.delete(api_keys).where(api_keys.c.id == key_id)).rowcount == 1

    def fleet_of_key(self, key: str) -> int | None:
        """The fleet a key belongs to, or None for an unknown key."""
        return self.fleet_of_digest(key_digest(key))

    def fleet_of_digest(self, digest: str) -> int | None:
        """The fleet of a key known by its digest (a session holds the digest, never the key), or None.

        Parameters
        ----------
        digest : str
            :func:`key_digest` of the key.
        """
        row = self.read_pool.read(KEY_FLEET, {"digest": digest}, CursorResult.first)
        return None if row is None else int(row.fleet_id)
