"""The service killed with ``kill -9`` mid-analysis, again and again (``make bench-kill``).

``python -m benchmarks.service_kill [--sqlite-runs 20] [--postgresql-runs 5] [--outage-cycles 3]
[--outage-s 20] [--disk-full-mib 12]``. Each run starts on a
fresh store a server, and in every other run a separate worker (the server then only queues),
uploads three recordings, waits until an analysis runs, then kills with SIGKILL the process that runs
it (the server itself, or the worker): that process alone, not its group. It then checks that
nothing of the killed process is left running (its analysis processes die with it), restarts it at
once on the same port, and waits until every analysis is done. Counted per store: uploads lost (a
recording answered 201 and not stored, or never analysed), results duplicated, 5xx answers,
processes left behind, restarts that failed. It writes its section of docs/service.md.

Then the service while its surroundings fail (:mod:`benchmarks.service_outage`): PostgreSQL stopped
(through a proxy) ``--outage-cycles`` times for ``--outage-s`` seconds, and the data folder full
(a tmpfs of ``--disk-full-mib``), each under readers and uploaders; each writes a section of its own.
A count of 0 (``--sqlite-runs 0 --postgresql-runs 0``, ``--outage-cycles 0``, ``--disk-full-mib 0``)
leaves a run out and its section as it was.
"""

from __future__ import annotations

import argparse
import platform
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import httpx

from benchmarks.sections import replace_section
from benchmarks.service_load import POSTGRES, base_recordings, free_port, postgres_database, start_monitor
from benchmarks.service_outage import (
    DISK_END,
    DISK_START,
    OUTAGE_END,
    OUTAGE_START,
    disk_full_run,
    disk_full_section,
    outage_run,
    outage_section,
)
from monitor.io.hdf5 import write_hdf5
from monitor.runtime.processes import session_processes
from monitor.store import open_store

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "service.md"
START, END = "<!-- service-kill: start -->", "<!-- service-kill: end -->"
UPLOADS = 3
STARTUP_S = 60.0
FINISH_S = 180.0


@dataclass
class Tally:
    """What the runs of one store found."""

    runs: int = 0
    server_kills: int = 0
    worker_kills: int = 0
    uploads: int = 0
    lost: int = 0
    duplicated: int = 0
    errors_5xx: int = 0
    left_behind: int = 0
    restart_failures: int = 0
    restart_s: list[float] = field(default_factory=list)
    finish_s: list[float] = field(default_factory=list)


def _recordings(folder: Path, count: int, seconds: float) -> list[Path]:
    """Distinct recordings to upload (``seconds`` of the 6L32 baseline scene, one seed each)."""
    paths = []
    for i, recording in enumerate(base_recordings(count, seconds)):
        paths.append(folder / f"kill-{i}.h5")
        write_hdf5(recording, paths[-1])
    return paths


def _wait_healthy(url: str) -> float | None:
    started = time.monotonic()
    while time.monotonic() - started < STARTUP_S:
        try:
            if httpx.get(f"{url}/health", timeout=2).status_code == 200:
                return time.monotonic() - started
        except httpx.TransportError:
            pass
        time.sleep(0.1)
    return None


def one_run(store_url: str, folder: Path, recordings: list[Path], kill_worker: bool, tally: Tally) -> None:
    store = open_store(store_url)
    key = store.create_key(store.create_fleet("fleet"))
    store.close()
    data, log = folder / "data", folder / "service.log"
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    serve = ["serve", "--port", str(port), "--store", store_url, "--data", str(data), "--lease", "30"]
    serve += ["--workers", "0" if kill_worker else "1"]
    work = ["worker", "--store", store_url, "--data", str(data), "--lease", "30"]
    server = start_monitor(serve, log)
    worker = start_monitor(work, log) if kill_worker else None
    try:
        if _wait_healthy(url) is None:
            raise RuntimeError(f"the server did not start (see {log})")
        client = httpx.Client(base_url=url, headers={"X-API-Key": key}, timeout=60)

        def answered(response: httpx.Response) -> httpx.Response:
            tally.errors_5xx += response.status_code >= 500
            return response

        ids = []
        for path in recordings:
            answer = answered(
                client.post("/recordings", params={"filename": path.name}, content=path.read_bytes())
            )
            if answer.status_code == 201:
                ids.append(answer.json()["id"])
        tally.uploads += len(ids)
        deadline = time.monotonic() + FINISH_S
        while not any(answered(client.get(f"/recordings/{i}")).json()["status"] == "running" for i in ids):
            if time.monotonic() > deadline:
                raise RuntimeError("no analysis started")
            time.sleep(0.05)
        victim = worker if kill_worker else server
        assert victim is not None
        victim.send_signal(signal.SIGKILL)
        victim.wait()
        tally.worker_kills += kill_worker
        tally.server_kills += not kill_worker
        gone = time.monotonic() + 5
        while session_processes(victim.pid) and time.monotonic() < gone:
            time.sleep(0.05)
        tally.left_behind += len(session_processes(victim.pid))
        restarted = time.monotonic()
        if kill_worker:
            worker = start_monitor(work, log)
        else:
            server = start_monitor(serve, log)
            if _wait_healthy(url) is None:
                tally.restart_failures += 1
                raise RuntimeError(f"the server did not restart on port {port} (see {log})")
            tally.restart_s.append(time.monotonic() - restarted)
        deadline = time.monotonic() + FINISH_S
        while True:
            states = [answered(client.get(f"/recordings/{i}")).json()["status"] for i in ids]
            if all(state in ("done", "set_aside") for state in states) or time.monotonic() > deadline:
                break
            time.sleep(0.2)
        tally.finish_s.append(time.monotonic() - restarted)
        tally.lost += len(ids) - sum(state == "done" for state in states)
        client.close()
        store = open_store(store_url)
        try:
            tally.duplicated += max(0, store.count("results") - 2 * len(ids))
            tally.lost += max(0, len(ids) - store.count("recordings"))
        finally:
            store.close()
        tally.runs += 1
    finally:
        for process in (server, worker):
            if process is not None and process.poll() is None:
                process.send_signal(signal.SIGTERM)
                try:
                    process.wait(10)
                except subprocess.TimeoutExpired:
                    process.kill()


def _median(values: list[float]) -> str:
    return f"{sorted(values)[len(values) // 2]:.1f}" if values else "-"


def document(tallies: dict[str, Tally], note: str) -> str:
    moment = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        START,
        f"Written by `make bench-kill` (`python -m benchmarks.service_kill`) on {moment}, Python "
        f"{platform.python_version()}, 2 cores (shared machine). {note}",
        "",
        "| store | runs | server kills | worker kills | uploads | lost | results duplicated | 5xx "
        "| processes "
        "left behind | restarts failed | restart to healthy [s], median | restart to all done [s], median |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, t in tallies.items():
        lines.append(
            f"| {name} | {t.runs} | {t.server_kills} | {t.worker_kills} | {t.uploads} | {t.lost} "
            f"| {t.duplicated} | "
            f"{t.errors_5xx} | {t.left_behind} | {t.restart_failures} | {_median(t.restart_s)} | "
            f"{_median(t.finish_s)} |"
        )
    held = all(
        t.lost == t.duplicated == t.errors_5xx == t.left_behind == t.restart_failures == 0
        for t in tallies.values()
    )
    lines += ["", f"Target (the hardening issue): nothing lost, duplicated or left behind, no 5xx: "
              f"{'met' if held else 'not met'}.", END]  # fmt: skip
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sqlite-runs", type=int, default=20)
    parser.add_argument("--postgresql-runs", type=int, default=5)
    parser.add_argument(
        "--postgres", default=POSTGRES, help="an administrator's URL of the server on loopback"
    )
    parser.add_argument("--outage-cycles", type=int, default=3, help="times PostgreSQL is stopped (0: none)")
    parser.add_argument("--outage-s", type=float, default=20.0, help="how long it is stopped each time [s]")
    parser.add_argument(
        "--disk-full-mib", type=int, default=12, help="the full data folder's size (0: no run)"
    )
    args = parser.parse_args(argv)
    if args.sqlite_runs + args.postgresql_runs > 0:
        _kill_runs(args)
    _outage_runs(args, " ".join(["python -m benchmarks.service_kill", *(argv or sys.argv[1:])]))


def _outage_runs(args: argparse.Namespace, command: str) -> None:
    moment, python = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC"), platform.python_version()
    if args.outage_cycles > 0:
        section = outage_section(
            outage_run(args.postgres, args.outage_cycles, args.outage_s), command, moment, python
        )
        replace_section(DOC, OUTAGE_START, OUTAGE_END, section)
        print(section, flush=True)
    if args.disk_full_mib > 0:
        section = disk_full_section(disk_full_run(args.disk_full_mib, refused=6), command, moment, python)
        replace_section(DOC, DISK_START, DISK_END, section)
        print(section, flush=True)


def _kill_runs(args: argparse.Namespace) -> None:
    tallies: dict[str, Tally] = {}
    note = (
        f"Each run: {UPLOADS} recordings of 6 s uploaded, SIGKILL of the server (even runs) or of the "
        "separate worker (odd runs) once an analysis runs, restart at once on the same port and store."
    )
    with tempfile.TemporaryDirectory() as scratch:
        recordings = _recordings(Path(scratch), UPLOADS, seconds=6.0)
        for name, runs in (("SQLite", args.sqlite_runs), ("PostgreSQL", args.postgresql_runs)):
            tally = tallies.setdefault(name, Tally())
            for run in range(runs):
                folder = Path(scratch) / f"{name}-{run}"
                folder.mkdir()
                database: tuple[str, Any] | None = (
                    (f"sqlite:///{folder / 'store.db'}", None)
                    if name == "SQLite"
                    else postgres_database(args.postgres)
                )
                if database is None:
                    note += " No PostgreSQL server answered: its runs were skipped."
                    break
                url, drop = database
                try:
                    one_run(url, folder, recordings, kill_worker=bool(run % 2), tally=tally)
                finally:
                    if drop is not None:
                        drop()
                print(f"{name} run {run + 1}/{runs}: {tally}", flush=True)
    section = document(tallies, note)
    replace_section(DOC, START, END, section)
    print(section)


if __name__ == "__main__":
    main()
