"""Opening a store's database: its URL, its password, the connection pool, SQLite's settings, and the
migrations that bring the schema up to date.

- SQLite by default, embedded, nothing to install: a file, in WAL mode (readers
  never wait for the writer), foreign keys on, a busy timeout so that
  concurrent writers queue instead of failing;
- PostgreSQL by a connection URL (``postgresql+psycopg://user@host/db``).

:func:`connect` brings the schema up to date with its migrations
(``monitor/store/migrations``, Alembic) before anything else.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import sqlalchemy as sa
from alembic import command
from alembic.config import Config
from sqlalchemy.engine import Engine

from monitor.errors import StoreError

__all__ = ["DEFAULT_URL_ENV", "PASSWORD_FILE_ENV", "POOL_OVERFLOW", "POOL_SIZE", "connect", "default_url"]

DEFAULT_URL_ENV = "ENGINE_MONITOR_DB"  # environment variable with the store's URL
#: Environment variable naming a file that holds the store's password (a container secret), for a URL
#: written without one; the password never has to appear in the URL, the environment or a command line.
PASSWORD_FILE_ENV = "ENGINE_MONITOR_DB_PASSWORD_FILE"
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


def connect(url: str | None = None) -> Engine:
    """The engine of the database at ``url``, its schema migrated to the newest.

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
    return engine
