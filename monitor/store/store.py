"""The store, whole: one class made of the parts each of its tables needs, and how it is opened."""

from __future__ import annotations

from monitor.store.baselines import BaselineStore
from monitor.store.engines import EngineStore
from monitor.store.fleets import FleetStore
from monitor.store.jobs import JobQueue
from monitor.store.opening import connect
from monitor.store.recordings import RecordingStore
from monitor.store.results import ResultStore

__all__ = ["Store", "open_store"]


class Store(FleetStore, EngineStore, RecordingStore, JobQueue, ResultStore, BaselineStore):
    """The store behind one SQLAlchemy engine (see :mod:`monitor.store`). Use :func:`open_store`.

    Its methods are those of its parts: the fleets and their keys (:class:`FleetStore`), the engine
    descriptions (:class:`EngineStore`), the recordings (:class:`RecordingStore`), the analysis jobs
    (:class:`JobQueue`), their results (:class:`ResultStore`) and the baselines
    (:class:`BaselineStore`), all on the connections, transactions and outage log of
    :class:`monitor.store.base.StoreBase`.

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


def open_store(url: str | None = None) -> Store:
    """Open (and migrate to the newest schema) the store at ``url``.

    Parameters
    ----------
    url : str, optional
        ``sqlite:///PATH`` or ``postgresql+psycopg://...``; default:
        :func:`monitor.store.opening.default_url`. A URL without a password takes it from the file
        ``$ENGINE_MONITOR_DB_PASSWORD_FILE`` names, if set.

    Raises
    ------
    StoreError
        If the database cannot be reached or migrated; the message names the URL without its password.
    """
    return Store(connect(url))
