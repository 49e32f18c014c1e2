"""The results store: fleets, keys, engines, recordings, analysis jobs and their results.

One data layer (SQLAlchemy Core) over two databases, SQLite by default (a
file, nothing to install) or PostgreSQL by a connection URL;
:func:`open_store` opens one and brings its schema up to date with its
migrations (:mod:`monitor.store.opening`). A :class:`Store` is made of one
part per resource, each in a module of its own:

- :mod:`monitor.store.base`: the engine, the connections kept for the reads
  the service answers most (:mod:`monitor.store.pool`, their statements in
  :mod:`monitor.store.queries`), transactions, the outage log
  (:mod:`monitor.store.outage`);
- :mod:`monitor.store.fleets`: fleets and their API keys;
- :mod:`monitor.store.engines`: engine descriptions;
- :mod:`monitor.store.recordings`: recordings, their names, the listing;
- :mod:`monitor.store.jobs`: the queue of analysis jobs;
- :mod:`monitor.store.results`: the results, written with their job's
  completion, with the diagnosis' trend points (:mod:`monitor.store.trends`)
  and alerts (:mod:`monitor.store.alerts`, for the fleet's webhooks:
  :mod:`monitor.store.webhooks`);
- :mod:`monitor.store.baselines`: the engines' baselines.

The tables are declared in :mod:`monitor.store.schema`.
"""

from __future__ import annotations

from monitor.store.baselines import BaselineRow
from monitor.store.fleets import KeyRow, key_digest
from monitor.store.jobs import MAX_ATTEMPTS, RETRY_BACKOFF, Job
from monitor.store.opening import DEFAULT_URL_ENV, PASSWORD_FILE_ENV, default_url
from monitor.store.recordings import RecordingRow, RecordingSummary, RecordingView
from monitor.store.results import ResultRead, StoredResult, document_text
from monitor.store.store import Store, open_store

__all__ = [
    "DEFAULT_URL_ENV",
    "MAX_ATTEMPTS",
    "PASSWORD_FILE_ENV",
    "RETRY_BACKOFF",
    "BaselineRow",
    "Job",
    "KeyRow",
    "RecordingRow",
    "RecordingSummary",
    "RecordingView",
    "ResultRead",
    "Store",
    "StoredResult",
    "default_url",
    "document_text",
    "key_digest",
    "open_store",
]
