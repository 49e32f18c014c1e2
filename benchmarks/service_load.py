"""The HTTP service under load on loopback; writes its section of docs/performance.md.

Run with ``python -m benchmarks.service_load [--seconds S] [--postgres URL]``
(``make bench-service``). For each store (the embedded SQLite, and PostgreSQL
when a server answers at the URL) it starts ``engine-monitor serve`` in its
own process on a free loopback port, uploads one recording and waits for its
analysis, then for ``--seconds``:

- 50 client threads read results in a loop: the recording list, one
  recording, its diagnosis, its spectrum (a request each, round robin);
- 4 client threads each upload their own recording (3 s of a 6L32, 0.96 MB)
  in a loop: stored the first time, found by its content after that, each
  time streamed to disk and validated in a child process.

It reports the latency percentiles and the throughput of reads and uploads,
and counts 5xx answers and uploads the store does not hold afterwards (both
must be 0). The rest of docs/performance.md comes from ``benchmarks.performance``;
this command rewrites only the section between its markers.
"""

from __future__ import annotations

import argparse
import os
import platform
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.sections import replace_section

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "performance.md"
START, END = "<!-- service-load: start -->", "<!-- service-load: end -->"
READERS, UPLOADERS = 50, 4
POSTGRES = "postgresql+psycopg://postgres@127.0.0.1:5432/postgres"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _recordings(folder: Path, count: int, seconds: float = 3.0) -> list[Path]:
    """Distinct short recordings to upload (``seconds`` of the 6L32 baseline scene, one seed each)."""
    from monitor.io.hdf5 import write_hdf5
    from monitor.scene import load_scene, simulate

    scene = load_scene(ROOT / "recordings" / "scenes" / "6l32-baseline.toml").model_copy(
        update={"duration_s": seconds}
    )
    paths = []
    for seed in range(count):
        path = folder / f"upload-{seed}.h5"
        write_hdf5(simulate(scene, seed=1000 + seed).recording, path)
        paths.append(path)
    return paths


def _postgres_database(admin_url: str) -> tuple[str, Any] | None:
    import sqlalchemy as sa

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


def run(store_url: str, folder: Path, seconds: float, uploads: list[Path]) -> dict[str, Any]:
    """Start a server on this store, load it, stop it; the measurements."""
    import httpx

    from monitor.store import open_store

    store = open_store(store_url)
    key = store.create_key(store.create_fleet("bench"))
    store.close()
    port = _free_port()
    base = f"http://127.0.0.1:{port}"
    server = subprocess.Popen(
        [sys.executable, "-m", "monitor", "serve", "--port", str(port), "--store", store_url,
         "--data", str(folder / "data"), "--workers", "1"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True, cwd=ROOT,
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
        sample = ROOT / "recordings" / "samples" / "7k98mc-misfire-cyl4.h5"
        first = httpx.post(
            f"{base}/recordings",
            params={"filename": sample.name},
            content=sample.read_bytes(),
            headers=headers,
            timeout=60,
        ).json()["id"]
        while httpx.get(f"{base}/recordings/{first}", headers=headers).json()["status"] != "done":
            time.sleep(0.2)
        paths = [
            "/recordings",
            f"/recordings/{first}",
            f"/recordings/{first}/diagnosis",
            f"/recordings/{first}/spectrum",
        ]
        reads: list[float] = []
        sent: list[float] = []
        errors = {"5xx": 0, "other": 0}
        stored_ids: list[int] = []
        lock = threading.Lock()
        stop = time.monotonic() + seconds

        def reader(i: int) -> None:
            with httpx.Client(base_url=base, headers=headers, timeout=60) as client:
                n = i
                while time.monotonic() < stop:
                    t0 = time.perf_counter()
                    answer = client.get(paths[n % len(paths)])
                    elapsed = time.perf_counter() - t0
                    n += 1
                    with lock:
                        reads.append(elapsed)
                        if answer.status_code >= 500:
                            errors["5xx"] += 1
                        elif answer.status_code >= 400:
                            errors["other"] += 1

        def uploader(i: int) -> None:
            with httpx.Client(base_url=base, headers=headers, timeout=120) as client:
                path = uploads[i]
                data = path.read_bytes()
                round_ = 0
                while time.monotonic() < stop:
                    # each uploader sends its own recording again and again: the first is stored (201), the
                    # repeats are streamed, validated and found by content (200), as a re-sent file would be
                    t0 = time.perf_counter()
                    answer = client.post(
                        "/recordings", params={"filename": f"{path.stem}-{round_}.h5"}, content=data
                    )
                    elapsed = time.perf_counter() - t0
                    round_ += 1
                    with lock:
                        sent.append(elapsed)
                        if answer.status_code >= 500:
                            errors["5xx"] += 1
                        elif answer.status_code not in (200, 201):
                            errors["other"] += 1
                        else:
                            stored_ids.append(int(answer.json()["id"]))

        threads = [threading.Thread(target=reader, args=(i,)) for i in range(READERS)]
        threads += [threading.Thread(target=uploader, args=(i,)) for i in range(UPLOADERS)]
        started = time.perf_counter()
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        wall = time.perf_counter() - started
        listed = httpx.get(f"{base}/recordings", params={"limit": 500}, headers=headers).json()["items"]
        lost = len(set(stored_ids) - {r["id"] for r in listed})
    finally:
        os.killpg(server.pid, signal.SIGTERM)
        server.wait(timeout=30)
    r, u = np.asarray(reads) * 1e3, np.asarray(sent) * 1e3
    return {
        "reads": r.size,
        "uploads": u.size,
        "wall": wall,
        "read_p": [*np.percentile(r, [50, 90, 99]).tolist(), float(r.max())],
        "upload_p": [*np.percentile(u, [50, 90, 99]).tolist(), float(u.max())],
        "errors_5xx": errors["5xx"],
        "errors_other": errors["other"],
        "lost": lost,
        "distinct": len(set(stored_ids)),
    }


def _section(rows: list[tuple[str, dict[str, Any]]], seconds: float) -> list[str]:
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        START,
        "## The HTTP service under load",
        "",
        f"Written by `python -m benchmarks.service_load --seconds {seconds:g}` on {stamp}, Python "
        f"{platform.python_version()}, {os.cpu_count()} cores (shared machine; the clients run on the same "
        "machine as the server, one uvicorn process with one analysis worker). For each store, "
        f"{READERS} client threads read results (the list, a recording, its diagnosis, its spectrum, in "
        f"turn) while {UPLOADERS} threads upload recordings (0.96 MB each, validated in a child process and "
        "stored), for the stated time. Latencies in milliseconds.",
        "",
        "| store | reads | read p50 | p90 | p99 | max | reads/s | uploads | upload p50 | p90 | p99 | max "
        "| uploads/s | 5xx | other 4xx | uploads lost |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, m in rows:
        rp, up = m["read_p"], m["upload_p"]
        lines.append(
            f"| {name} | {m['reads']} | {rp[0]:.0f} | {rp[1]:.0f} | {rp[2]:.0f} | {rp[3]:.0f} | "
            f"{m['reads'] / m['wall']:.0f} | {m['uploads']} | {up[0]:.0f} | {up[1]:.0f} | {up[2]:.0f} | "
            f"{up[3]:.0f} | {m['uploads'] / m['wall']:.1f} | {m['errors_5xx']} | {m['errors_other']} | "
            f"{m['lost']} |"
        )
    lines += [
        "",
        "Targets (the service issue): no 5xx and no lost upload under 50 readers and 4 uploaders: "
        + ("met." if all(m["errors_5xx"] == 0 and m["lost"] == 0 for _, m in rows) else "**not met**."),
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
        "--postgres", default=POSTGRES, help="PostgreSQL admin URL (a database is made there)"
    )
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        uploads = _recordings(Path(folder), UPLOADERS)
        print("SQLite ...", flush=True)
        sqlite_folder = Path(folder) / "sqlite"
        sqlite_folder.mkdir()
        rows.append(
            (
                "SQLite (WAL)",
                run(f"sqlite:///{sqlite_folder / 'store.db'}", sqlite_folder, args.seconds, uploads),
            )
        )
        made = _postgres_database(args.postgres)
        if made is None:
            print(f"no PostgreSQL server answers at {args.postgres}: its row is left out", flush=True)
        else:
            url, drop = made
            print("PostgreSQL ...", flush=True)
            pg_folder = Path(folder) / "postgres"
            pg_folder.mkdir()
            try:
                rows.append(("PostgreSQL", run(url, pg_folder, args.seconds, uploads)))
            finally:
                drop()
    write_section(_section(rows, args.seconds))
    print(f"wrote the service section of {DOC.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
