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
import os
import secrets
import socket
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import sqlalchemy as sa
from sqlalchemy.engine import Connection, Engine

from monitor.errors import MonitorError
from monitor.store.schema import api_keys, engines, fleets, jobs, metadata, recordings, results

__all__ = [
    "DEFAULT_URL_ENV",
    "MAX_ATTEMPTS",
    "PASSWORD_FILE_ENV",
    "RETRY_BACKOFF",
    "Job",
    "KeyRow",
    "RecordingRow",
    "Store",
    "StoreError",
    "default_url",
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


class StoreError(MonitorError):
    """The store cannot do what was asked (unreachable database, unknown fleet, ...)."""


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
    return RecordingRow(
        row.id,
        row.fleet_id,
        row.content_hash,
        row.engine_id,
        row.filename,
        row.path,
        int(row.size_bytes),
        row.recorded_at,
        _utc(row.uploaded_at),
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
    """

    def __init__(self, engine: Engine) -> None:
        self.db = engine

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
        self.db.dispose()

    # ------------------------------------------------------------------------------- fleets, keys
    def create_fleet(self, name: str) -> int:
        """A new fleet's id (a fleet of that name already there is refused)."""
        with self.transaction() as c:
            if c.execute(sa.select(fleets.c.id).where(fleets.c.name == name)).first() is not None:
                raise StoreError(f"fleet {name!r} exists already")
            c.execute(sa.insert(fleets).values(name=name, created_at=_now()))
            return int(c.execute(sa.select(fleets.c.id).where(fleets.c.name == name)).scalar_one())

    def fleet_id(self, name: str) -> int:
        """The id of a fleet by name."""
        with self.db.connect() as c:
            row = c.execute(sa.select(fleets.c.id).where(fleets.c.name == name)).first()
        if row is None:
            raise StoreError(f"no fleet {name!r}")
        return int(row.id)

    def create_key(self, fleet_id: int, label: str = "") -> str:
        """A new API key for a fleet; only its digest is stored, so this is the one time it is seen."""
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
        with self.db.connect() as c:
            row = c.execute(
                sa.select(api_keys.c.fleet_id).where(api_keys.c.digest == key_digest(key))
            ).first()
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
    ) -> tuple[RecordingRow, bool]:
        """Store a recording's row, or find the one with the same content: ``(row, created)``.

        Concurrent uploads of the same content store one row (the unique key decides, atomically).
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
            return _recording(c.execute(sa.select(recordings).where(where)).one()), created

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

    def recordings(
        self,
        fleet_id: int,
        *,
        engine_id: str | None = None,
        since: datetime | None = None,
        until: datetime | None = None,
        offset: int = 0,
        limit: int = 100,
    ) -> list[RecordingRow]:
        """A fleet's recordings, newest first, filtered by engine and upload time, a page at a time."""
        query = sa.select(recordings).where(recordings.c.fleet_id == fleet_id)
        # stored times are UTC (SQLite keeps no zone): compare in UTC; a time without a zone is UTC
        since = _utc(since).astimezone(UTC) if since is not None else None
        until = _utc(until).astimezone(UTC) if until is not None else None
        if self.dialect == "sqlite":
            since = since.replace(tzinfo=None) if since is not None else None
            until = until.replace(tzinfo=None) if until is not None else None
        if engine_id is not None:
            query = query.where(recordings.c.engine_id == engine_id)
        if since is not None:
            query = query.where(recordings.c.uploaded_at >= since)
        if until is not None:
            query = query.where(recordings.c.uploaded_at < until)
        query = (
            query.order_by(recordings.c.uploaded_at.desc(), recordings.c.id.desc())
            .offset(offset)
            .limit(limit)
        )
        with self.db.connect() as c:
            return [_recording(r) for r in c.execute(query)]

    # ------------------------------------------------------------------------------- jobs, results
    def enqueue(self, recording_id: int, analysis_version: str) -> Job:
        """The job of a recording at an analysis version, queued if it did not exist."""
        now = _now()
        with self.transaction() as c:
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

    def complete(self, job: Job, documents: dict[str, tuple[str, dict[str, Any]]]) -> bool:
        """Store a job's results (``kind -> (status, document)``) and mark it done, in one transaction.

        A result already stored for the same recording, version and kind is kept as it is. Returns
        False if the job had been taken back from this taker meanwhile (its results are kept all the
        same: they are the analysis of the same recording at the same version).
        """
        with self.transaction() as c:
            for kind, (status, document) in documents.items():
                _insert_new(
                    c,
                    results,
                    {
                        "recording_id": job.recording_id,
                        "analysis_version": job.analysis_version,
                        "kind": kind,
                        "status": status,
                        "document": document,
                        "created_at": _now(),
                    },
                    ["recording_id", "analysis_version", "kind"],
                )
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
        engine = sa.create_engine(_with_password_file(target), pool_pre_ping=True)
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
