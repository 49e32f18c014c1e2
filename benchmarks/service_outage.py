"""The service while its store stops and its data folder fills, under reads and uploads (``make bench-kill``).

Two runs, each on a server started once and never restarted, with readers and uploaders at once
(client threads on loopback):

- the store stopped: PostgreSQL through a loopback proxy (:mod:`benchmarks.store_proxy`; the machine's
  server itself is never stopped), cut for ``outage_s`` (every connection closed, new ones refused),
  then back, ``cycles`` times;
- the data folder full: a tmpfs of a few MiB mounted as it (skipped, saying why, where mount is not
  allowed), filled by the uploads until they are refused, then grown (``mount -o remount``).

Counted: answers by kind (503 and 507 are the expected answers of a dependency down; any other 5xx
must be 0), requests left without an answer, tracebacks in answers and in the server's log, files in
the data folder without their row, partial uploads left, jobs lost or run twice, and whether the
service answered again without a restart. :func:`outage_section` and :func:`disk_full_section`
write their sections of docs/service.md.
"""

from __future__ import annotations

import subprocess
import tempfile
import threading
import time
from collections import Counter
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path
from typing import Any

import httpx
import sqlalchemy as sa

from benchmarks.service_load import base_recordings, free_port, postgres_database, start_monitor
from benchmarks.store_proxy import proxied
from monitor.diagnosis import ANALYSIS_VERSION
from monitor.io.hdf5 import write_hdf5
from monitor.store import open_store

__all__ = ["DiskTally", "OutageTally", "disk_full_run", "disk_full_section", "outage_run", "outage_section"]

READERS, UPLOADERS = 4, 2
STEADY_S = 5.0  # reads and uploads before each cut and after the service is healthy again [s]
HEALTHY_S = 60.0  # longest wait for /health to answer 200 again after a cut [s]
FINISH_S = 240.0  # longest wait for every stored recording's analysis after the last cycle [s]


@dataclass
class OutageTally:
    """What the store-outage run found."""

    cycles: int = 0
    outage_s: float = 0.0
    answers: Counter[str] = field(default_factory=Counter)  # "2xx", "4xx", "503", "507", "other 5xx"
    unanswered: int = 0
    tracebacks_answered: int = 0
    tracebacks_logged: int = 0
    outage_lines: int = 0  # "store unreachable" lines in the log
    uploads_stored: int = 0
    files_without_rows: int = 0
    jobs_lost: int = 0
    jobs_run_twice: int = 0
    recovered: int = 0  # cycles after which /health answered 200 again, the same server process
    back_s: list[float] = field(default_factory=list)
    skipped: str = ""


@dataclass
class DiskTally:
    """What the disk-full run found."""

    size_mib: int = 0
    answers: Counter[str] = field(default_factory=Counter)
    unanswered: int = 0
    tracebacks_answered: int = 0
    tracebacks_logged: int = 0
    uploads_stored: int = 0
    parts_left: int = 0
    files_without_rows: int = 0
    health_while_full: str = ""
    recovered: bool = False
    skipped: str = ""


def _kind(status: int) -> str:
    if status in (503, 507):
        return str(status)
    return "other 5xx" if status >= 500 else f"{status // 100}xx"


class _Load:
    """Readers and uploaders against a server until stopped, counting what they are answered."""

    def __init__(self, url: str, key: str, folder: Path, bases: list[Any]) -> None:
        self.url, self.key, self.folder, self.bases = url, key, folder, bases
        self.answers: Counter[str] = Counter()
        self.uploads: Counter[str] = Counter()  # the uploads' answers alone
        self.unanswered = 0
        self.tracebacks = 0
        self.stored: list[int] = []
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._threads = [threading.Thread(target=self._read, daemon=True) for _ in range(READERS)] + [
            threading.Thread(target=self._upload, args=(i,), daemon=True) for i in range(UPLOADERS)
        ]

    def __enter__(self) -> _Load:
        for thread in self._threads:
            thread.start()
        return self

    def __exit__(self, *_: object) -> None:
        self._stop.set()
        for thread in self._threads:
            thread.join(60)

    def _count(self, send: Any) -> httpx.Response | None:
        try:
            answer: httpx.Response = send()
        except httpx.TransportError:
            with self._lock:
                self.unanswered += 1
            return None
        with self._lock:
            self.answers[_kind(answer.status_code)] += 1
            self.tracebacks += "Traceback" in answer.text
        return answer

    def _read(self) -> None:
        with httpx.Client(base_url=self.url, headers={"X-API-Key": self.key}, timeout=60) as client:
            n = 0
            while not self._stop.is_set():
                some = self.stored[-1] if self.stored else 1
                path = ("/health", "/recordings", f"/recordings/{some}", f"/recordings/{some}/diagnosis")[
                    n % 4
                ]
                self._count(partial(client.get, path))
                n += 1
                time.sleep(0.02)

    def _upload(self, uploader: int) -> None:
        path = self.folder / f"uploader-{uploader}.h5"
        n = 0
        with httpx.Client(base_url=self.url, headers={"X-API-Key": self.key}, timeout=120) as client:
            while not self._stop.is_set():
                # a new note: new content, validated, stored and analysed anew
                write_hdf5(replace(self.bases[uploader], notes=f"outage run: uploader {uploader}, {n}"), path)
                n += 1
                body = path.read_bytes()
                answer = self._count(
                    partial(client.post, "/recordings", params={"filename": path.name}, content=body)
                )
                with self._lock:
                    self.uploads["no answer" if answer is None else _kind(answer.status_code)] += 1
                if answer is not None and answer.status_code == 201:
                    with self._lock:
                        self.stored.append(int(answer.json()["id"]))
                elif answer is None or answer.status_code >= 500:
                    self._stop.wait(0.5)


def _healthy_within(url: str, seconds: float) -> float | None:
    started = time.monotonic()
    while time.monotonic() - started < seconds:
        try:
            if httpx.get(f"{url}/health", timeout=5).status_code == 200:
                return time.monotonic() - started
        except httpx.TransportError:
            pass
        time.sleep(0.1)
    return None


def _files_without_rows(data: Path, store_url: str) -> int:
    store = open_store(store_url)
    try:
        return sum(not store.content_stored(path.stem) for path in (data / "recordings").iterdir())
    finally:
        store.close()


def _stop(process: subprocess.Popen[bytes]) -> None:
    if process.poll() is None:
        process.terminate()
        try:
            process.wait(10)
        except subprocess.TimeoutExpired:
            process.kill()


def outage_run(postgres: str, cycles: int, outage_s: float) -> OutageTally:
    """The store stopped ``cycles`` times for ``outage_s`` [s] under readers and uploaders."""
    tally = OutageTally(cycles=cycles, outage_s=outage_s)
    database = postgres_database(postgres)
    if database is None:
        tally.skipped = f"no PostgreSQL server answered at {postgres}"
        return tally
    url_db, drop = database
    try:
        with tempfile.TemporaryDirectory() as scratch, proxied(url_db) as (proxy, through):
            folder = Path(scratch)
            store = open_store(url_db)
            key = store.create_key(store.create_fleet("fleet"))
            store.close()
            data, log = folder / "data", folder / "service.log"
            port = free_port()
            url = f"http://127.0.0.1:{port}"
            serve = ["serve", "--port", str(port), "--store", through, "--data", str(data), "--workers", "1"]
            server = start_monitor([*serve, "--no-access-log"], log)
            try:
                if _healthy_within(url, HEALTHY_S) is None:
                    raise RuntimeError(f"the server did not start (see {log})")
                with _Load(url, key, folder, base_recordings(UPLOADERS)) as load:
                    for _ in range(cycles):
                        time.sleep(STEADY_S)
                        proxy.stop()
                        time.sleep(outage_s)
                        proxy.start()
                        back = _healthy_within(url, HEALTHY_S)
                        if back is not None and server.poll() is None:
                            tally.recovered += 1
                            tally.back_s.append(back)
                        time.sleep(STEADY_S)
                tally.answers, tally.unanswered = load.answers, load.unanswered
                tally.tracebacks_answered, tally.uploads_stored = load.tracebacks, len(load.stored)
                deadline = time.monotonic() + FINISH_S
                store = open_store(url_db)
                try:
                    while time.monotonic() < deadline:
                        states = store.jobs_by_state(_version())
                        if not states.get("queued") and not states.get("running"):
                            break
                        time.sleep(1)
                    rows = store.count("recordings")
                    with store.db.connect() as c:
                        done = c.execute(
                            sa.text("SELECT count(*) FROM jobs WHERE state = 'done'")
                        ).scalar_one()
                        twice = c.execute(
                            sa.text("SELECT count(*) FROM jobs WHERE attempts > 1")
                        ).scalar_one()
                    tally.jobs_lost = rows - int(done)
                    tally.jobs_run_twice = int(twice)
                finally:
                    store.close()
                tally.files_without_rows = _files_without_rows(data, url_db)
            finally:
                _stop(server)
            text = log.read_text(errors="replace")
            tally.tracebacks_logged = text.count("Traceback")
            tally.outage_lines = text.count("store unreachable:")
    finally:
        drop()
    return tally


def _version() -> str:
    return ANALYSIS_VERSION


def disk_full_run(size_mib: int, refused: int) -> DiskTally:
    """Distinct recordings uploaded into a data folder of ``size_mib`` [MiB], readers at once, until
    ``refused`` uploads were refused for lack of room; then the folder grown, and one more upload."""
    tally = DiskTally(size_mib=size_mib)
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        data = folder / "data"
        data.mkdir()
        mounted = subprocess.run(
            ["mount", "-t", "tmpfs", "-o", f"size={size_mib}m", "tmpfs", str(data)],
            capture_output=True,
            text=True,
        )
        if mounted.returncode != 0:
            tally.skipped = f"a tmpfs cannot be mounted here: {mounted.stderr.strip()}"
            return tally
        try:
            _disk_full(folder, data, refused, tally)
        finally:
            subprocess.run(["umount", "-l", str(data)], check=False)
    return tally


def _disk_full(folder: Path, data: Path, refused: int, tally: DiskTally) -> None:
    store_url = f"sqlite:///{folder / 'store.db'}"  # beside the data folder: the uploads fill it alone
    store = open_store(store_url)
    key = store.create_key(store.create_fleet("fleet"))
    store.close()
    log, port = folder / "service.log", free_port()
    url = f"http://127.0.0.1:{port}"
    server = start_monitor(
        ["serve", "--port", str(port), "--store", store_url, "--data", str(data), "--workers", "0"], log
    )
    try:
        if _healthy_within(url, HEALTHY_S) is None:
            raise RuntimeError(f"the server did not start (see {log})")
        load = _Load(url, key, folder, base_recordings(UPLOADERS))
        deadline = time.monotonic() + FINISH_S
        with load:  # until `refused` uploads were refused for lack of room (or the deadline)
            while load.uploads["507"] + load.uploads["other 5xx"] < refused and time.monotonic() < deadline:
                time.sleep(0.2)
        tally.answers, tally.unanswered = load.answers, load.unanswered
        tally.tracebacks_answered, tally.uploads_stored = load.tracebacks, len(load.stored)
        health = httpx.get(f"{url}/health", timeout=10)
        tally.health_while_full = f"{health.status_code} " + (
            health.json()["error"]["code"] if health.status_code != 200 else "ok"
        )
        tally.parts_left = len(list((data / "incoming").glob("*.part")))
        tally.files_without_rows = _files_without_rows(data, store_url)
        subprocess.run(["mount", "-o", f"remount,size={4 * tally.size_mib}m", str(data)], check=True)
        path = folder / "after.h5"

        write_hdf5(replace(base_recordings(1)[0], notes="disk-full run: after the folder grew"), path)
        answer = httpx.post(
            f"{url}/recordings",
            params={"filename": path.name},
            content=path.read_bytes(),
            headers={"X-API-Key": key},
            timeout=120,
        )
        tally.recovered = (
            httpx.get(f"{url}/health", timeout=10).status_code == 200 and answer.status_code == 201
        ) and server.poll() is None
    finally:
        _stop(server)
    tally.tracebacks_logged = log.read_text(errors="replace").count("Traceback")


OUTAGE_START, OUTAGE_END = "<!-- service-outage: start -->", "<!-- service-outage: end -->"
DISK_START, DISK_END = "<!-- service-disk-full: start -->", "<!-- service-disk-full: end -->"


def _written(command: str, moment: str, python: str) -> str:
    return f"Written by `{command}` on {moment}, Python {python}, 2 cores (shared machine)."


def outage_section(t: OutageTally, command: str, moment: str, python: str) -> str:
    """The store-outage run's section of docs/service.md."""
    lines = [OUTAGE_START, _written(command, moment, python)]
    if t.skipped:
        return "\n".join([*lines, f"Skipped: {t.skipped}.", OUTAGE_END])
    other = t.answers["other 5xx"]
    lines += [
        f"PostgreSQL through a loopback proxy, cut {t.cycles} times for {t.outage_s:g} s (every connection "
        f"closed, new ones refused), {STEADY_S:g} s of load before each cut and after the service is "
        f"healthy again; {READERS} readers (`/health`, the listing, a recording, its diagnosis) and "
        f"{UPLOADERS} uploaders of distinct recordings at once; one server, one analysis process, never "
        "restarted.",
        "",
        "| cycles | answers 2xx / 4xx | 503 | 5xx other than 503/507 | no answer | tracebacks in answers "
        "| tracebacks in the log | outage lines in the log | uploads stored | files without rows "
        "| jobs lost | jobs run twice | recovered without a restart | cut ended to healthy [s], median |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
        f"| {t.cycles} | {t.answers['2xx']} / {t.answers['4xx']} | {t.answers['503']} | {other} "
        f"| {t.unanswered} | {t.tracebacks_answered} | {t.tracebacks_logged} | {t.outage_lines} "
        f"| {t.uploads_stored} | {t.files_without_rows} | {t.jobs_lost} | {t.jobs_run_twice} "
        f"| {'yes' if t.recovered == t.cycles else 'no'} ({t.recovered} of {t.cycles}) "
        f"| {_median(t.back_s)} |",
    ]
    held = other == t.unanswered == t.tracebacks_answered == t.files_without_rows == t.jobs_lost == 0
    held = held and t.recovered == t.cycles
    target = (
        "Target: no 5xx but 503, no answer missing, no traceback answered, no file without its row, no job "
        f"lost, recovery without a restart: {'met' if held else 'not met'}."
    )
    lines += ["", target, OUTAGE_END]
    return "\n".join(lines)


def disk_full_section(t: DiskTally, command: str, moment: str, python: str) -> str:
    """The disk-full run's section of docs/service.md."""
    lines = [DISK_START, _written(command, moment, python)]
    if t.skipped:
        return "\n".join([*lines, f"Skipped: {t.skipped}.", DISK_END])
    other = t.answers["other 5xx"]
    lines += [
        f"A tmpfs of {t.size_mib} MiB as the data folder (the SQLite store beside it), filled by "
        f"{UPLOADERS} uploaders of distinct recordings (0.96 MB each) while {READERS} readers read; then "
        f"grown to {4 * t.size_mib} MiB (`mount -o remount`) and one more upload sent; one server "
        "(queuing only), never restarted.",
        "",
        "| answers 2xx / 4xx | 507 | 5xx other than 503/507 | no answer | tracebacks in answers "
        "| tracebacks in the log | uploads stored | partial uploads left | files without rows "
        "| `/health` while full | recovered without a restart |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
        f"| {t.answers['2xx']} / {t.answers['4xx']} | {t.answers['507']} | {other} | {t.unanswered} "
        f"| {t.tracebacks_answered} | {t.tracebacks_logged} | {t.uploads_stored} | {t.parts_left} "
        f"| {t.files_without_rows} | {t.health_while_full} | {'yes' if t.recovered else 'no'} |",
    ]
    held = other == t.unanswered == t.tracebacks_answered == t.parts_left == t.files_without_rows == 0
    held = held and t.recovered and t.answers["507"] > 0
    target = (
        "Target: the full folder answered 507, no other 5xx, nothing left behind, recovery without a "
        f"restart: {'met' if held else 'not met'}."
    )
    lines += ["", target, DISK_END]
    return "\n".join(lines)


def _median(values: list[float]) -> str:
    return f"{sorted(values)[len(values) // 2]:.1f}" if values else "-"
