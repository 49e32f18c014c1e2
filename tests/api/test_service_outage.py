"""The service when its surroundings fail: the store stopped and started again, the data folder full.

The machine's PostgreSQL is never stopped: the server's store URL goes through a loopback proxy
(:mod:`benchmarks.store_proxy`) that cuts every connection and refuses new ones, then listens again.
The data folder fills for real: a tmpfs of a few MiB mounted as it (skipped where mount is not
allowed). Longer series, with readers and uploaders at once: ``make bench-kill``
(benchmarks/service_kill.py).
"""

from __future__ import annotations

import subprocess
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from pathlib import Path

import httpx
import pytest

from benchmarks.store_proxy import StoreProxy, proxied
from monitor.io.hdf5 import read_hdf5, write_hdf5
from monitor.store import open_store
from tests.api.test_api import SAMPLES, Server
from tests.conftest import postgres_database, unavailable

SAMPLE = SAMPLES / "6l32-misfire-cyl3.h5"  # 1.3 MB, a bundled engine
OUTAGE_S = 3.0  # the store stopped this long: every kind of request meets it a few times


def _distinct(folder: Path, count: int, tag: str) -> list[Path]:
    """``count`` copies of the sample that differ by a note: each a new content, stored anew."""
    recording = read_hdf5(SAMPLE)
    paths = []
    for i in range(count):
        path = folder / f"{tag}-{i}.h5"
        write_hdf5(replace(recording, notes=f"{tag} {i}"), path)
        paths.append(path)
    return paths


def _upload(client: httpx.Client, path: Path) -> httpx.Response:
    return client.post("/recordings", params={"filename": path.name}, content=path.read_bytes())


@pytest.fixture
def through_proxy(tmp_path: Path) -> Iterator[tuple[Server, StoreProxy]]:
    """A server (one analysis process, a lease of 30 s) on a fresh PostgreSQL database, through a proxy."""
    with postgres_database() as url:
        store = open_store(url)
        keys = {"a": store.create_key(store.create_fleet("a"))}
        store.close()
        with proxied(url) as (proxy, proxied_url):
            server = Server("", proxied_url, tmp_path / "data", keys, extra=("--lease", "30"))
            server.start()
            try:
                yield server, proxy
            finally:
                server.kill()


def test_the_store_stopped_is_503_everywhere_and_the_service_recovers(
    through_proxy: tuple[Server, StoreProxy], tmp_path: Path
) -> None:
    """PostgreSQL "stopped" for 3 s (every connection cut, new ones refused), then back.

    While it is down every route and /health answer 503 ``store_unavailable`` with ``Retry-After``,
    on the same keep-alive connection (none closed unanswered), and an upload leaves no file behind.
    After it is back (and after a restart that cut the kept read connections, with no request
    between), every read answers at once, without a restart of the service; the analysis that ran
    across the outage is done once. The log holds one line when the outage began and one when it
    ended, and not one traceback."""
    server, proxy = through_proxy
    during, after = _distinct(tmp_path, 2, "outage")
    seen: list[str] = []  # what went wrong, every phase's, asserted empty at the end
    with server.client() as client:
        created = _upload(client, SAMPLE)
        assert created.status_code == 201, created.text
        recording = created.json()["id"]
        reads = [f"/recordings/{recording}", "/recordings", f"/recordings/{recording}/diagnosis"]

        def status(path: str) -> int:
            """A read's status, 0 for a connection closed without an answer."""
            try:
                return client.get(path).status_code
            except httpx.TransportError:
                return 0

        # a restart with no request in between: the connections the reads keep are all stale
        with ThreadPoolExecutor(8) as pool:  # 8 reads at once: 8 connections kept
            assert set(pool.map(status, reads * 8)) <= {200, 409}
        proxy.stop()
        proxy.start()
        with ThreadPoolExecutor(8) as pool:
            answers = list(pool.map(status, reads * 8))
        if not set(answers) <= {200, 409}:
            seen.append(f"reads after a restart answered {sorted(set(answers) - {200, 409})} (0: none)")

        # stopped for OUTAGE_S: every request answered 503, none left unanswered
        proxy.stop()
        stopped = time.monotonic()
        answered: list[httpx.Response] = []
        unanswered = 0
        uploads = 0
        while time.monotonic() - stopped < OUTAGE_S:
            for method, path in [("GET", "/health"), ("GET", "/engines"), *(("GET", r) for r in reads)]:
                try:
                    answered.append(client.request(method, path))
                except httpx.TransportError:
                    unanswered += 1
            try:
                answered.append(_upload(client, during))
                uploads += 1
            except httpx.TransportError:
                unanswered += 1
        if unanswered:
            seen.append(f"{unanswered} requests left without an answer while the store was down")
        assert uploads >= 1
        wrong = [
            f"{a.request.method} {a.request.url.path} {a.status_code} {a.text[:80]}"
            for a in answered
            if a.status_code != 503
            or a.json()["error"]["code"] != "store_unavailable"
            or int(a.headers.get("Retry-After", "0")) <= 0
        ]
        if wrong:
            seen.append(f"{len(wrong)} of {len(answered)} answers not 503 with Retry-After, e.g. {wrong[:3]}")
        kept = sorted(p.name for p in (server.data / "recordings").iterdir())
        if kept != [f"{created.json()['content_hash']}.h5"]:
            seen.append(f"files without a row after uploads in the outage: {len(kept) - 1}")
        assert list((server.data / "incoming").iterdir()) == []

        proxy.start()
        back = time.monotonic()
        while status("/health") != 200:
            assert time.monotonic() - back < 10, "the service did not recover without a restart"
            time.sleep(0.1)
        answers = [status(path) for path in reads]
        if not set(answers) <= {200, 409}:
            seen.append(f"reads once /health was back answered {answers} (0: none)")
        try:
            stored = _upload(client, after).status_code
        except httpx.TransportError:  # a connection the server closed: once more, on a new one
            seen.append("an upload once the store was back left without an answer")
            stored = _upload(client, after).status_code
        assert stored == 201
        deadline = time.monotonic() + 45  # the analysis takes seconds; a job lost would wait the lease
        while True:
            try:
                state = client.get(f"/recordings/{recording}").json()
            except httpx.TransportError:
                continue
            if state["status"] in ("done", "set_aside") or time.monotonic() > deadline:
                break
            time.sleep(0.2)
        if state["status"] != "done" or state["attempts"] != 1:
            seen.append(f"the analysis across the outage: {state['status']}, {state['attempts']} attempts")
    log = server.log.read_text(errors="replace")
    if log.count("Traceback"):
        seen.append(f"{log.count('Traceback')} tracebacks in the log")
    began, ended = log.count("store unreachable:"), log.count("store reachable again")
    if not 1 <= began <= 2 or began != ended:  # 2: the restart met by the worker's look at the queue
        seen.append(f"the log's lines of outages begun and ended: {began}, {ended}")
    assert not seen, "\n".join(seen)


def _mount_tmpfs(folder: Path, size: str) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    mounted = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(folder)], capture_output=True, text=True
    )
    if mounted.returncode != 0:
        unavailable(f"a small tmpfs cannot be mounted here as the data folder: {mounted.stderr.strip()}")


@pytest.fixture
def small_data_folder(tmp_path: Path) -> Iterator[Server]:
    """A server whose data folder is a tmpfs of 4 MiB (its store an SQLite file beside it), queuing only."""
    data = tmp_path / "data"
    _mount_tmpfs(data, "4m")
    try:
        url = f"sqlite:///{tmp_path / 'store.db'}"
        store = open_store(url)
        keys = {"a": store.create_key(store.create_fleet("a"))}
        store.close()
        server = Server("", url, data, keys, workers=0)
        server.start()
        try:
            yield server
        finally:
            server.kill()
    finally:
        subprocess.run(["umount", "-l", str(data)], check=False)


def test_a_full_data_folder_is_507_and_leaves_nothing_behind(
    small_data_folder: Server, tmp_path: Path
) -> None:
    """Distinct 0.94 MB recordings uploaded into a 4 MiB data folder until it is full: each is stored
    (201) or refused with 507 ``data_folder_full`` in the product's words, never a 500; no partial
    upload and no file without its row is left; /health says the data folder is full until it has
    room, then uploads are stored again, without a restart."""
    server = small_data_folder
    files = _distinct(tmp_path, 6, "full")  # 0.94 MB each, 5.6 MB: more than the folder holds
    seen: list[str] = []  # what went wrong, asserted empty at the end
    with server.client() as client:
        codes = []
        for path in files:
            try:
                answer = _upload(client, path)
            except httpx.TransportError as error:
                codes.append(0)
                seen.append(f"an upload left without an answer ({error})")
                continue
            codes.append(answer.status_code)
            if answer.status_code == 507:
                body = answer.json()["error"]
                if body["code"] != "data_folder_full" or "data folder is full" not in body["message"]:
                    seen.append(f"507 without the product's words: {answer.text}")
            elif answer.status_code != 201:
                seen.append(f"upload answered {answer.status_code}: {answer.text}")
        assert 201 in codes and set(codes) != {201}, codes
        stored = client.get("/recordings", params={"limit": 100}).json()["items"]
        assert len(stored) == codes.count(201)
        names = sorted(p.stem for p in (server.data / "recordings").iterdir())
        if names != sorted(r["content_hash"] for r in stored):
            seen.append(f"{len(names)} files in recordings/ for {len(stored)} rows")
        if list((server.data / "incoming").iterdir()):
            seen.append("a partial upload left in incoming/")
        health = client.get("/health")
        if health.status_code != 503 or "data_folder_full" not in health.text:
            seen.append(f"/health on a full data folder: {health.status_code} {health.text}")

        subprocess.run(["mount", "-o", "remount,size=64m", str(server.data)], check=True)
        assert client.get("/health").status_code == 200
        refused_before = files[codes.index(next(c for c in codes if c != 201))]
        assert _upload(client, refused_before).status_code == 201
    log = server.log.read_text(errors="replace")
    if log.count("Traceback"):
        seen.append(f"{log.count('Traceback')} tracebacks in the log")
    if log.count("full: uploads answer 507") != 1 or log.count("has room again") != 1:
        seen.append("not one log line when the data folder filled and one when it had room again")
    assert not seen, "\n".join(seen)


def test_store_faults_are_told_apart_from_the_statement_s_own_errors() -> None:
    """The driver's errors of a store that cannot serve (or whose disk is full) are told from errors of
    the statement itself, which stay faults of the service (500, with their traceback)."""
    import sqlite3

    import psycopg
    import sqlalchemy as sa

    from monitor.store.outage import store_fault

    def wrapped(error: Exception, kind: type[sa.exc.DBAPIError] = sa.exc.OperationalError) -> Exception:
        return kind("SELECT 1", {}, error)

    assert store_fault(wrapped(sqlite3.OperationalError("database is locked"))) == "unavailable"
    assert store_fault(wrapped(sqlite3.OperationalError("database or disk is full"))) == "full"
    assert store_fault(wrapped(sqlite3.OperationalError("no such table: recordings"))) is None
    assert store_fault(wrapped(psycopg.errors.AdminShutdown("terminating connection"))) == "unavailable"
    assert store_fault(wrapped(psycopg.OperationalError("connection refused"))) == "unavailable"
    assert store_fault(wrapped(psycopg.errors.DiskFull("could not extend file"))) == "full"
    unique = psycopg.errors.UniqueViolation("duplicate key")
    assert store_fault(wrapped(unique, sa.exc.IntegrityError)) is None
    assert store_fault(OSError("not the store's")) is None


def test_an_outage_is_logged_once_when_it_begins_and_once_when_it_ends(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """Many failures make one line; the first connection after makes one more; failures just after it
    ended are stragglers of that outage, not a new one."""
    import sqlalchemy as sa

    from monitor.store.outage import Outage

    outage = Outage()
    error = sa.exc.OperationalError("SELECT 1", {}, Exception("connection refused"))
    with caplog.at_level("INFO", logger="engine_monitor.store"):
        for _ in range(50):
            outage.failed(error)
        assert outage.down
        outage.back()
        outage.back()
        outage.failed(error)  # a request sent before the end
    lines = [record.getMessage() for record in caplog.records]
    assert len(lines) == 2 and not outage.down, lines
    assert lines[0].startswith("store unreachable: connection refused")
    assert "(50 failures meanwhile)" in lines[1]
