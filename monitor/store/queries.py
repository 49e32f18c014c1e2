"""The statements of the service's reads, built once with bound parameters.

Building a SQLAlchemy statement costs several times what SQLite takes to
answer it, so the reads every request makes (a key's fleet, a recording with
its job, a stored result, a page of a fleet's recordings) are built here once,
and only their parameters change from call to call. Each is answered from an
index: a key by its digest, a job or a result by its unique key, a page of
recordings by ``ix_recordings_fleet_uploaded`` (fleet, upload time, id), in the
order of the listing, so a page costs the same however deep it is.

The rows of ``VIEWS``, ``ONE_VIEW``, ``STORED`` and of a listing begin with
the ``recordings`` table's columns, in its order, then (but for the plain
listing) :data:`JOB_COLUMNS`: the store reads them by position.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import sqlalchemy as sa

from monitor.store.schema import api_keys, jobs, recordings, results

__all__ = ["JOB_COLUMNS", "KEY_FLEET", "ONE_VIEW", "STORED", "VIEWS", "listing"]

_VERSION = sa.bindparam("version", type_=sa.String)
#: a recording's job at ``version`` (NULLs where it has none), after the recording's columns
JOB_COLUMNS = (
    jobs.c.id.label("job_id"),
    jobs.c.state.label("job_state"),
    jobs.c.attempts.label("job_attempts"),
    jobs.c.error.label("job_error"),
    jobs.c.not_before.label("job_not_before"),
)
_WITH_JOB = recordings.outerjoin(
    jobs, (jobs.c.recording_id == recordings.c.id) & (jobs.c.analysis_version == _VERSION)
)
_ONE_RECORDING = (recordings.c.id == sa.bindparam("recording_id")) & (
    recordings.c.fleet_id == sa.bindparam("fleet_id")
)
#: a key's fleet, by the key's digest
KEY_FLEET = sa.select(api_keys.c.fleet_id).where(api_keys.c.digest == sa.bindparam("digest"))
#: recordings with their job and their diagnosis' status (one row each)
VIEWS = sa.select(recordings, *JOB_COLUMNS, results.c.status.label("diagnosis_status")).select_from(
    _WITH_JOB.outerjoin(
        results,
        (results.c.recording_id == recordings.c.id)
        & (results.c.analysis_version == _VERSION)
        & (results.c.kind == "diagnosis"),
    )
)
ONE_VIEW = VIEWS.where(_ONE_RECORDING)
#: one recording's job and stored result of one kind, its text as stored (never parsed)
STORED = (
    sa.select(
        recordings,
        *JOB_COLUMNS,
        results.c.id.label("result_id"),
        results.c.digest,
        sa.cast(results.c.document, sa.Text).label("text"),
    )
    .select_from(
        _WITH_JOB.outerjoin(
            results,
            (results.c.recording_id == recordings.c.id)
            & (results.c.analysis_version == _VERSION)
            & (results.c.kind == sa.bindparam("kind")),
        )
    )
    .where(_ONE_RECORDING)
)


@lru_cache(maxsize=64)
def listing(views: bool, engine: bool, since: bool, until: bool, after: bool) -> Any:
    """The statement of a fleet's listing with these filters (parameters: ``fleet_id``, ``engine_id``,
    ``since``, ``until``, ``after_time``, ``after_id``, ``offset``, ``limit``, and ``version`` for
    ``views``), newest first, the id breaking ties, as ``ix_recordings_fleet_uploaded`` is ordered."""
    moment = recordings.c.uploaded_at.type
    query = VIEWS if views else sa.select(recordings)
    query = query.where(recordings.c.fleet_id == sa.bindparam("fleet_id"))
    if engine:
        query = query.where(recordings.c.engine_id == sa.bindparam("engine_id"))
    if since:
        query = query.where(recordings.c.uploaded_at >= sa.bindparam("since", type_=moment))
    if until:
        query = query.where(recordings.c.uploaded_at < sa.bindparam("until", type_=moment))
    if after:  # keyset: the rows after the last one of the previous page, read off the index
        query = query.where(
            sa.tuple_(recordings.c.uploaded_at, recordings.c.id)
            < sa.tuple_(sa.bindparam("after_time", type_=moment), sa.bindparam("after_id", type_=sa.Integer))
        )
    return (
        query.order_by(recordings.c.uploaded_at.desc(), recordings.c.id.desc())
        .offset(sa.bindparam("offset", type_=sa.Integer))
        .limit(sa.bindparam("limit", type_=sa.Integer))
    )
