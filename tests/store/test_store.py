"""The results store on SQLite (embedded, WAL) and on the PostgreSQL server on loopback."""

from __future__ import annotations

import hashlib
import subprocess
import sys
import time
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from dataclasses import fields
from datetime import UTC, datetime, timedelta
from pathlib import Path

import pytest
import sqlalchemy as sa
from alembic import command
from alembic.autogenerate import compare_metadata
from alembic.config import Config
from alembic.migration import MigrationContext
from alembic.script import ScriptDirectory

import monitor.store
from monitor.cli import main
from monitor.diagnosis import ANALYSIS_VERSION
from monitor.errors import MonitorError, StoreError
from monitor.jobs.plots import plot_names
from monitor.store import MAX_ATTEMPTS, RecordingRow, Store, document_text, key_digest, open_store
from monitor.store.jobs import process_identity
from monitor.store.opening import PASSWORD_FILE_ENV, _with_password_file
from monitor.store.queries import JOB_COLUMNS, STORED, VIEWS, listing
from monitor.store.schema import jobs, metadata, recordings


@pytest.fixture
def store(store_url: str) -> Iterator[Store]:
    opened = open_store(store_url)
    try:
        yield opened
    finally:
        opened.close()


def _recording(store: Store, fleet: int, content: str = "a" * 64) -> int:
    row, _ = store.add_recording(
        fleet,
        content_hash=content,
        engine_id="man-b-w-7k98mc",
        filename="r.h5",
        path="/x/r.h5",
        size_bytes=10,
    )
    return row.id


def test_the_migrated_schema_is_the_declared_one(store: Store) -> None:
    """The migrations produce exactly the tables the code declares (Alembic's comparison finds nothing)."""
    with store.db.connect() as c:
        assert compare_metadata(MigrationContext.configure(c), metadata) == []


def test_opening_twice_migrates_once(store: Store) -> None:
    """A second opening finds the store at the newest revision (the migrations' head) and leaves it."""
    config = Config()
    config.set_main_option("script_location", str(Path(monitor.store.__file__).parent / "migrations"))
    head = ScriptDirectory.from_config(config).get_current_head()
    url = store.db.url.render_as_string(hide_password=False)
    again = open_store(url)
    try:
        with again.db.connect() as c:
            version = c.execute(sa.text("SELECT version_num FROM alembic_version")).scalar_one()
        assert version == head == "0009"
    finally:
        again.close()


def test_sqlite_runs_in_wal_mode(tmp_path: Path) -> None:
    store = open_store(f"sqlite:///{tmp_path / 's.db'}")
    try:
        with store.db.connect() as c:
            assert c.exec_driver_sql("PRAGMA journal_mode").scalar_one() == "wal"
            assert c.exec_driver_sql("PRAGMA foreign_keys").scalar_one() == 1
    finally:
        store.close()


def test_an_unreachable_database_is_a_clear_error() -> None:
    with pytest.raises(
        StoreError, match=r"store postgresql\+psycopg://nobody:\*\*\*@127.0.0.1:9/x: cannot be reached"
    ):
        open_store("postgresql+psycopg://nobody:secret@127.0.0.1:9/x")
    with pytest.raises(StoreError, match="store URL 'nonsense'"):
        open_store("nonsense")
    with pytest.raises(StoreError) as info:  # a password never shows in a message
        open_store("nosuchdriver://monitor:s3cret@host/db")
    assert "s3cret" not in str(info.value)


def test_keys_are_stored_hashed_and_name_their_fleet(store: Store) -> None:
    a, b = store.create_fleet("a"), store.create_fleet("b")
    key = store.create_key(a, "ci")
    assert store.fleet_of_key(key) == a and store.fleet_of_key(key + "x") is None
    with store.db.connect() as c:
        digests = [r.digest for r in c.execute(sa.text("SELECT digest FROM api_keys"))]
    assert digests == [key_digest(key)] and key not in digests
    assert store.fleet_of_key(store.create_key(b)) == b
    with pytest.raises(StoreError, match="fleet 'a' exists already"):
        store.create_fleet("a")


def test_keys_are_listed_without_themselves_and_revoked_at_once(store: Store) -> None:
    """Listed by id, fleet, label and time, filtered by fleet; a revoked key names no fleet from then
    on, and revoking it again (or an unknown id) reports False."""
    a, b = store.create_fleet("a"), store.create_fleet("b")
    first, second = store.create_key(a, "bridge"), store.create_key(b, "office")
    listed = store.list_keys()
    assert [(k.fleet, k.label) for k in listed] == [("a", "bridge"), ("b", "office")]
    assert [k.fleet for k in store.list_keys("b")] == ["b"]
    assert listed[0].created_at.tzinfo is not None
    assert store.revoke_key(listed[0].id)
    assert store.fleet_of_key(first) is None and store.fleet_of_key(second) == b
    assert not store.revoke_key(listed[0].id) and not store.revoke_key(10**6)


def test_the_same_content_is_stored_once_per_fleet(store: Store) -> None:
    a, b = store.create_fleet("a"), store.create_fleet("b")
    first = _recording(store, a)
    row, created = store.add_recording(
        a, content_hash="a" * 64, engine_id="man-b-w-7k98mc", filename="other.h5", path="/y", size_bytes=10
    )
    assert (row.id, created) == (first, False)
    assert _recording(store, b) != first  # another fleet's upload of the same bytes is its own
    assert store.recording(b, first) is None  # and another fleet's id is not found
    assert store.count("recordings") == 2


def test_recordings_are_listed_newest_first_by_engine_and_date(store: Store) -> None:
    fleet = store.create_fleet("a")
    ids = [_recording(store, fleet, f"{i:064d}") for i in range(5)]
    store.add_recording(
        fleet, content_hash="f" * 64, engine_id="other", filename="o", path="/o", size_bytes=1
    )
    listed = store.recordings(fleet, engine_id="man-b-w-7k98mc", limit=3)
    assert [r.id for r in listed] == ids[::-1][:3]
    assert [r.id for r in store.recordings(fleet, engine_id="man-b-w-7k98mc", offset=3)] == ids[1::-1]
    later = datetime.now(UTC) + timedelta(hours=1)
    assert store.recordings(fleet, since=later) == []


def test_a_job_runs_once_and_its_result_is_written_once(store: Store) -> None:
    """Claims are exclusive (eight threads race for one job), and completing twice keeps one result."""
    fleet = store.create_fleet("a")
    recording = _recording(store, fleet)
    job = store.enqueue(recording, "1")
    assert store.enqueue(recording, "1") == job
    with ThreadPoolExecutor(8) as pool:
        claims = list(pool.map(lambda _: store.claim_job(job.id), range(8)))
    taken = [c for c in claims if c is not None]
    assert len(taken) == 1 and taken[0].state == "running" and taken[0].attempts == 1
    store.complete(taken[0], {"diagnosis": ("alarm", {"status": "alarm"})})
    store.complete(taken[0], {"diagnosis": ("healthy", {"status": "healthy"})})
    assert store.count("results") == 1
    assert store.result(recording, "1", "diagnosis") == {"status": "alarm"}
    assert store.job(recording, "1").state == "done"  # type: ignore[union-attr]
    assert store.claim("1") is None


def test_a_failing_job_is_retried_then_set_aside(store: Store) -> None:
    fleet = store.create_fleet("a")
    recording = _recording(store, fleet)
    store.enqueue(recording, "1")
    states = []
    for _ in range(MAX_ATTEMPTS):
        job = store.claim("1")
        assert job is not None
        states.append(store.fail(job, "RuntimeError: boom", backoff=timedelta(0)))
    assert states == ["queued"] * (MAX_ATTEMPTS - 1) + ["set_aside"]
    final = store.job(recording, "1")
    assert final is not None and final.error == "RuntimeError: boom" and final.attempts == MAX_ATTEMPTS
    assert store.claim("1") is None


def test_a_passing_failure_waits_a_backoff_that_doubles(store: Store) -> None:
    """A transient failure queues the job again, not to be claimed before its backoff (doubled for
    each attempt after the first); a batch that names the job takes it all the same."""
    fleet = store.create_fleet("a")
    recording = _recording(store, fleet)
    store.enqueue(recording, "1")
    backoff = timedelta(seconds=0.5)
    waits = []
    for attempt in (1, 2):
        job = store.claim("1")
        assert job is not None and job.attempts == attempt
        before = datetime.now(UTC)
        assert store.fail(job, "OSError: disk full", backoff=backoff) == "queued"
        queued = store.job(recording, "1")
        assert queued is not None and queued.not_before is not None
        waits.append((queued.not_before - before).total_seconds())
        assert store.claim("1") is None  # not due yet
        time.sleep(max(0.0, (queued.not_before - datetime.now(UTC)).total_seconds()) + 0.05)
    # the clock between the fail and the reading above is all that separates them from 0.5 s and 1 s
    assert waits[0] == pytest.approx(0.5, abs=0.2) and waits[1] == pytest.approx(1.0, abs=0.2)
    job = store.claim("1")
    assert job is not None and job.not_before is None and job.attempts == 3
    store.fail(job, "OSError: disk full", backoff=timedelta(hours=1))  # the last attempt: set aside
    assert store.job(recording, "1").state == "set_aside"  # type: ignore[union-attr]
    other = _recording(store, fleet, "c" * 64)
    waiting = store.enqueue(other, "1")
    taken = store.claim_job(waiting.id)
    assert taken is not None
    store.fail(taken, "OSError: disk full", backoff=timedelta(hours=1))
    assert store.claim("1") is None and store.claim_job(waiting.id) is not None


def test_the_jobs_of_a_process_of_this_host_that_is_gone_are_taken_back_at_once(store: Store) -> None:
    """A taker names its process (host, id, start time): a restarted worker or batch takes back the jobs
    of a process that no longer runs without waiting for the lease; a live taker's are left alone,
    as are another host's until their lease runs out."""
    fleet = store.create_fleet("a")
    ids = [_recording(store, fleet, letter * 64) for letter in "abc"]
    for recording in ids:
        store.enqueue(recording, "1")
    taken = [store.claim("1") for _ in ids]
    assert all(job is not None for job in taken)
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True, check=True
    )
    holders = {
        ids[0]: process_identity(int(dead.stdout)),  # a process that ran here and ended
        ids[1]: process_identity(),  # this process: alive
        ids[2]: "another-host:1:12345",
    }
    with store.transaction() as c:
        for recording, holder in holders.items():
            c.execute(sa.update(jobs).where(jobs.c.recording_id == recording).values(holder=holder))
    assert store.requeue_stale("1", timedelta(hours=1)) == 1
    states = {recording: store.job(recording, "1").state for recording in ids}  # type: ignore[union-attr]
    assert states == {ids[0]: "queued", ids[1]: "running", ids[2]: "running"}


def test_jobs_whose_taker_went_silent_are_taken_back(store: Store) -> None:
    """A running job untouched for the lease is queued again (set aside after MAX_ATTEMPTS); a touched
    one is left to its taker; only the taker (by its token) completes or fails it."""
    fleet = store.create_fleet("a")
    first, second = _recording(store, fleet), _recording(store, fleet, "b" * 64)
    for recording in (first, second):
        store.enqueue(recording, "1")
    a, b = store.claim("1"), store.claim("1")
    assert a is not None and b is not None and a.token != b.token
    # the lease well apart from both: the first job untouched for a second, the second touched just
    # before (a loaded machine once took over 30 ms between the touch and the requeue)
    time.sleep(1.0)
    assert store.touch(b)
    assert store.requeue_stale("1", timedelta(seconds=0.5), recording_ids=[first, second]) == 1
    assert store.job(first, "1").state == "queued"  # type: ignore[union-attr]
    assert store.job(second, "1").state == "running"  # type: ignore[union-attr]
    # the silent taker of the first job wakes up: it can no longer touch, fail or complete it
    assert not store.touch(a)
    assert store.fail(a, "late") == "queued"
    again = store.claim("1")
    assert again is not None and again.recording_id == first and again.attempts == 2
    assert store.complete(a, {"diagnosis": ("healthy", {"by": "late"})}) is False  # its result is kept
    assert store.job(first, "1").state == "running"  # type: ignore[union-attr]  # still the new taker's
    assert store.complete(again, {"diagnosis": ("healthy", {"by": "again"})}) is True
    assert store.job(first, "1").state == "done"  # type: ignore[union-attr]
    assert store.result(first, "1", "diagnosis") == {"by": "late"} and store.count("results") == 1


def test_a_job_whose_worker_keeps_dying_is_set_aside(store: Store) -> None:
    fleet = store.create_fleet("a")
    recording = _recording(store, fleet)
    store.enqueue(recording, "1")
    for _ in range(MAX_ATTEMPTS):
        assert store.claim("1") is not None
        time.sleep(0.02)
        store.requeue_stale("1", timedelta(seconds=0.01))
    job = store.job(recording, "1")
    assert job is not None and job.state == "set_aside" and "stopped answering" in job.error


def test_concurrent_writers_store_one_row(store_url: str) -> None:
    """Eight processes add the same recording and create the same engine at once: one row each, no
    error (the unique keys decide, atomically)."""
    opened = open_store(store_url)
    fleet = opened.create_fleet("a")
    opened.close()
    with ProcessPoolExecutor(8) as pool:
        outcomes = list(pool.map(_add_same, [store_url] * 8, [fleet] * 8))
    assert sum(created for created, _ in outcomes) == 1 and sum(new for _, new in outcomes) == 1
    opened = open_store(store_url)
    try:
        assert opened.count("recordings") == 1 and opened.count("engines") == 1
    finally:
        opened.close()


def _add_same(url: str, fleet: int) -> tuple[bool, bool]:
    store = open_store(url)
    try:
        _, created = store.add_recording(
            fleet, content_hash="c" * 64, engine_id="e", filename="f.h5", path="/p", size_bytes=1
        )
        return created, store.put_engine(fleet, "e", {"id": "e"}, replace=False)
    finally:
        store.close()


def test_engines_are_created_and_updated(store: Store) -> None:
    fleet = store.create_fleet("a")
    assert store.put_engine(fleet, "e1", {"id": "e1", "cylinders": 6}) is True
    assert store.put_engine(fleet, "e1", {"id": "e1", "cylinders": 7}) is False
    assert store.engine(fleet, "e1") == {"id": "e1", "cylinders": 7}
    assert store.engines(fleet) == ["e1"] and store.engine(store.create_fleet("b"), "e1") is None


def test_a_baseline_is_one_per_fleet_and_engine_replaced_whole_and_never_another_fleet_s(
    store: Store,
) -> None:
    """A baseline is stored for the fleet's recording of the same engine, read back as it was written,
    replaced by the next, and invisible to another fleet; a recording of another fleet or another engine
    is refused with a message naming it, and nothing is stored."""
    a, b = store.create_fleet("a"), store.create_fleet("b")
    first, second = _recording(store, a, "1" * 64), _recording(store, a, "2" * 64)
    theirs = _recording(store, b, "3" * 64)
    other_engine, _ = store.add_recording(
        a, content_hash="4" * 64, engine_id="medium-speed-6l32", filename="o.h5", path="/x/o.h5", size_bytes=1
    )
    document = {"format": "test", "sensors": {"mb2-vertical": [1.5, -2.0]}, "speed_rpm": 104.0}
    assert store.baseline(a, "man-b-w-7k98mc") is None
    written = store.put_baseline(a, "man-b-w-7k98mc", first, "v1", document)
    read = store.baseline(a, "man-b-w-7k98mc")
    assert read is not None and read.document == document and read.recording_id == first
    assert (read.engine_id, read.analysis_version) == (written.engine_id, written.analysis_version)
    assert store.baseline(b, "man-b-w-7k98mc") is None
    store.put_baseline(a, "man-b-w-7k98mc", second, "v2", {**document, "speed_rpm": 90.0})
    replaced = store.baseline(a, "man-b-w-7k98mc")
    assert replaced is not None and (replaced.recording_id, replaced.analysis_version) == (second, "v2")
    assert replaced.document["speed_rpm"] == 90.0 and store.count("baselines") == 1
    with pytest.raises(StoreError, match=f"recording {theirs}: expected a recording of engine"):
        store.put_baseline(a, "man-b-w-7k98mc", theirs, "v3", document)
    with pytest.raises(StoreError, match="found one of engine 'medium-speed-6l32'"):
        store.put_baseline(a, "man-b-w-7k98mc", other_engine.id, "v3", document)
    assert store.baseline(a, "man-b-w-7k98mc") == replaced and store.count("baselines") == 1


def test_a_key_s_fleet_is_found_by_its_digest(store: Store) -> None:
    a = store.create_fleet("a")
    key = store.create_key(a)
    assert store.fleet_of_digest(key_digest(key)) == a == store.fleet_of_key(key)
    assert store.fleet_of_digest(key_digest(key + "x")) is None


def test_the_password_comes_from_a_secrets_file_when_the_url_has_none(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A container's secret: $ENGINE_MONITOR_DB_PASSWORD_FILE names a file with the password, so that
    it never appears in the URL, the environment or a command line."""
    secret = tmp_path / "db_password"
    secret.write_text("s3cr:et@\n")
    url = "postgresql+psycopg://monitor@postgres:5432/monitor"
    assert _with_password_file(url) == url  # no file named: the URL as given
    monkeypatch.setenv(PASSWORD_FILE_ENV, str(secret))
    with_password = _with_password_file(url)
    assert isinstance(with_password, sa.URL) and with_password.password == "s3cr:et@"
    assert (
        with_password.render_as_string(hide_password=True)
        == "postgresql+psycopg://monitor:***@postgres:5432/monitor"
    )
    given = "postgresql+psycopg://monitor:other@postgres:5432/monitor"
    assert _with_password_file(given) == given  # a password in the URL wins
    assert _with_password_file("sqlite:///x.db") == "sqlite:///x.db"
    monkeypatch.setenv(PASSWORD_FILE_ENV, str(tmp_path / "missing"))
    with pytest.raises(StoreError, match=r"ENGINE_MONITOR_DB_PASSWORD_FILE.*missing: cannot read"):
        _with_password_file(url)


# --------------------------------------------------------------------------------------------- reads
def test_the_reads_indexes_exist_and_the_listing_uses_its_own(store: Store) -> None:
    """Migration 0004: the listing's index (fleet, upload time, id), in the order of GET /recordings,
    and the plan of a listing page (keyset or not) reads it instead of sorting the fleet's rows. The
    other reads are by unique keys (a key's digest; a job or a result by recording and version)."""
    inspector = sa.inspect(store.db)
    indexes = {i["name"]: i["column_names"] for i in inspector.get_indexes("recordings")}
    assert indexes["ix_recordings_fleet_uploaded"] == ["fleet_id", "uploaded_at", "id"]
    assert {"digest"} <= {c["name"] for c in inspector.get_columns("results")}
    unique = {
        table: [u["column_names"] for u in inspector.get_unique_constraints(table)]
        for table in ("api_keys", "jobs", "results")
    }
    assert ["digest"] in unique["api_keys"]
    assert ["recording_id", "analysis_version"] in unique["jobs"]
    assert ["recording_id", "analysis_version", "kind"] in unique["results"]
    fleet = store.create_fleet("a")
    for i in range(20):
        _recording(store, fleet, f"{i:064d}")
    page = (
        "SELECT id FROM recordings WHERE fleet_id = 1 AND (uploaded_at, id) < ({now}, 1000) "
        "ORDER BY uploaded_at DESC, id DESC LIMIT 51"
    )
    with store.db.connect() as c:
        if store.dialect == "sqlite":
            plan = c.exec_driver_sql("EXPLAIN QUERY PLAN " + page.format(now="'9999-01-01'")).all()
            text = " ".join(str(row[-1]) for row in plan)
            assert "ix_recordings_fleet_uploaded" in text and "TEMP B-TREE" not in text, text
        else:  # a table this small is scanned unless scans are off: the index must serve the query
            c.exec_driver_sql("SET enable_seqscan = off")
            plan = c.exec_driver_sql("EXPLAIN " + page.format(now="now()")).all()
            text = " ".join(str(row[0]) for row in plan)
            assert "ix_recordings_fleet_uploaded" in text and "Sort" not in text, text


def test_a_result_is_read_as_the_text_stored_with_its_digest(store: Store) -> None:
    """The text a read hands out is the column's own text, byte for byte (read back with plain SQL),
    tagged by the SHA-256 written with it; the job comes in the same query; another fleet's recording
    is not found."""
    a, b = store.create_fleet("a"), store.create_fleet("b")
    recording = _recording(store, a)
    job = store.enqueue(recording, "1")
    pending = store.stored_result(a, recording, "1", "spectrum")
    assert pending is not None and pending.result is None and pending.job is not None
    assert pending.job.state == "queued"
    document = {"status": "alarm", "orders": [0.5, 1.0, 1e-300], "name": "Zylinder 4 – Aussetzer", "n": None}
    taken = store.claim_job(job.id)
    assert taken is not None
    store.complete(taken, {"spectrum": ("alarm", document)})
    read = store.stored_result(a, recording, "1", "spectrum")
    assert read is not None and read.result is not None and read.job is not None and read.job.state == "done"
    with store.db.connect() as c:
        stored = c.exec_driver_sql(
            f"SELECT CAST(document AS TEXT), digest FROM results WHERE recording_id = {recording}"
        ).one()
    assert read.result.text == stored[0] == document_text(document)
    assert read.result.digest == stored[1] == hashlib.sha256(stored[0].encode("utf-8")).hexdigest()
    assert store.result(recording, "1", "spectrum") == document  # parsed, it is the document written
    assert store.stored_result(b, recording, "1", "spectrum") is None
    assert store.stored_result(a, recording + 1, "1", "spectrum") is None
    view = store.recording_view(a, recording, "1")
    assert view is not None and view.diagnosis_status == "" and view.job is not None
    assert store.recording_view(b, recording, "1") is None
    assert store.jobs_by_state("1") == {"done": 1}


def test_the_migration_tags_results_stored_before_it_and_changes_none(store_url: str) -> None:
    """A store at revision 0003 with a result in it: opening it migrates to 0004, which writes the
    digest of the result's stored text and leaves the text as it was."""
    engine = sa.create_engine(store_url)
    config = Config()
    config.set_main_option("script_location", str(Path(__file__).parents[2] / "monitor/store/migrations"))
    with engine.begin() as connection:
        config.attributes["connection"] = connection
        command.upgrade(config, "0003")
    text = '{"status": "warning", "note": "stored before 0004"}'
    now = datetime.now(UTC)
    with engine.begin() as c:
        c.execute(sa.text("INSERT INTO fleets (name, created_at) VALUES ('a', :t)"), {"t": now})
        c.execute(
            sa.text(
                "INSERT INTO recordings (fleet_id, content_hash, engine_id, filename, path, size_bytes, "
                "recorded_at, uploaded_at) VALUES (1, :h, 'e', 'r.h5', '/r.h5', 1, '', :t)"
            ),
            {"h": "a" * 64, "t": now},
        )
        c.execute(
            sa.text(
                "INSERT INTO results (recording_id, analysis_version, kind, status, document, created_at) "
                "VALUES (1, '1', 'diagnosis', 'warning', :d, :t)"
            ),
            {"d": text, "t": now},
        )
    engine.dispose()
    store = open_store(store_url)
    try:
        read = store.stored_result(1, 1, "1", "diagnosis")
        assert read is not None and read.result is not None
        assert read.result.text == text
        with store.db.connect() as c:
            assert (
                c.exec_driver_sql("SELECT digest FROM results").scalar_one()
                == hashlib.sha256(text.encode("utf-8")).hexdigest()
            )
    finally:
        store.close()


def test_every_name_a_content_is_given_is_kept_once_and_read_by_its_fleet_alone(store: Store) -> None:
    """One content given under three names (one of them twice) is one recording that keeps each name
    once, in the order given, the first the registered one; another fleet reads none of them."""
    a, b = store.create_fleet("a"), store.create_fleet("b")
    first = _recording(store, a)  # as r.h5
    for name in ("copy-2.h5", "r.h5", "Copy 3.h5"):
        row, created = store.add_recording(
            a, content_hash="a" * 64, engine_id="man-b-w-7k98mc", filename=name, path="/y", size_bytes=10
        )
        assert (row.id, row.filename, created) == (first, "r.h5", False)
    assert store.recording_names(a, [first, first + 100]) == {first: ["r.h5", "copy-2.h5", "Copy 3.h5"]}
    assert store.recording_names(b, [first]) == {}
    assert store.count("recordings") == 1 and store.count("recording_names") == 3


def test_a_diagnosis_records_its_plot_which_its_fleet_alone_reads(store: Store) -> None:
    """The plot file a diagnosis kept is recorded with it (not with the spectrum), read by the
    recording's id and fleet; a file outside the data folder's plots/ is refused and nothing stored."""
    a, b = store.create_fleet("a"), store.create_fleet("b")
    recording = _recording(store, a)
    job = store.claim_job(store.enqueue(recording, "1").id)
    assert job is not None and store.plot(a, recording, "1") is None  # no diagnosis yet
    documents = {"diagnosis": ("alarm", {"status": "alarm"}), "spectrum": ("alarm", {})}
    for outside in ("../engine-monitor.db", "plots/../x.png", "/etc/passwd", "plots/a/b.png", "plots/"):
        with pytest.raises(StoreError, match="expected a file name under plots/"):
            store.complete(job, documents, plot=outside)
    assert store.count("results") == 0
    assert store.complete(job, documents, plot="plots/r-v1.png")
    assert store.plot(a, recording, "1") == "plots/r-v1.png"
    assert store.plot(b, recording, "1") is None and store.plot(a, recording, "2") is None
    with store.db.connect() as c:
        kept = dict(c.exec_driver_sql("SELECT kind, plot FROM results").all())
    assert kept == {"diagnosis": "plots/r-v1.png", "spectrum": None}


def test_the_migration_keeps_each_recording_s_name_and_records_the_plots_named_before_it(
    store_url: str,
) -> None:
    """A store at revision 0006 with three recordings, two of one stem (compared ignoring case), each
    diagnosed: opening it migrates to 0008, which keeps each recording's name and records each
    diagnosis' plot under the name the batch and the worker gave it until then (the rule of
    monitor.jobs.plots.plot_names, an independent copy of which the migration froze), none for a spectrum."""
    engine = sa.create_engine(store_url)
    config = Config()
    config.set_main_option("script_location", str(Path(__file__).parents[2] / "monitor/store/migrations"))
    with engine.begin() as connection:
        config.attributes["connection"] = connection
        command.upgrade(config, "0006")
    files = {1: "night.h5", 2: "NIGHT.mcap", 3: "other night.h5"}
    now = datetime.now(UTC)
    with engine.begin() as c:
        c.execute(sa.text("INSERT INTO fleets (name, created_at) VALUES ('a', :t)"), {"t": now})
        for recording_id, name in files.items():
            c.execute(
                sa.text(
                    "INSERT INTO recordings (id, fleet_id, content_hash, engine_id, filename, path, "
                    "size_bytes, recorded_at, uploaded_at) VALUES (:i, 1, :h, 'e', :n, '/r', 1, '', :t)"
                ),
                {"i": recording_id, "h": f"{recording_id:064d}", "n": name, "t": now},
            )
            for kind in ("diagnosis", "spectrum"):
                c.execute(
                    sa.text(
                        "INSERT INTO results (recording_id, analysis_version, kind, status, document, "
                        "created_at) VALUES (:i, '7', :k, 'healthy', '{}', :t)"
                    ),
                    {"i": recording_id, "k": kind, "t": now},
                )
    engine.dispose()
    store = open_store(store_url)
    try:
        assert store.recording_names(1, list(files)) == {i: [name] for i, name in files.items()}
        names = plot_names(files.items())
        assert {i: store.plot(1, i, "7") for i in files} == {
            i: f"plots/{names[i].removesuffix(f'-v{ANALYSIS_VERSION}.png')}-v7.png" for i in files
        }
        assert store.plot(1, 2, "7") == "plots/NIGHT+2-v7.png"
        with store.db.connect() as c:
            assert (
                c.exec_driver_sql("SELECT plot FROM results WHERE kind = 'spectrum'").scalars().all()
                == [None] * 3
            )
    finally:
        store.close()


def test_keyset_pages_list_every_recording_once_in_order_even_at_equal_times(store: Store) -> None:
    """Pages after the last row of the previous one give the same rows as the whole listing, in the
    same order, each once; recordings uploaded at the same instant are ordered by id."""
    fleet = store.create_fleet("a")
    other = store.create_fleet("b")
    ids = [_recording(store, fleet, f"{i:064d}") for i in range(12)]
    _recording(store, other, "e" * 64)
    with store.transaction() as c:  # a third of them at one instant
        c.execute(
            sa.update(recordings).where(recordings.c.id.in_(ids[3:7])).values(uploaded_at=datetime.now(UTC))
        )
    whole = [r.id for r in store.recordings(fleet, limit=100)]
    paged: list[int] = []
    after = None
    while page := store.recordings(fleet, after=after, limit=5):
        paged += [r.id for r in page]
        after = (page[-1].uploaded_at, page[-1].id)
    assert paged == whole and sorted(paged) == sorted(ids)
    first = store.recordings(fleet, limit=5)[-1]
    views = store.recording_views(fleet, "1", after=(first.uploaded_at, first.id), limit=100)
    assert [v.recording.id for v in views] == whole[5:]


def test_rows_are_read_by_position_in_the_order_the_store_declares() -> None:
    """The store reads a recording's row by position (a listing page is read that way, several
    times faster than by name): the table's columns are RecordingRow's fields, in order, and the
    joined reads put the job's columns right after them."""
    assert [c.name for c in recordings.c] == [f.name for f in fields(RecordingRow)]
    jobs_at = len(recordings.c)
    for query in (VIEWS, STORED, listing(True, True, True, True, True)):
        names = [c.name for c in query.selected_columns]
        assert names[:jobs_at] == [c.name for c in recordings.c]
        assert names[jobs_at : jobs_at + len(JOB_COLUMNS)] == [c.name for c in JOB_COLUMNS]
    assert [c.name for c in listing(False, False, False, False, False).selected_columns] == [
        c.name for c in recordings.c
    ]


def test_reads_on_kept_connections_see_every_write_and_outlive_a_dropped_connection(store: Store) -> None:
    """The reads' kept connections (monitor.store.pool) hold no snapshot between reads: a key
    revoked and a job's new state are seen by the next read on the same connection. On PostgreSQL, a
    kept connection the server ends (as a restart would) costs that read one retry, not an error."""
    fleet = store.create_fleet("a")
    key = store.create_key(fleet)
    recording, _ = store.add_recording(
        fleet, content_hash="c" * 64, engine_id="e", filename="f.h5", path="p", size_bytes=1, recorded_at=""
    )
    assert store.fleet_of_key(key) == fleet
    view = store.recording_view(fleet, recording.id, "v1")
    assert view is not None and view.job is None
    store.enqueue(recording.id, "v1")
    view = store.recording_view(fleet, recording.id, "v1")
    assert view is not None and view.job is not None and view.job.state == "queued"
    assert store.revoke_key(max(k.id for k in store.list_keys("a")))
    assert store.fleet_of_key(key) is None
    if store.dialect == "postgresql":
        with store.db.connect() as admin:
            ended = admin.execute(
                sa.text(
                    "SELECT count(*) FROM (SELECT pg_terminate_backend(pid) FROM pg_stat_activity "
                    "WHERE datname = current_database() AND pid <> pg_backend_pid()) AS ended"
                )
            ).scalar_one()
        assert ended >= 1  # the kept reader, at least
    assert [v.recording.id for v in store.recording_views(fleet, "v1")] == [recording.id]
    assert store.recording_view(fleet, recording.id, "v1") is not None


def test_a_summary_says_what_a_view_says_in_every_state_of_the_analysis(store: Store) -> None:
    """The listing's flat summaries (RecordingSummary) against the views they stand in for: no job,
    queued, queued again after a passing failure (a retry time), running, done (the diagnosis'
    status), set aside; one by id and a page, newest first."""
    fleet = store.create_fleet("a")
    ids = [_recording(store, fleet, content * 64) for content in "abcdef"]
    for recording in ids[1:]:
        store.enqueue(recording, "1")
    for recording in ids[2:]:  # ids[1] stays queued
        job = store.claim_job(store.job(recording, "1").id)  # type: ignore[union-attr]
        assert job is not None
        if recording == ids[2]:
            store.fail(job, "OSError: disk full", backoff=timedelta(hours=1))
        elif recording == ids[4]:
            store.complete(job, {"diagnosis": ("warning", {"status": "warning"})})
        elif recording == ids[5]:
            store.fail(job, "MonitorError: not a recording", permanent=True)
    views = store.recording_views(fleet, "1")
    summaries = store.recording_summaries(fleet, "1")
    assert [s.id for s in summaries] == [v.recording.id for v in views] == ids[::-1]
    for view, summary in zip(views, summaries, strict=True):
        row, job = view.recording, view.job
        assert summary == (
            row.id,
            row.engine_id,
            row.filename,
            row.content_hash,
            row.size_bytes,
            row.recorded_at,
            row.uploaded_at,
            job.state if job is not None else "none",
            job.attempts if job is not None else 0,
            job.error if job is not None else "",
            job.not_before if job is not None and job.state == "queued" else None,
            view.diagnosis_status,
        )
        assert store.recording_summary(fleet, row.id, "1") == summary
    states = {s.id: (s.status, s.diagnosis_status, s.retry_after is not None) for s in summaries}
    assert states == {
        ids[0]: ("none", "", False),
        ids[1]: ("queued", "", False),
        ids[2]: ("queued", "", True),
        ids[3]: ("running", "", False),
        ids[4]: ("done", "warning", False),
        ids[5]: ("set_aside", "", False),
    }
    assert store.recording_summary(store.create_fleet("b"), ids[0], "1") is None


#: Fleet names and key labels that are not printable names: empty, white space, a tab, a right-to-left
#: override (which makes a name display as another), a zero-width space, padding, 5000 characters.
BAD_NAMES = ["", " ", "\t", "a\u202eb", "a\u200bb", " fleet", "fleet ", "x" * 5000]


@pytest.mark.parametrize("bad", BAD_NAMES, ids=repr)
def test_a_fleet_name_or_key_label_that_is_not_a_printable_name_is_refused_and_nothing_stored(
    store_url: str, bad: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """The same refusal on both stores (PostgreSQL's column limit no longer decides, with a DataError
    'of engine-monitor'), from the store and from ``keys create`` (exit 2, one line, no traceback),
    before anything is written: no fleet made for a key whose label is refused."""
    store = open_store(store_url)
    try:
        for option in (
            (["--fleet", bad], ["--fleet", "other", "--label", bad]) if bad else (["--fleet", bad],)
        ):
            assert main(["keys", "create", *option, "--store", store_url]) == 2
            said = capsys.readouterr()
            assert said.out == "" and "Traceback" not in said.err and "unexpected" not in said.err
            assert f"{option[-2]} " in said.err and "printable characters" in said.err, said.err
        with pytest.raises(MonitorError, match="expected 1 to 200 printable characters"):
            store.create_fleet(bad)
        if bad:  # an empty label is no label
            with pytest.raises(MonitorError, match="key label"):
                store.create_key(store.create_fleet("good"), bad)
        with store.db.connect() as c:
            fleets = c.execute(sa.text("SELECT name FROM fleets")).scalars().all()
        assert fleets == (["good"] if bad else [])
        assert store.list_keys() == []
    finally:
        store.close()


def test_a_revoked_key_s_id_is_never_given_to_a_later_key(store: Store) -> None:
    """On SQLite a plain integer key reused the largest id once its row was deleted: ``keys revoke 2``
    written down for the old key would revoke the new one. PostgreSQL's sequences never reuse."""
    fleet = store.create_fleet("a")
    store.create_key(fleet, "first")
    store.create_key(fleet, "second")
    old = [k.id for k in store.list_keys()]
    assert store.revoke_key(old[-1])
    store.create_key(fleet, "third")
    new = [k.id for k in store.list_keys()][-1]
    assert new not in old, (old, new)


def test_migration_0007_keeps_every_key_and_its_id(store_url: str) -> None:
    """A store at 0006 with three keys: opened, it is at 0007 with the same keys, ids and digests, and
    the next key after revoking the newest does not take its id."""
    engine = sa.create_engine(store_url)
    config = Config()
    config.set_main_option("script_location", str(Path(__file__).parents[2] / "monitor/store/migrations"))
    with engine.begin() as connection:
        config.attributes["connection"] = connection
        command.upgrade(config, "0006")
    now = datetime.now(UTC)
    with engine.begin() as c:
        c.execute(sa.text("INSERT INTO fleets (name, created_at) VALUES ('a', :t)"), {"t": now})
        for i in (1, 2, 3):
            c.execute(
                sa.text("INSERT INTO api_keys (fleet_id, digest, label, created_at) VALUES (1, :d, :l, :t)"),
                {"d": f"{i}" * 64, "l": f"key {i}", "t": now},
            )
    engine.dispose()
    store = open_store(store_url)
    try:
        with store.db.connect() as c:
            kept = c.execute(sa.text("SELECT id, digest, label FROM api_keys ORDER BY id")).all()
        assert [tuple(r) for r in kept] == [(i, f"{i}" * 64, f"key {i}") for i in (1, 2, 3)]
        assert store.revoke_key(3)
        store.create_key(1)
        assert [k.id for k in store.list_keys()] == [1, 2, 4]
    finally:
        store.close()
