"""The HTTP service under load on loopback, over a store of 10 000 recordings; writes its section of
docs/performance.md.

Run with ``python -m benchmarks.service_load [--seconds S] [--recordings N] [--postgres URL]``
(``make bench-service``). For each store (the embedded SQLite, and PostgreSQL
when a server answers at the URL):

1. the store is seeded with ``--recordings`` analysed recordings of one fleet
   (each with its job done and its two results, the diagnosis and the
   spectrum of one real analysis), written directly through the store's
   tables in one transaction, not over HTTP, as a fleet's history would be
   (on PostgreSQL then ``ANALYZE``, as autovacuum does within a minute of a
   bulk load, so the plans are those of a store in service);
2. ``engine-monitor serve`` starts in its own process on a free loopback port,
   with one analysis process and without its access log (``--no-access-log``,
   as a server under load would run), warmed by one upload analysed before
   the run;
3. for ``--seconds``, at once:

   - 50 readers: ``wrk`` (a load generator in C, installed with apt-get if
     missing) keeps 50 connections busy, each sending its next request as
     soon as the last is answered: the recording list (first page, 50
     items), a recording, its diagnosis, its spectrum, in turn, each of a
     recording drawn at random from the 10 000. Python client threads would
     take much of the two cores the server needs;
   - 4 uploaders (client threads here): each uploads recording after
     recording (3 s of a 6L32, 0.96 MB), every one distinct (a new note in
     each file, so a new content hash), so every upload is validated,
     stored, queued and analysed, as a fleet's would be.

It reports the reads' latency percentiles and throughput, the answers by
class (5xx must be 0), the uploads and their latencies, the uploads answered
as stored that the store does not hold afterwards (must be 0), and the
analyses completed during the run. The rest of docs/performance.md comes from
``benchmarks.performance``; this command rewrites only the section between
its markers.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import replace
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import sqlalchemy as sa

from benchmarks.sections import replace_section
from monitor.diagnosis import ANALYSIS_VERSION
from monitor.io.hdf5 import write_hdf5
from monitor.jobs.analyse import diagnose_file
from monitor.scene import load_scene, simulate
from monitor.store import document_text, open_store
from monitor.store.schema import jobs, recordings, results

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "performance.md"
START, END = "<!-- service-load: start -->", "<!-- service-load: end -->"
READERS, UPLOADERS = 50, 4
RECORDINGS = 10_000
POSTGRES = "postgresql+psycopg://postgres@127.0.0.1:5432/postgres"
#: the targets of the service issue (SQLite): read p99 [ms] below, reads/s at least
READ_P99_MS, READS_PER_S = 100.0, 1000.0
SAMPLE = ROOT / "recordings" / "samples" / "6l32-misfire-cyl3.h5"

# The readers' script for wrk: random recordings, the four reads in turn; answers counted by class; at
# the end one JSON line with the latency percentiles (microseconds) and the counts.
WRK_SCRIPT = """
local first, count = %(first)d, %(count)d
local n, threads = 0, {}
classes = {0, 0, 0, 0, 0}  -- a global: done() reads each thread's with thread:get
function setup(thread) table.insert(threads, thread) end
function init(args) math.randomseed(os.time() + os.clock() * 1e6) end
function request()
  n = n + 1
  local id = first + math.random(0, count - 1)
  local k = n %% 4
  if k == 0 then return wrk.format("GET", "/recordings") end
  if k == 1 then return wrk.format("GET", "/recordings/" .. id) end
  if k == 2 then return wrk.format("GET", "/recordings/" .. id .. "/diagnosis") end
  return wrk.format("GET", "/recordings/" .. id .. "/spectrum")
end
function response(status, headers, body)
  local c = math.floor(status / 100)
  if c >= 1 and c <= 5 then classes[c] = classes[c] + 1 end
end
function done(summary, latency, requests)
  local total = {0, 0, 0, 0, 0}
  for _, thread in ipairs(threads) do
    local c = thread:get("classes")
    for i = 1, 5 do total[i] = total[i] + c[i] end
  end
  local e = summary.errors
  io.write(string.format(
    '{"requests": %%d, "duration_us": %%d, "p50": %%d, "p90": %%d, "p99": %%d, "max": %%d, '
    .. '"2xx": %%d, "3xx": %%d, "4xx": %%d, "5xx": %%d, "socket_errors": %%d}\\n',
    summary.requests, summary.duration, latency:percentile(50), latency:percentile(90),
    latency:percentile(99), latency.max, total[2], total[3], total[4], total[5],
    e.connect + e.read + e.write + e.timeout))
end
"""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _wrk() -> str:
    """The wrk command, installed from Debian's packages if missing (as root)."""
    found = shutil.which("wrk")
    if found:
        return found
    if os.geteuid() != 0 or not shutil.which("apt-get"):
        raise SystemExit("wrk is missing and this user cannot install it: apt-get install wrk (as root)")
    environment = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    subprocess.run(
        ["apt-get", "install", "-y", "--no-install-recommends", "wrk"], check=True, env=environment
    )
    return shutil.which("wrk") or "wrk"


def start_monitor(argv: list[str], log: Path) -> subprocess.Popen[bytes]:
    """Start ``python -m monitor ARGV`` in a session of its own, its output appended to ``log``."""
    with open(log, "ab") as out:
        return subprocess.Popen(
            [sys.executable, "-m", "monitor", *argv], stdout=out, stderr=out, start_new_session=True, cwd=ROOT
        )


def base_recordings(count: int, seconds: float = 3.0) -> list[Any]:
    """Recordings the uploaders vary (``seconds`` of the 6L32 baseline scene, one seed each)."""
    scene = load_scene(ROOT / "recordings" / "scenes" / "6l32-baseline.toml").model_copy(
        update={"duration_s": seconds}
    )
    return [simulate(scene, seed=1000 + seed).recording for seed in range(count)]


def _analysed() -> dict[str, tuple[str, dict[str, Any]]]:
    """The results of one real analysis, stored with every seeded recording."""
    return diagnose_file(str(SAMPLE), None, None, None, SAMPLE.name)


def _seed(store_url: str, count: int, documents: dict[str, tuple[str, dict[str, Any]]]) -> tuple[str, int]:
    """A fleet with ``count`` analysed recordings, written through the store's tables in one
    transaction; the fleet's key and its first recording's id."""
    store = open_store(store_url)
    try:
        fleet = store.create_fleet("bench")
        key = store.create_key(fleet)
        start = datetime.now(UTC) - timedelta(days=30)
        step = timedelta(days=30) / count
        texts = {kind: document_text(document) for kind, (_, document) in documents.items()}
        with store.transaction() as c:
            ids = list(
                c.execute(
                    sa.insert(recordings).returning(recordings.c.id, sort_by_parameter_order=True),
                    [
                        {
                            "fleet_id": fleet,
                            "content_hash": hashlib.sha256(f"seeded {i}".encode()).hexdigest(),
                            "engine_id": "wartsila-6l32",
                            "filename": f"seeded-{i:05d}.h5",
                            "path": f"seeded-{i:05d}.h5",
                            "size_bytes": 960_000,
                            "recorded_at": "",
                            "uploaded_at": start + i * step,
                        }
                        for i in range(count)
                    ],
                ).scalars()
            )
            first = ids[0]
            if ids != list(range(first, first + count)):  # the readers draw ids from this range
                raise SystemExit(
                    f"{store_url}: the seeded recordings' ids are not {first} to {first + count - 1}"
                )
            c.execute(
                sa.insert(jobs),
                [
                    {"recording_id": r, "analysis_version": ANALYSIS_VERSION, "state": "done", "attempts": 1,
                     "error": "", "token": "", "holder": "", "created_at": start, "updated_at": start}
                    for r in ids
                ],
            )  # fmt: skip
            c.execute(
                sa.insert(results),
                [
                    {"recording_id": r, "analysis_version": ANALYSIS_VERSION, "kind": kind, "status": status,
                     "document": document, "created_at": start,
                     "digest": hashlib.sha256(texts[kind].encode("utf-8")).hexdigest()}
                    for r in ids
                    for kind, (status, document) in documents.items()
                ],
            )  # fmt: skip
        if store.dialect == "postgresql":
            # the planner's statistics after a bulk load, as autovacuum makes them within its minute:
            # the plans of a store in service, not those of tables the planner takes as empty
            with store.db.connect().execution_options(isolation_level="AUTOCOMMIT") as c:
                c.exec_driver_sql("ANALYZE")
        stored = store.stored_result(fleet, first, ANALYSIS_VERSION, "spectrum")
        if stored is None or stored.result is None or stored.result.text != texts["spectrum"]:
            raise SystemExit(f"{store_url}: the seeded results are not stored as the store writes them")
        return key, first
    finally:
        store.close()


def _analyses_done(store_url: str) -> int:
    store = open_store(store_url)
    try:
        return store.jobs_by_state(ANALYSIS_VERSION).get("done", 0)
    finally:
        store.close()


def run(
    store_url: str,
    folder: Path,
    seconds: float,
    count: int,
    bases: list[Any],
    documents: dict[str, tuple[str, dict[str, Any]]],
) -> dict[str, Any]:
    """Seed the store, start a server on it, load it, stop it; the measurements."""
    seeding = time.perf_counter()
    key, first = _seed(store_url, count, documents)
    seeded_s = time.perf_counter() - seeding
    port = free_port()
    base = f"http://127.0.0.1:{port}"
    log = open(folder / "server.log", "wb")
    server = subprocess.Popen(
        [sys.executable, "-m", "monitor", "serve", "--port", str(port), "--store", store_url,
         "--data", str(folder / "data"), "--workers", "1", "--no-access-log"],
        stdout=log, stderr=subprocess.STDOUT, start_new_session=True, cwd=ROOT,
    )  # fmt: skip
    try:
        headers = {"X-API-Key": key}
        deadline = time.monotonic() + 60
        while True:
            try:
                if httpx.get(f"{base}/health", timeout=1).status_code == 200:
                    break
            except httpx.TransportError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.2)
        # the analysis process started and warm, as in a server in service: one upload analysed first
        write_hdf5(replace(bases[0], notes="load benchmark: warm-up"), folder / "warm-up.h5")
        with httpx.Client(base_url=base, headers=headers, timeout=120) as client:
            answer = client.post(
                "/recordings", params={"filename": "warm-up.h5"}, content=(folder / "warm-up.h5").read_bytes()
            )
            answer.raise_for_status()
            warm_up = answer.json()["id"]
            while client.get(f"/recordings/{warm_up}").json()["status"] not in ("done", "set_aside"):
                time.sleep(0.2)
        done_before = _analyses_done(store_url)
        script = folder / "reads.lua"
        script.write_text(WRK_SCRIPT % {"first": first, "count": count})
        sent: list[float] = []
        answers: dict[str, int] = {"5xx": 0, "other": 0}
        stored_ids: list[int] = []
        lock = threading.Lock()
        load_average = os.getloadavg()[0]
        readers = subprocess.Popen(
            [_wrk(), "-t1", f"-c{READERS}", f"-d{seconds:g}s", "--timeout", "60s", "-s", str(script),
             "-H", f"X-API-Key: {key}", base],
            stdout=subprocess.PIPE, text=True, cwd=folder,
        )  # fmt: skip
        stop = time.monotonic() + seconds

        def uploader(i: int) -> None:
            path = folder / f"upload-{i}.h5"
            with httpx.Client(base_url=base, headers=headers, timeout=120) as client:
                n = 0
                while time.monotonic() < stop:
                    # a new note makes new content: each upload is stored and analysed, none found again
                    write_hdf5(replace(bases[i], notes=f"load benchmark: uploader {i}, upload {n}"), path)
                    data = path.read_bytes()
                    t0 = time.perf_counter()
                    answer = client.post(
                        "/recordings", params={"filename": f"upload-{i}-{n}.h5"}, content=data
                    )
                    elapsed = time.perf_counter() - t0
                    n += 1
                    with lock:
                        sent.append(elapsed)
                        if answer.status_code >= 500:
                            answers["5xx"] += 1
                        elif answer.status_code != 201:  # 200 would be content found again: not distinct
                            answers["other"] += 1
                        else:
                            stored_ids.append(int(answer.json()["id"]))

        threads = [threading.Thread(target=uploader, args=(i,)) for i in range(UPLOADERS)]
        for t in threads:
            t.start()
        out, _ = readers.communicate(timeout=seconds + 120)
        done_at_end = _analyses_done(store_url)
        for t in threads:
            t.join()
        reads = json.loads(out.strip().splitlines()[-1])
        with httpx.Client(base_url=base, headers=headers, timeout=60) as client:
            lost = sum(client.get(f"/recordings/{i}").status_code != 200 for i in stored_ids)
    finally:
        os.killpg(server.pid, signal.SIGTERM)
        server.wait(timeout=30)
        log.close()
    u = np.asarray(sent) * 1e3
    wall = reads["duration_us"] / 1e6
    return {
        "seeded": count,
        "seeded_s": seeded_s,
        "load_average": load_average,
        "reads": reads["requests"],
        "wall": wall,
        "read_p": [reads[p] / 1e3 for p in ("p50", "p90", "p99", "max")],
        "read_classes": {c: reads[c] for c in ("2xx", "3xx", "4xx", "5xx")},
        "socket_errors": reads["socket_errors"],
        "uploads": len(stored_ids),
        "upload_p": [*np.percentile(u, [50, 90, 99]).tolist(), float(u.max())] if u.size else [0.0] * 4,
        "upload_5xx": answers["5xx"],
        "upload_other": answers["other"],
        "lost": lost,
        "analysed": done_at_end - done_before,
    }


def postgres_database(admin_url: str) -> tuple[str, Any] | None:
    admin = sa.create_engine(admin_url, isolation_level="AUTOCOMMIT")
    name = f"engine_monitor_bench_{os.getpid()}"
    try:
        with admin.connect() as c:
            c.execute(sa.text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
            c.execute(sa.text(f'CREATE DATABASE "{name}"'))
    except sa.exc.OperationalError:
        admin.dispose()
        return None

    def drop() -> None:
        with admin.connect() as c:
            c.execute(sa.text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
        admin.dispose()

    return admin.url.set(database=name).render_as_string(hide_password=False), drop


def _met(m: dict[str, Any]) -> dict[str, bool]:
    return {
        "p99": m["read_p"][2] < READ_P99_MS,
        "rate": m["reads"] / m["wall"] >= READS_PER_S,
        "no 5xx": m["read_classes"]["5xx"] + m["upload_5xx"] == 0 and m["socket_errors"] == 0,
        "nothing lost": m["lost"] == 0,
    }


def _verdict(name: str, m: dict[str, Any]) -> str:
    met = _met(m)
    rate = m["reads"] / m["wall"]
    parts = [
        f"read p99 {m['read_p'][2]:.0f} ms (target under {READ_P99_MS:.0f}): "
        + ("met" if met["p99"] else "**not met**"),
        f"{rate:.0f} reads/s (target at least {READS_PER_S:.0f}): "
        + ("met" if met["rate"] else "**not met**"),
        f"{m['read_classes']['5xx'] + m['upload_5xx']} answers 5xx and {m['socket_errors']} connection "
        "errors (target none): " + ("met" if met["no 5xx"] else "**not met**"),
        f"{m['lost']} uploads lost of {m['uploads']} (target none): "
        + ("met" if met["nothing lost"] else "**not met**"),
    ]
    return f"- {name}: " + "; ".join(parts) + "."


def _section(rows: list[tuple[str, dict[str, Any]]], seconds: float) -> list[str]:
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    loads = ", ".join(f"{m['load_average']:.1f} before the {name} run" for name, m in rows)
    lines = [
        START,
        "## The HTTP service under load",
        "",
        f"Written by `python -m benchmarks.service_load --seconds {seconds:g}` on {stamp}, Python "
        f"{platform.python_version()}, {os.cpu_count()} cores, shared (load average {loads}); the clients "
        "run on the same machine as the server: one uvicorn process (`serve --no-access-log`) with one "
        "analysis process; validations "
        "and analyses run at niceness 10, below the server (docs/service.md, Priorities). Each store "
        f"holds {rows[0][1]['seeded'] if rows else RECORDINGS:,} analysed recordings of one fleet before the "
        "run, seeded directly through the store's tables, not over HTTP (then, on PostgreSQL, `ANALYZE`, "
        "as autovacuum does within a minute of a bulk load). Then, for the stated time, "
        f"{READERS} readers (`wrk`, a load generator in C, {READERS} connections, each sending its next "
        "request when the last is answered) read the recording list (first page of 50), a recording, its "
        "diagnosis and its spectrum in turn, each of a recording drawn at random, while "
        f"{UPLOADERS} client threads upload distinct recordings (0.96 MB each, a new note in each file), "
        "each validated in a child process, stored, queued and analysed. Latencies in milliseconds; "
        '"uploads" counts the uploads stored (201), "analysed" the analyses completed during the run.',
        "",
        "| store | reads | read p50 | p90 | p99 | max | reads/s | 2xx | 4xx | 5xx | uploads | upload p50 "
        "| p90 | p99 | max | uploads lost | analysed |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, m in rows:
        rp, up, rc = m["read_p"], m["upload_p"], m["read_classes"]
        lines.append(
            f"| {name} | {m['reads']} | {rp[0]:.1f} | {rp[1]:.1f} | {rp[2]:.1f} | {rp[3]:.0f} | "
            f"{m['reads'] / m['wall']:.0f} | {rc['2xx']} | {rc['4xx'] + m['upload_other']} | "
            f"{rc['5xx'] + m['upload_5xx']} | {m['uploads']} | {up[0]:.0f} | {up[1]:.0f} | {up[2]:.0f} | "
            f"{up[3]:.0f} | {m['lost']} | {m['analysed']} |"
        )
    lines += [
        "",
        f"Targets (the service issue, for SQLite; PostgreSQL measured beside it): read p99 under "
        f"{READ_P99_MS:.0f} ms, at least {READS_PER_S:.0f} reads/s, no 5xx, no upload lost.",
        "",
        *(_verdict(name, m) for name, m in rows),
        END,
    ]
    return lines


def write_section(lines: list[str]) -> None:
    """Replace (or append) the section between the markers in docs/performance.md."""
    replace_section(DOC, START, END, "\n".join(lines))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="load duration per store")
    parser.add_argument(
        "--recordings", type=int, default=RECORDINGS, help="analysed recordings in the store before the run"
    )
    parser.add_argument(
        "--postgres", default=POSTGRES, help="PostgreSQL admin URL (a database is made there)"
    )
    args = parser.parse_args()
    _wrk()
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        print("one analysis for the seeded results, the uploads' recordings ...", flush=True)
        documents = _analysed()
        bases = base_recordings(UPLOADERS)
        print("SQLite ...", flush=True)
        sqlite_folder = Path(folder) / "sqlite"
        sqlite_folder.mkdir()
        url = f"sqlite:///{sqlite_folder / 'store.db'}"
        rows.append(
            ("SQLite (WAL)", run(url, sqlite_folder, args.seconds, args.recordings, bases, documents))
        )
        made = postgres_database(args.postgres)
        if made is None:
            print(f"no PostgreSQL server answers at {args.postgres}: its row is left out", flush=True)
        else:
            url, drop = made
            print("PostgreSQL ...", flush=True)
            pg_folder = Path(folder) / "postgres"
            pg_folder.mkdir()
            try:
                rows.append(
                    ("PostgreSQL", run(url, pg_folder, args.seconds, args.recordings, bases, documents))
                )
            finally:
                drop()
    for name, m in rows:
        print(name, json.dumps(m), flush=True)
    write_section(_section(rows, args.seconds))
    print(f"wrote the service section of {DOC.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
