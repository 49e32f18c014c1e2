"""The results store: fleets, keys, engines, recordings, analysis jobs and their results.

One data layer (SQLAlchemy Core) over two databases:

- SQLite by default, embedded, nothing to install: a file, in WAL mode (readers
  never wait for the writer), foreign keys on, a busy timeout so that
  concurrent writers queue instead of failing;
- PostgreSQL by a connection URL (``postgresql+psycopg://user@host/db``).

:func:`open_store` brings the schema up to date with its migrations
(``monitor/store/migrations``, Alembic) before anything else. Every write is a
transaction: a result is stored whole or not at all, and the unique keys make
a second write of the same result (same recording, analysis version and
kind) a no-op, so a resumed batch or a restarted worker never duplicates one.
A result is written once and never changed: its JSON text is stored with the
text's SHA-256, so a read hands out the stored text as it is
(:meth:`Store.stored_result`), tagged by that digest, without parsing it.
The transaction that stores a diagnosis also stores its trend points
(:mod:`monitor.store.trends`) and queues the alerts of its new findings for
the fleet's webhooks (:mod:`monitor.store.alerts`).

A recording is stored once per fleet and content, and keeps every file name it
was given (:meth:`Store.recording_names`). Its artefacts are found by its id:
a diagnosis records the plot file it kept (:meth:`Store.plot`), relative to the
data folder, and no reader looks for a plot by a file name.

Jobs move ``queued -> running -> done``; a failure records why and puts the
job back in the queue until :data:`MAX_ATTEMPTS`, after which it is set aside.
A job whose taker stopped touching it (a crash), or whose taker was a process
of this host that is gone, is taken back by :meth:`Store.requeue_stale`; only
its taker, by the token it got, may complete or fail a running job. A job
that failed for a passing reason waits before it is tried again, twice as
long after each attempt (:data:`RETRY_BACKOFF`).
"""

from __future__ import annotations

import hashlib
import json
import os
import secrets
import socket
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any, NamedTuple

import sqlalchemy as sa
from sqlalchemy.engine import Connection, CursorResult, Engine

from monitor.errors import StoreError
from monitor.names import check_name
from monitor.store.alerts import enqueue_events
from monitor.store.outage import Outage
from monitor.store.pool import ReadPool
from monitor.store.queries import KEY_FLEET, ONE_VIEW, STORED, listing
from monitor.store.schema import (
    api_keys,
    engines,
    fleets,
    jobs,
    metadata,
    recordings,
    results,
)
from monitor.store.schema import baselines as baseline_rows
from monitor.store.schema import recording_names as name_rows
from monitor.store.trends import DIAGNOSIS_KIND, write_trend_points

__all__ = [
    "DEFAULT_URL_ENV",
    "MAX_ATTEMPTS",
    "PASSWORD_FILE_ENV",
    "POOL_OVERFLOW",
    "POOL_SIZE",
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

DEFAULT_URL_ENV = "ENGINE_MONITOR_DB"  # environment variable with the store's URL
#: Environment variable naming a file that holds the store's password (a container secret), for a URL
#: written without one; the password never has to appear in the URL, the environment or a command line.
PASSWORD_FILE_ENV = "ENGINE_MONITOR_DB_PASSWORD_FILE"
MAX_ATTEMPTS = 3  # a job that failed this many times is set aside
#: The wait before the first retry of a job that failed for a passing reason; doubled after each attempt.
RETRY_BACKOFF = timedelta(seconds=10)
#: Connections a store keeps open, and how many more it opens for a burst (closed after it).
POOL_SIZE, POOL_OVERFLOW = 12, 20


def default_url(folder: str | Path = ".") -> str:
    """The store's URL: ``$ENGINE_MONITOR_DB``, else an SQLite file ``engine-monitor.db`` in ``folder``.

    Parameters
    ----------
    folder : str or Path, optional
    """
    url = os.environ.get(DEFAULT_URL_ENV)
    if url:
        return url
    return f"sqlite:///{Path(folder).resolve() / 'engine-monitor.db'}"


def key_digest(key: str) -> str:
    """The stored form of an API key: its SHA-256 digest (hex).

    Parameters
    ----------
    key : str
    """
    return hashlib.sha256(key.encode("utf-8")).hexdigest()


def _now() -> datetime:
    return datetime.now(UTC)


def document_text(document: dict[str, Any]) -> str:
    """A result document's stored form: JSON text, written as the store always wrote its documents.

    Parameters
    ----------
    document : dict
    """
    return json.dumps(document)


def _text_digest(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


@dataclass(frozen=True)
class RecordingRow:
    """A stored recording."""

    id: int
    fleet_id: int
    content_hash: str
    engine_id: str
    filename: str
    path: str
    size_bytes: int
    recorded_at: str
    uploaded_at: datetime


@dataclass(frozen=True)
class BaselineRow:
    """A fleet's baseline of an engine: the calibration document (``engine-monitor calibrate``'s JSON),
    the stored recording it was calibrated on, the analysis version that calibrated it, and when."""

    engine_id: str
    recording_id: int
    analysis_version: str
    document: dict[str, Any]
    created_at: datetime


@dataclass(frozen=True)
class KeyRow:
    """An API key as listed: its id, fleet, label and creation time (the key itself is never kept)."""

    id: int
    fleet: str
    label: str
    created_at: datetime


@dataclass(frozen=True)
class Job:
    """One analysis of one recording at one analysis version (``not_before``: a retry waits until then)."""

    id: int
    recording_id: int
    analysis_version: str
    state: str
    attempts: int
    error: str
    token: str = ""
    not_before: datetime | None = None


@dataclass(frozen=True)
class StoredResult:
    """A result document as stored: its JSON text and the SHA-256 (hex) of that text's UTF-8 bytes."""

    text: str
    digest: str


@dataclass(frozen=True)
class RecordingView:
    """A recording as a reader sees it: the row, its job at one analysis version (None before one is
    queued), and the status stored with its diagnosis ("" before there is one)."""

    recording: RecordingRow
    job: Job | None
    diagnosis_status: str


class RecordingSummary(NamedTuple):
    """A recording with the state of its analysis, flat, as a reader is answered: the fields of a
    :class:`RecordingView` that a client sees, in one tuple, a third of the cost of a view's three
    objects to build (which counts in a page of a listing).

    ``status`` is the job's state ("none" before one is queued); ``retry_after`` the time before
    which a queued job that failed is not tried again; ``diagnosis_status`` the stored diagnosis'
    status once the job is done, else "".
    """

    id: int
    engine_id: str
    filename: str
    content_hash: str
    size_bytes: int
    recorded_at: str
    uploaded_at: datetime
    status: str
    attempts: int
    error: str
    retry_after: datetime | None
    diagnosis_status: str


def _summary(row: Any) -> RecordingSummary:
    """The summary in a row of :data:`monitor.store.queries.VIEWS`, read by position (as
    :func:`_recording` and :func:`_view_job` read)."""
    id_, _, content_hash, engine_id, filename, _, size_bytes, recorded_at, uploaded_at = row[:9]
    job_id, state, attempts, error, not_before, diagnosis_status = row[9:15]
    if job_id is None:
        state, attempts, error, diagnosis_status = "none", 0, "", ""
    elif state != "done":
        diagnosis_status = ""
    retry_after = _utc(not_before) if state == "queued" and not_before is not None else None
    return RecordingSummary(
        id_,
        engine_id,
        filename,
        content_hash,
        int(size_bytes),
        recorded_at,
        _utc(uploaded_at),
        state,
        int(attempts),
        error,
        retry_after,
        diagnosis_status or "",
    )


@dataclass(frozen=True)
class ResultRead:
    """What a read of one result found for a fleet's recording: its job and the stored result (None
    while the analysis has not written it)."""

    job: Job | None
    result: StoredResult | None


def _process_start(pid: int) -> str:
    """When a process started, in clock ticks since boot (Linux), so a reused process id is told
    apart; "" where the system does not say."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[19]
    except (OSError, IndexError):
        return ""


def process_identity(pid: int | None = None) -> str:
    """``host:pid:start`` of a process (default: this one), as a job's ``holder``."""
    pid = os.getpid() if pid is None else pid
    return f"{socket.gethostname()}:{pid}:{_process_start(pid)}"


def _gone(holder: str) -> bool:
    """Whether a job's holder was a process of this host that no longer runs."""
    host, _, rest = holder.partition(":")
    pid_text, _, start = rest.partition(":")
    if not holder or host != socket.gethostname() or not pid_text.isdigit():
        return False  # another host's (or an older taker's): only its lease tells
    pid = int(pid_text)
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except PermissionError:
        pass  # it exists, under another user
    return bool(start) and _process_start(pid) not in ("", start)


def _utc(moment: datetime) -> datetime:
    """SQLite keeps no time zone: every stored time is UTC."""
    return moment if moment.tzinfo is not None else moment.replace(tzinfo=UTC)


def _recording(row: Any) -> RecordingRow:
    """The recording in a row that begins with the ``recordings`` table's columns, in their order (the
    fields of :class:`RecordingRow`): read by position, several times faster than by name, which
    counts in a page of a listing."""
    id_, fleet_id, content_hash, engine_id, filename, path, size_bytes, recorded_at, uploaded_at = row[:9]
    return RecordingRow(
        id_,
        fleet_id,
        content_hash,
        engine_id,
        filename,
        path,
        int(size_bytes),
        recorded_at,
        _utc(uploaded_at),
    )


def _job(row: Any) -> Job:
    return Job(
        row.id,
        row.recording_id,
        row.analysis_version,
        row.state,
        int(row.attempts),
        row.error,
        row.token,
        _utc(row.not_before) if row.not_before is not None else None,
    )


def _view_job(row: Any, analysis_version: str) -> Job | None:
    """The job in a row of a recording joined with its job (None where the join found none): the
    recording's id first, the job's columns (:data:`monitor.store.queries.JOB_COLUMNS`) from the
    tenth on, read by position as :func:`_recording` reads."""
    job_id, state, attempts, error, not_before = row[9:14]
    if job_id is None:
        return None
    return Job(
        job_id,
        row[0],
        analysis_version,
        state,
        int(attempts),
        error,
        "",  # a view never carries the taker's token
        _utc(not_before) if not_before is not None else None,
    )


def _plot_file(relative: str) -> bool:
    """Whether a recorded plot is a plain file name in the data folder's ``plots/`` (nothing that
    reaches elsewhere: no other folder, no ``..``, not absolute)."""
    folder, slash, name = relative.partition("/")
    return (
        folder == "plots"
        and bool(slash)
        and name not in ("", ".", "..")
        and "/" not in name
        and "\\" not in name
        and "\x00" not in name
    )


def _document_value(c: Connection, text: str) -> Any:
    """The stored JSON text as the value of a ``document`` column: as it is (SQLite keeps JSON as text;
    PostgreSQL's ``json`` keeps the exact text it is given)."""
    value = sa.literal(text, sa.Text)
    return sa.cast(value, sa.JSON) if c.dialect.name == "postgresql" else value


def _insert_new(c: Connection, table: sa.Table, values: dict[str, Any], keys: list[str]) -> bool:
    """Insert a row unless one with the same unique ``keys`` exists (atomic, for concurrent writers)."""
    if c.dialect.name == "postgresql":
        from sqlalchemy.dialects.postgresql import insert
    else:
        from sqlalchemy.dialects.sqlite import insert  # type: ignore[assignment]
    statement = insert(table).values(**values).on_conflict_do_nothing(index_elements=keys)
    # RETURNING says whether a row went in (rowcount is not reliable for this on every driver)
    return c.execute(statement.returning(table.c.id)).first() is not None


class Store:
    """The store behind one SQLAlchemy engine (see the module docstring). Use :func:`open_store`.

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
        self.readers = ReadPool(engine, POOL_SIZE)  # the reads the service answers most
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
        self.readers.close()
        self.db.dispose()

    # ------------------------------------------------------------------------------- fleets, keys
    def create_fleet(self, name: str) -> int:
        """A new fleet's id (a fleet of that name already there is refused, and so is a name that is
        not 1 to 200 printable characters without white space at either end:
        :func:`monitor.names.check_name`)."""
        check_name("fleet name", name)
        with self.transaction() as c:
            if c.execute(sa.select(fleets.c.id).where(fleets.c.name == name)).first() is not None:
                raise StoreError(f"fleet {name!r} exists already")
            c.execute(sa.insert(fleets).values(name=name, created_at=_now()))
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
                    fleet_id=fleet_id, digest=key_digest(key), label=label, created_at=_now()
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
            return [
                KeyRow(int(r.id), str(r.name), str(r.label), _utc(r.created_at)) for r in c.execute(query)
            ]

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
        row = self.readers.read(KEY_FLEET, {"digest": key_digest(key)}, CursorResult.first)
        return None if row is None else int(row.fleet_id)

    # -------------------------------------------------------------------------------------- engines
    def put_engine(
        self, fleet_id: int, engine_id: str, description: dict[str, Any], *, replace: bool = True
    ) -> bool:
        """Store a fleet's engine description; True if it was new. With ``replace=False`` an existing
        one is kept (and False returned): concurrent creations store one."""
        now = _now()
        with self.transaction() as c:
            created = _insert_new(
                c,
                engines,
                {
                    "fleet_id": fleet_id,
                    "engine_id": engine_id,
                    "description": description,
                    "created_at": now,
                    "updated_at": now,
                },
                ["fleet_id", "engine_id"],
            )
            if not created and replace:
                c.execute(
                    sa.update(engines)
                    .where((engines.c.fleet_id == fleet_id) & (engines.c.engine_id == engine_id))
                    .values(description=description, updated_at=now)
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

    # ----------------------------------------------------------------------------------- recordings
    def add_recording(
        self,
        fleet_id: int,
        *,
        content_hash: str,
        engine_id: str,
        filename: str,
        path: str,
        size_bytes: int,
        recorded_at: str = "",
        queue: str | None = None,
    ) -> tuple[RecordingRow, bool]:
        """Store a recording's row, or find the one with the same content: ``(row, created)``.

        Concurrent uploads of the same content store one row (the unique key decides, atomically). The
        row keeps the file name the content was first given; every name it is given is kept besides
        (:meth:`recording_names`), in the same transaction. With ``queue`` (an analysis version)
        its analysis job is queued, if it has none at that version, in the same transaction: a recording is
        never stored without its job.
        """
        if len(engine_id) > 200 or len(filename) > 255 or "\x00" in engine_id + filename:
            raise StoreError(
                "a recording's engine id must be at most 200 characters and its file name 255, without NUL"
            )
        with self.transaction() as c:
            created = _insert_new(
                c,
                recordings,
                {
                    "fleet_id": fleet_id,
                    "content_hash": content_hash,
                    "engine_id": engine_id,
                    "filename": filename,
                    "path": path,
                    "size_bytes": size_bytes,
                    "recorded_at": recorded_at,
                    "uploaded_at": _now(),
                },
                ["fleet_id", "content_hash"],
            )
            where = (recordings.c.fleet_id == fleet_id) & (recordings.c.content_hash == content_hash)
            row = _recording(c.execute(sa.select(recordings).where(where)).one())
            _insert_new(
                c,
                name_rows,
                {"recording_id": row.id, "filename": filename, "created_at": _now()},
                ["recording_id", "filename"],
            )
            if queue is not None:
                self._enqueue(c, row.id, queue)
            return row, created

    def recording_names(self, fleet_id: int, recording_ids: list[int]) -> dict[int, list[str]]:
        """Every file name each of a fleet's recordings was given, in the order they were first given.

        Parameters
        ----------
        fleet_id : int
        recording_ids : list of int
            Another fleet's ids, and unknown ones, are left out of the answer.

        Returns
        -------
        dict of int to list of str
            The names, by recording id; the first is the name the recording was registered under.
        """
        with self.db.connect() as c:
            rows = c.execute(
                sa.select(name_rows.c.recording_id, name_rows.c.filename)
                .join(recordings, recordings.c.id == name_rows.c.recording_id)
                .where((recordings.c.fleet_id == fleet_id) & recordings.c.id.in_(recording_ids))
                .order_by(name_rows.c.recording_id, name_rows.c.id)
            )
            names: dict[int, list[str]] = {}
            for recording_id, filename in rows:
                names.setdefault(int(recording_id), []).append(str(filename))
            return names

    def registered_filenames(self) -> list[tuple[int, str]]:
        """Every recording of every fleet, by id: its id and the file name it was registered under (the
        batch names the plots of a shared data folder after them, :func:`monitor.jobs.batch.plot_names`)."""
        with self.db.connect() as c:
            rows = c.execute(sa.select(recordings.c.id, recordings.c.filename).order_by(recordings.c.id))
            return [(int(r.id), str(r.filename)) for r in rows]

    def content_stored(self, content_hash: str) -> bool:
        """Whether any fleet's recording has this content (its file in the data folder is in use).

        Parameters
        ----------
        content_hash : str
            The SHA-256 (hex) of the file.
        """
        with self.db.connect() as c:
            found = c.execute(
                sa.select(recordings.c.id).where(recordings.c.content_hash == content_hash).limit(1)
            ).first()
        return found is not None

    def recording(self, fleet_id: int, recording_id: int) -> RecordingRow | None:
        """A fleet's recording by id (another fleet's answers None, as an unknown one)."""
        with self.db.connect() as c:
            row = c.execute(
                sa.select(recordings).where(
                    (recordings.c.id == recording_id) & (recordings.c.fleet_id == fleet_id)
                )
            ).first()
        return None if row is None else _recording(row)

    def recording_by_id(self, recording_id: int) -> RecordingRow | None:
        """A recording by id, whatever its fleet (for workers, never for answers to a key)."""
        with self.db.connect() as c:
            row = c.execute(sa.select(recordings).where(recordings.c.id == recording_id)).first()
        return None if row is None else _recording(row)

    def _stored_time(self, moment: datetime) -> datetime:
        """A time as the store compares it: UTC (a time without a zone is UTC), without a zone on SQLite,
        which keeps none."""
        moment = _utc(moment).astimezone(UTC)
        return moment.replace(tzinfo=None) if self.dialect == "sqlite" else moment

    def _page(
        self,
        views: bool,
        fleet_id: int,
        engine_id: str | None,
        since: datetime | None,
        until: datetime | None,
        after: tuple[datetime, int] | None,
        offset: int,
        limit: int,
        **more: Any,
    ) -> list[Any]:
        """The rows of one page of a fleet's listing (see :meth:`recordings`)."""
        query = listing(views, engine_id is not None, since is not None, until is not None, after is not None)
        values = {"fleet_id": fleet_id, "engine_id": engine_id, "offset": offset, "limit": limit, **more}
        if since is not None:
            values["since"] = self._stored_time(since)
        if until is not None:
            values["until"] = self._stored_time(until)
        if after is not None:
            values["after_time"], values["after_id"] = self._stored_time(after[0]), after[1]
        return list(self.readers.read(query, values, CursorResult.all))

    def recordings(
        self,
        fleet_id: int,
        *,
        engine_id: str | None = None,
        since: datetime | None = None,
        until: datetime | None = None,
        after: tuple[datetime, int] | None = None,
        offset: int = 0,
        limit: int = 100,
    ) -> list[RecordingRow]:
        """A fleet's recordings, newest first, filtered by engine and upload time, a page at a time.

        Parameters
        ----------
        fleet_id : int
        engine_id : str, optional
        since, until : datetime, optional
            Uploaded at or after ``since``, before ``until`` (UTC where they have no zone).
        after : (datetime, int), optional
            The upload time and id of the last recording of the previous page: the page after it
            (keyset paging: read off the index however deep the page).
        offset, limit : int, optional
            Rows skipped (after ``after``), rows at most.
        """
        rows = self._page(False, fleet_id, engine_id, since, until, after, offset, limit)
        return [_recording(r) for r in rows]

    @staticmethod
    def _view(row: Any, analysis_version: str) -> RecordingView:
        job = _view_job(row, analysis_version)
        status = row.diagnosis_status if job is not None and job.state == "done" else None
        return RecordingView(_recording(row), job, status or "")

    def recording_view(self, fleet_id: int, recording_id: int, analysis_version: str) -> RecordingView | None:
        """A fleet's recording with its job and diagnosis status, in one query (another fleet's: None).

        Parameters
        ----------
        fleet_id, recording_id : int
        analysis_version : str
        """
        values = {"fleet_id": fleet_id, "recording_id": recording_id, "version": analysis_version}
        row = self.readers.read(ONE_VIEW, values, CursorResult.first)
        return None if row is None else self._view(row, analysis_version)

    def recording_views(
        self,
        fleet_id: int,
        analysis_version: str,
        *,
        engine_id: str | None = None,
        since: datetime | None = None,
        until: datetime | None = None,
        after: tuple[datetime, int] | None = None,
        offset: int = 0,
        limit: int = 100,
    ) -> list[RecordingView]:
        """A page of :meth:`recordings` with each one's job and diagnosis status, in one query.

        Parameters are those of :meth:`recordings`, and the analysis version of the jobs.
        """
        rows = self._page(
            True, fleet_id, engine_id, since, until, after, offset, limit, version=analysis_version
        )
        return [self._view(r, analysis_version) for r in rows]

    def recording_summary(
        self, fleet_id: int, recording_id: int, analysis_version: str
    ) -> RecordingSummary | None:
        """:meth:`recording_view` as a :class:`RecordingSummary` (another fleet's: None)."""
        values = {"fleet_id": fleet_id, "recording_id": recording_id, "version": analysis_version}
        row = self.readers.read(ONE_VIEW, values, CursorResult.first)
        return None if row is None else _summary(row)

    def recording_summaries(
        self,
        fleet_id: int,
        analysis_version: str,
        *,
        engine_id: str | None = None,
        since: datetime | None = None,
        until: datetime | None = None,
        after: tuple[datetime, int] | None = None,
        offset: int = 0,
        limit: int = 100,
    ) -> list[RecordingSummary]:
        """:meth:`recording_views` as :class:`RecordingSummary` tuples, in one query (the listing's page).

        Parameters are those of :meth:`recording_views`.
        """
        rows = self._page(
            True, fleet_id, engine_id, since, until, after, offset, limit, version=analysis_version
        )
        return [_summary(r) for r in rows]

    # ------------------------------------------------------------------------------- jobs, results
    def enqueue(self, recording_id: int, analysis_version: str) -> Job:
        """The job of a recording at an analysis version, queued if it did not exist."""
        with self.transaction() as c:
            return self._enqueue(c, recording_id, analysis_version)

    def _enqueue(self, c: Connection, recording_id: int, analysis_version: str) -> Job:
        now = _now()
        _insert_new(
            c,
            jobs,
            {
                "recording_id": recording_id,
                "analysis_version": analysis_version,
                "state": "queued",
                "attempts": 0,
                "error": "",
                "token": "",
                "created_at": now,
                "updated_at": now,
            },
            ["recording_id", "analysis_version"],
        )
        where = (jobs.c.recording_id == recording_id) & (jobs.c.analysis_version == analysis_version)
        return _job(c.execute(sa.select(jobs).where(where)).one())

    def _take(self, c: Connection, job_id: int) -> Job | None:
        token = secrets.token_hex(16)
        taken = c.execute(
            sa.update(jobs)
            .where((jobs.c.id == job_id) & (jobs.c.state == "queued"))
            .values(
                state="running",
                attempts=jobs.c.attempts + 1,
                token=token,
                holder=process_identity(),
                not_before=None,
                updated_at=_now(),
            )
        ).rowcount
        if taken != 1:
            return None
        return _job(c.execute(sa.select(jobs).where(jobs.c.id == job_id)).one())

    def claim(self, analysis_version: str) -> Job | None:
        """Take the oldest queued job of this version that is due (marking it running), or None.

        A job waiting out its retry backoff is not due yet.

        Two workers never take the same job: the state changes only where it is still "queued", and
        the taker's token (in the returned job) is what later updates of the job must show.
        """
        while True:
            with self.transaction() as c:
                due = jobs.c.not_before.is_(None) | (jobs.c.not_before <= _now())
                row = c.execute(
                    sa.select(jobs.c.id)
                    .where((jobs.c.state == "queued") & (jobs.c.analysis_version == analysis_version) & due)
                    .order_by(jobs.c.id)
                    .limit(1)
                ).first()
                if row is None:
                    return None
                job = self._take(c, row.id)
                if job is not None:
                    return job

    def claim_job(self, job_id: int) -> Job | None:
        """Take one job if it is still queued (marking it running), else None; a batch asks for it
        by name, so a retry backoff does not hold it."""
        with self.transaction() as c:
            return self._take(c, job_id)

    @staticmethod
    def _mine(job: Job) -> Any:
        """The job, still running under this taker's token (not taken back meanwhile)."""
        return (jobs.c.id == job.id) & (jobs.c.state == "running") & (jobs.c.token == job.token)

    def complete(
        self, job: Job, documents: dict[str, tuple[str, dict[str, Any]]], *, plot: str | None = None
    ) -> bool:
        """Store a job's results (``kind -> (status, document)``) and mark it done, in one transaction.

        A result already stored for the same recording, version and kind is kept as it is. Returns
        False if the job had been taken back from this taker meanwhile (its results are kept all the
        same: they are the analysis of the same recording at the same version).

        Parameters
        ----------
        job : Job
            As its taker got it (:meth:`claim`, :meth:`claim_job`).
        documents : dict of str to (str, dict)
            The results by kind: their status and document.
        plot : str, optional
            The diagnosis plot the analysis kept, relative to the data folder (``plots/NAME.png``),
            recorded with the diagnosis (:meth:`plot`); None: none was kept.
        """
        if plot is not None and not _plot_file(plot):
            raise StoreError(f"plot {plot!r}: expected a file name under plots/ of the data folder")
        texts = {kind: document_text(document) for kind, (_, document) in documents.items()}
        with self.transaction() as c:
            created = set()
            for kind, (status, _) in documents.items():
                if _insert_new(
                    c,
                    results,
                    {
                        "recording_id": job.recording_id,
                        "analysis_version": job.analysis_version,
                        "kind": kind,
                        "status": status,
                        "document": _document_value(c, texts[kind]),
                        "digest": _text_digest(texts[kind]),
                        "plot": plot if kind == DIAGNOSIS_KIND else None,
                        "created_at": _now(),
                    },
                    ["recording_id", "analysis_version", "kind"],
                ):
                    created.add(kind)
            if DIAGNOSIS_KIND in documents:  # its quantities, for the engine's trends
                write_trend_points(c, job.recording_id, job.analysis_version, documents[DIAGNOSIS_KIND][1])
            if DIAGNOSIS_KIND in created:  # its new findings' alerts, queued once: with the diagnosis
                enqueue_events(c, job.recording_id, job.analysis_version, documents[DIAGNOSIS_KIND][1])
            mine = c.execute(
                sa.update(jobs)
                .where(self._mine(job))
                .values(state="done", error="", token="", holder="", updated_at=_now())
            ).rowcount
            if mine != 1:  # taken back and maybe queued again: with its results stored, it is done
                c.execute(
                    sa.update(jobs)
                    .where((jobs.c.id == job.id) & (jobs.c.state == "queued"))
                    .values(state="done", error="", updated_at=_now())
                )
            return mine == 1

    def fail(self, job: Job, error: str, *, permanent: bool = False, backoff: timedelta | None = None) -> str:
        """Record why a job failed; queue it again, or set it aside after :data:`MAX_ATTEMPTS`.

        A ``permanent`` failure (the input itself is wrong: trying again gives the same answer) is
        set aside at once; another is queued again, not before ``backoff`` (default
        :data:`RETRY_BACKOFF`) doubled for each attempt after the first. Returns the job's new state
        (its current one, unchanged, if it was taken back meanwhile).
        """
        wait = (RETRY_BACKOFF if backoff is None else backoff) * 2 ** max(0, job.attempts - 1)
        with self.transaction() as c:
            state = "set_aside" if permanent or job.attempts >= MAX_ATTEMPTS else "queued"
            changed = c.execute(
                sa.update(jobs)
                .where(self._mine(job))
                .values(
                    state=state,
                    error=error[:4000],
                    token="",
                    holder="",
                    not_before=_now() + wait if state == "queued" else None,
                    updated_at=_now(),
                )
            ).rowcount
            if changed != 1:
                return str(c.execute(sa.select(jobs.c.state).where(jobs.c.id == job.id)).scalar_one())
            return state

    def touch(self, job: Job) -> bool:
        """A running job's heartbeat: its taker is alive. False if the job was taken back."""
        with self.transaction() as c:
            return c.execute(sa.update(jobs).where(self._mine(job)).values(updated_at=_now())).rowcount == 1

    def requeue_stale(
        self, analysis_version: str, older_than: timedelta, *, recording_ids: list[int] | None = None
    ) -> int:
        """Take back the running jobs whose taker died; how many.

        A taker is dead when it has not touched its job for ``older_than`` (takers touch their
        running jobs, :meth:`touch`, more often than that), or at once when it was a process of
        this host that no longer runs (a killed server, worker or batch restarted). Its jobs are
        queued again, or set aside once they have been tried :data:`MAX_ATTEMPTS` times (a
        recording that kills its worker).
        """
        cutoff = _now() - older_than
        running = (jobs.c.state == "running") & (jobs.c.analysis_version == analysis_version)
        if recording_ids is not None:
            running &= jobs.c.recording_id.in_(recording_ids)
        with self.transaction() as c:
            held = c.execute(
                sa.select(jobs.c.id, jobs.c.holder).where(running & (jobs.c.updated_at >= cutoff))
            )
            gone = [
                (jobs.c.id == row.id) & (jobs.c.holder == row.holder) for row in held if _gone(row.holder)
            ]
        where = running & ((jobs.c.updated_at < cutoff) | sa.or_(sa.false(), *gone))
        lost = "its worker stopped answering while it ran (killed, or out of memory)"
        with self.transaction() as c:
            aside = c.execute(
                sa.update(jobs)
                .where(where & (jobs.c.attempts >= MAX_ATTEMPTS))
                .values(state="set_aside", error=lost, token="", holder="", updated_at=_now())
            ).rowcount
            again = c.execute(
                sa.update(jobs).where(where).values(state="queued", token="", holder="", updated_at=_now())
            ).rowcount
            return int(aside + again)

    def job(self, recording_id: int, analysis_version: str) -> Job | None:
        """The job of a recording at a version, or None."""
        with self.db.connect() as c:
            row = c.execute(
                sa.select(jobs).where(
                    (jobs.c.recording_id == recording_id) & (jobs.c.analysis_version == analysis_version)
                )
            ).first()
        return None if row is None else _job(row)

    def result(self, recording_id: int, analysis_version: str, kind: str) -> dict[str, Any] | None:
        """A stored result document, or None."""
        with self.db.connect() as c:
            row = c.execute(
                sa.select(results.c.document).where(
                    (results.c.recording_id == recording_id)
                    & (results.c.analysis_version == analysis_version)
                    & (results.c.kind == kind)
                )
            ).first()
        return None if row is None else dict(row.document)

    def stored_result(
        self, fleet_id: int, recording_id: int, analysis_version: str, kind: str
    ) -> ResultRead | None:
        """A fleet's recording's result as stored (its JSON text, never parsed) and its job, in one
        query; None for a recording the fleet does not have.

        Parameters
        ----------
        fleet_id, recording_id : int
        analysis_version, kind : str
        """
        values = {
            "fleet_id": fleet_id,
            "recording_id": recording_id,
            "version": analysis_version,
            "kind": kind,
        }
        row = self.readers.read(STORED, values, CursorResult.first)
        if row is None:
            return None
        stored = None
        if row.result_id is not None:
            stored = StoredResult(row.text, row.digest or _text_digest(row.text))
        return ResultRead(_view_job(row, analysis_version), stored)

    def plot(self, fleet_id: int, recording_id: int, analysis_version: str) -> str | None:
        """The plot file a fleet's recording's diagnosis kept, relative to the data folder; None while
        there is no diagnosis, when it kept none, or for another fleet's recording.

        Parameters
        ----------
        fleet_id, recording_id : int
        analysis_version : str
        """
        with self.db.connect() as c:
            row = c.execute(
                sa.select(results.c.plot)
                .join(recordings, recordings.c.id == results.c.recording_id)
                .where(
                    (recordings.c.id == recording_id)
                    & (recordings.c.fleet_id == fleet_id)
                    & (results.c.analysis_version == analysis_version)
                    & (results.c.kind == DIAGNOSIS_KIND)
                )
            ).first()
        return None if row is None or row.plot is None or not _plot_file(row.plot) else str(row.plot)

    def jobs_by_state(self, analysis_version: str) -> dict[str, int]:
        """How many jobs of an analysis version are in each state (the states with none left out)."""
        with self.db.connect() as c:
            rows = c.execute(
                sa.select(jobs.c.state, sa.func.count())
                .where(jobs.c.analysis_version == analysis_version)
                .group_by(jobs.c.state)
            )
            return {str(state): int(n) for state, n in rows}

    def result_status(self, recording_id: int, analysis_version: str, kind: str) -> str | None:
        """The status stored with a result (healthy, warning, alarm), or None."""
        with self.db.connect() as c:
            row = c.execute(
                sa.select(results.c.status).where(
                    (results.c.recording_id == recording_id)
                    & (results.c.analysis_version == analysis_version)
                    & (results.c.kind == kind)
                )
            ).first()
        return None if row is None else str(row.status)

    # ------------------------------------------------------------------------------------ baselines
    def put_baseline(
        self,
        fleet_id: int,
        engine_id: str,
        recording_id: int,
        analysis_version: str,
        document: dict[str, Any],
    ) -> BaselineRow:
        """Store a fleet's baseline of an engine, replacing the one it had, in one transaction.

        Parameters
        ----------
        fleet_id : int
        engine_id : str
        recording_id : int
            The fleet's stored recording of that engine it was calibrated on.
        analysis_version : str
            The version of the analysis that calibrated it.
        document : dict
            The baseline (:meth:`monitor.diagnosis.Baseline.to_document`).

        Raises
        ------
        StoreError
            If the recording is not the fleet's, or is of another engine (nothing is stored).
        """
        now = _now()
        with self.transaction() as c:
            found = c.execute(
                sa.select(recordings.c.engine_id).where(
                    (recordings.c.id == recording_id) & (recordings.c.fleet_id == fleet_id)
                )
            ).first()
            if found is None or found.engine_id != engine_id:
                raise StoreError(
                    f"recording {recording_id}: expected a recording of engine {engine_id!r} of the same "
                    f"fleet, found {'none' if found is None else 'one of engine ' + repr(found.engine_id)}"
                )
            values = {
                "recording_id": recording_id,
                "analysis_version": analysis_version,
                "document": document,
                "created_at": now,
            }
            created = _insert_new(
                c,
                baseline_rows,
                {"fleet_id": fleet_id, "engine_id": engine_id, **values},
                ["fleet_id", "engine_id"],
            )
            if not created:
                c.execute(
                    sa.update(baseline_rows)
                    .where((baseline_rows.c.fleet_id == fleet_id) & (baseline_rows.c.engine_id == engine_id))
                    .values(**values)
                )
        return BaselineRow(engine_id, recording_id, analysis_version, document, now)

    def baseline(self, fleet_id: int, engine_id: str) -> BaselineRow | None:
        """A fleet's baseline of an engine, or None (another fleet's answers None, as none at all).

        Parameters
        ----------
        fleet_id : int
        engine_id : str
        """
        with self.db.connect() as c:
            row = c.execute(
                sa.select(baseline_rows).where(
                    (baseline_rows.c.fleet_id == fleet_id) & (baseline_rows.c.engine_id == engine_id)
                )
            ).first()
        if row is None:
            return None
        return BaselineRow(
            row.engine_id,
            int(row.recording_id),
            row.analysis_version,
            dict(row.document),
            _utc(row.created_at),
        )

    def fleet_of_digest(self, digest: str) -> int | None:
        """The fleet of a key known by its digest (a session holds the digest, never the key), or None.

        Parameters
        ----------
        digest : str
            :func:`key_digest` of the key.
        """
        row = self.readers.read(KEY_FLEET, {"digest": digest}, CursorResult.first)
        return None if row is None else int(row.fleet_id)

    def count(self, table: str) -> int:
        """Rows in a table (for checks and summaries)."""
        with self.db.connect() as c:
            return int(c.execute(sa.select(sa.func.count()).select_from(metadata.tables[table])).scalar_one())


def _without_password(url: str) -> str:
    """The URL with its password masked (for messages)."""
    try:
        return sa.engine.make_url(url).render_as_string(hide_password=True)
    except sa.exc.ArgumentError:
        return url if "@" not in url else "***@" + url.rsplit("@", 1)[1]


def _sqlite_pragmas(connection: Any, _: Any) -> None:
    cursor = connection.cursor()
    cursor.execute("PRAGMA journal_mode=WAL")
    cursor.execute("PRAGMA foreign_keys=ON")
    cursor.execute("PRAGMA busy_timeout=30000")
    cursor.execute("PRAGMA synchronous=NORMAL")
    cursor.close()


def _with_password_file(url: str) -> str | sa.URL:
    """The URL with the password from :data:`PASSWORD_FILE_ENV`'s file, where it names one and the URL
    has none."""
    secret = os.environ.get(PASSWORD_FILE_ENV)
    if not secret:
        return url
    try:
        parsed = sa.make_url(url)
    except sa.exc.ArgumentError:
        return url  # refused, with its message, by create_engine
    if parsed.password is not None or parsed.get_backend_name() == "sqlite":
        return url
    try:
        password = Path(secret).read_text(encoding="utf-8").rstrip("\r\n")
    except OSError as error:
        raise StoreError(
            f"${PASSWORD_FILE_ENV} {secret}: cannot read the store's password ({error})"
        ) from None
    return parsed.set(password=password)


def _pool_options(url: sa.URL) -> dict[str, Any]:
    """The connection pool: :data:`POOL_SIZE` connections kept open (a busy server's reads neither wait
    for one nor open and close one each), more for a burst; each checked with a ping before use where a
    server may have dropped it (PostgreSQL), not for an SQLite file, which no one can drop."""
    if url.get_backend_name() == "sqlite":
        if url.database in (None, "", ":memory:"):
            return {}  # one connection per thread, kept by SQLAlchemy's own pool for memory databases
        return {"pool_size": POOL_SIZE, "max_overflow": POOL_OVERFLOW}
    return {"pool_size": POOL_SIZE, "max_overflow": POOL_OVERFLOW, "pool_pre_ping": True}


def open_store(url: str | None = None) -> Store:
    """Open (and migrate to the newest schema) the store at ``url``.

    Parameters
    ----------
    url : str, optional
        ``sqlite:///PATH`` or ``postgresql+psycopg://...``; default: :func:`default_url`. A URL
        without a password takes it from the file ``$ENGINE_MONITOR_DB_PASSWORD_FILE`` names, if set.

    Raises
    ------
    StoreError
        If the database cannot be reached or migrated; the message names the URL without its password.
    """
    from alembic import command
    from alembic.config import Config

    target = url or default_url()
    try:
        given = _with_password_file(target)
        engine = sa.create_engine(given, **_pool_options(sa.make_url(given)))
    except (sa.exc.ArgumentError, ImportError) as error:
        shown = _without_password(target)
        raise StoreError(f"store URL {shown!r}: {str(error).replace(target, shown)}") from None
    if engine.dialect.name == "sqlite":
        sa.event.listen(engine, "connect", _sqlite_pragmas)
    config = Config()
    config.set_main_option("script_location", str(Path(__file__).parent / "migrations"))
    try:
        with engine.begin() as connection:
            if engine.dialect.name == "postgresql":  # one migrator at a time (an API and a worker starting)
                connection.execute(sa.text("SELECT pg_advisory_xact_lock(4242020601)"))
            config.attributes["connection"] = connection
            command.upgrade(config, "head")
    except sa.exc.OperationalError as error:
        engine.dispose()
        shown = engine.url.render_as_string(hide_password=True)
        raise StoreError(f"store {shown}: cannot be reached or migrated ({error.orig})") from error
    return Store(engine)
