"""A flood of idle connections against the server, ``/health`` timed meanwhile (``make bench-kill``).

``python -m benchmarks.service_flood [--connections 20000] [--clients 2] [--seconds 30]``. For each
of its scenarios (serve's default limits; the per-client cap lifted and the timeouts long, so that
the cap in all alone holds the flood) it starts ``engine-monitor serve`` on a free loopback port
and a fresh SQLite store, then CLIENTS processes, each from its own loopback address (127.0.0.2,
127.0.0.3, ...), each opening its share of CONNECTIONS at once (its open-file limit raised to hold
them) and sending nothing; in half the scenarios they also re-open, once a second, every connection
the server closed. Meanwhile it asks ``GET /health`` on a new connection from 127.0.0.1 four times
a second (5 s timeout) and samples the server's open descriptors and resident memory. Counted: the
connections the server held (its descriptors beyond those it had before the flood), its sheds (from
its log), the refusals (503) and timeouts (408) the clients got, /health's answers and latency. It
writes its section of docs/service.md.
"""

from __future__ import annotations

import argparse
import errno
import json
import os
import platform
import re
import resource
import select
import socket
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

from benchmarks.sections import replace_section
from benchmarks.service_load import free_port

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "service.md"
START, END = "<!-- service-flood: start -->", "<!-- service-flood: end -->"
STARTUP_S = 60.0
HEALTH_EVERY_S = 0.25
HEALTH_TIMEOUT_S = 5.0
TARGET_S = 1.0  # the acceptance: /health answers within this while the flood is held
IN_FLIGHT = 256  # a client's connection attempts under way at once (its handshakes not yet done)
IP_BIND_ADDRESS_NO_PORT = getattr(socket, "IP_BIND_ADDRESS_NO_PORT", 24)  # Linux's value

#: serve's options that leave the cap in all alone to hold the flood
CAP_ALONE = ("--connections-per-client", "0", "--idle-timeout", "600", "--header-timeout", "600")
#: (name, serve's options, whether the clients re-open what the server closed): the table's rows.
SCENARIOS: tuple[tuple[str, tuple[str, ...], bool], ...] = (
    ("default limits, held", (), False),
    ("cap in all alone, held", CAP_ALONE, False),
    ("default limits, re-opened", (), True),
    ("cap in all alone, re-opened", CAP_ALONE, True),
)


# -- a client process ------------------------------------------------------------------------------


def _raise_nofile(needed: int) -> int:
    """Raise this process's open-file limit to hold ``needed`` descriptors (the hard limit too when
    allowed, as root); the soft limit it got."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    for limits in ((max(soft, needed), max(hard, needed)), (hard, hard)):
        try:
            resource.setrlimit(resource.RLIMIT_NOFILE, limits)
            break
        except (ValueError, OSError):
            continue
    return resource.getrlimit(resource.RLIMIT_NOFILE)[0]


def client(port: int, source: str, count: int, seconds: float, reopen: bool) -> dict[str, int]:
    """Hold ``count`` idle connections from ``source`` for ``seconds``, opened as fast as the server
    completes their handshakes, ``IN_FLIGHT`` at a time (with ``reopen``, re-opening once a second
    the ones the server closed); what it saw."""
    limit = _raise_nofile(count + IN_FLIGHT + 64)
    count = min(count, limit - IN_FLIGHT - 64)
    poller = select.epoll()
    sockets: dict[int, socket.socket] = {}
    pending: set[int] = set()  # handshakes under way
    seen = {"wanted": count, "opened": 0, "connect_errors": 0, "refused_503": 0, "timed_out_408": 0,
            "closed": 0, "held_max": 0}  # fmt: skip

    def open_one() -> None:
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            s.setsockopt(socket.IPPROTO_IP, IP_BIND_ADDRESS_NO_PORT, 1)  # the port chosen at connect
            s.bind((source, 0))
            s.setblocking(False)
            code = s.connect_ex(("127.0.0.1", port))
        except OSError:
            s.close()
            seen["connect_errors"] += 1
            return
        if code not in (0, errno.EINPROGRESS):
            s.close()
            seen["connect_errors"] += 1
            return
        poller.register(s.fileno(), select.EPOLLOUT | select.EPOLLIN | select.EPOLLRDHUP)
        sockets[s.fileno()] = s
        pending.add(s.fileno())

    def closed(fd: int) -> None:
        s = sockets.pop(fd)
        poller.unregister(fd)
        try:
            data = s.recv(64)
        except OSError:
            data = b""
        if fd in pending:
            pending.discard(fd)
            seen["opened"] += bool(data)  # answered (refused) as soon as accepted
        key = {b"HTTP/1.1 503": "refused_503", b"HTTP/1.1 408": "timed_out_408"}.get(data[:12], "closed")
        seen[key] += 1
        s.close()

    started = time.monotonic()
    to_open, reopened, next_pass = count, 0, started + 1.0
    while (now := time.monotonic()) < started + seconds:
        while to_open and len(pending) < IN_FLIGHT:
            open_one()
            to_open -= 1
        for fd, events in poller.poll(0.05):
            if fd in pending and not events & (select.EPOLLIN | select.EPOLLRDHUP | select.EPOLLHUP):
                if sockets[fd].getsockopt(socket.SOL_SOCKET, socket.SO_ERROR):
                    seen["connect_errors"] += 1
                    closed(fd)
                    continue
                pending.discard(fd)  # connected: from now on only its close is awaited
                poller.modify(fd, select.EPOLLIN | select.EPOLLRDHUP)
                seen["opened"] += 1
                continue
            closed(fd)
            reopened += reopen
        seen["held_max"] = max(seen["held_max"], len(sockets) - len(pending))
        if now >= next_pass:
            to_open, reopened, next_pass = to_open + reopened, 0, now + 1.0
    for s in sockets.values():
        s.close()
    return seen


# -- the server and the measurements ---------------------------------------------------------------


@dataclass
class Row:
    """What one scenario found."""

    name: str
    options: tuple[str, ...]
    reopen: bool
    cap: str = ""
    nofile: str = ""
    clients: list[dict[str, int]] = field(default_factory=list)
    descriptors_max: int = 0
    descriptors_idle: int = 0
    rss_max_mb: float = 0.0
    shed: int = 0
    episodes: int = 0
    health_s: list[float] = field(default_factory=list)
    health_failed: int = 0


def _health(port: int) -> float | None:
    started = time.monotonic()
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=HEALTH_TIMEOUT_S) as s:
            s.sendall(b"GET /health HTTP/1.1\r\nHost: bench\r\nConnection: close\r\n\r\n")
            if not s.recv(64).startswith(b"HTTP/1.1 200"):
                return None
    except OSError:
        return None
    return time.monotonic() - started


def _server_sample(pid: int) -> tuple[int, float]:
    """The server's open descriptors and resident memory [MB]."""
    try:
        descriptors = len(list(Path(f"/proc/{pid}/fd").iterdir()))
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return 0, 0.0
    rss = re.search(r"VmRSS:\s+(\d+) kB", status)
    return descriptors, int(rss.group(1)) / 1024 if rss else 0.0


def run_scenario(row: Row, folder: Path, connections: int, clients: int, seconds: float) -> None:
    port = free_port()
    log = folder / "server.log"
    with open(log, "ab") as out:
        server = subprocess.Popen(
            [sys.executable, "-m", "monitor", "serve", "--port", str(port), "--data", str(folder / "data"),
             "--store", f"sqlite:///{folder / 'store.db'}", "--workers", "0", "--no-access-log",
             *row.options],
            stdout=out, stderr=subprocess.STDOUT, cwd=ROOT,
        )  # fmt: skip
    floods: list[subprocess.Popen[str]] = []
    try:
        deadline = time.monotonic() + STARTUP_S
        while _health(port) is None:
            if server.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"the server did not start:\n{log.read_text(errors='replace')}")
            time.sleep(0.2)
        started = re.search(r"connections: at most (\d+).*open-file limit (\d+)", log.read_text())
        row.cap, row.nofile = started.groups() if started else ("?", "?")
        row.descriptors_idle = _server_sample(server.pid)[0]
        share = connections // clients
        for i in range(clients):
            flood = [sys.executable, "-m", "benchmarks.service_flood", "--client", str(port),
                     f"127.0.0.{2 + i}", str(share + (i < connections % clients)), str(seconds),
                     str(int(row.reopen))]  # fmt: skip
            floods.append(subprocess.Popen(flood, stdout=subprocess.PIPE, text=True, cwd=ROOT))
        stop = threading.Event()

        def sample() -> None:
            while not stop.is_set():
                descriptors, rss = _server_sample(server.pid)
                row.descriptors_max = max(row.descriptors_max, descriptors)
                row.rss_max_mb = max(row.rss_max_mb, rss)
                stop.wait(0.5)

        sampler = threading.Thread(target=sample, daemon=True)
        sampler.start()
        while all(flood.poll() is None for flood in floods):
            moment = time.monotonic()
            took = _health(port)
            if took is None:
                row.health_failed += 1
            else:
                row.health_s.append(took)
            time.sleep(max(0.0, HEALTH_EVERY_S - (time.monotonic() - moment)))
        for flood in floods:
            output, _ = flood.communicate(timeout=60)
            row.clients.append(json.loads(output.strip().splitlines()[-1]))
        stop.set()
        sampler.join()
        time.sleep(3.0)  # the server tells the end of its episodes after 2 s without another
    finally:
        for flood in floods:
            if flood.poll() is None:
                flood.kill()
        server.terminate()
        try:
            server.wait(timeout=30)
        except subprocess.TimeoutExpired:
            server.kill()
            server.wait()
    text = log.read_text(errors="replace")
    for line in text.splitlines():  # the server's own lines about its connections
        if "connections: " in line:
            print(f"{row.name}: {line}", flush=True)
    row.shed = sum(int(n) for n in re.findall(r"shed (\d+) idle connections", text))
    row.episodes = len(re.findall(r"closing the oldest idle ones", text))


def _percentile(values: list[float], q: float) -> str:
    if not values:
        return "-"
    ordered = sorted(values)
    return f"{1000 * ordered[min(len(ordered) - 1, int(q * len(ordered)))]:.0f}"


def document(rows: list[Row], connections: int, clients: int, seconds: float, load: float) -> str:
    moment = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        START,
        f"Written by `make bench-kill` (`python -m benchmarks.service_flood`) on {moment}, Python "
        f"{platform.python_version()}, {os.cpu_count()} cores (shared machine: load average "
        f"{load:.1f} over the minute before it began). Each scenario: {connections} idle "
        f"connections held for {seconds:g} s by {clients} client processes (one loopback address "
        f"each), opened as fast as the server completes their handshakes ({IN_FLIGHT} attempts "
        "under way at once per client); in the rows *re-opened*, every connection the server closed "
        "is opened again within a second (a connection-rate flood on top). `GET /health` on a new "
        f"connection every {HEALTH_EVERY_S:g} s from the flood's start ({HEALTH_TIMEOUT_S:g} s "
        "timeout).",
        "",
        "| scenario | serve's options | open-file limit | cap | connections opened | "
        "connections the server held, max | "
        "shed | refused 503 | closed 408 | closed otherwise | /health answered | /health p50 / p99 / "
        "max [ms] | server memory, max [MB] |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        total = {key: sum(c[key] for c in row.clients) for key in row.clients[0]} if row.clients else {}
        held = row.descriptors_max - row.descriptors_idle
        options = " ".join(row.options) or "(none)"
        asked = len(row.health_s) + row.health_failed
        lines.append(
            f"| {row.name} | `{options}` | {row.nofile} | {row.cap} | {total.get('opened', 0)} | {held} | "
            f"{row.shed} | {total.get('refused_503', 0)} | {total.get('timed_out_408', 0)} | "
            f"{total.get('closed', 0)} | {len(row.health_s)} of {asked} | "
            f"{_percentile(row.health_s, 0.5)} / {_percentile(row.health_s, 0.99)} / "
            f"{_percentile(row.health_s, 1.0)} | {row.rss_max_mb:.0f} |"
        )
    held = [r for r in rows if not r.reopen]
    met = all(r.health_s and not r.health_failed and max(r.health_s) < TARGET_S for r in held)
    lines += [
        "",
        f"Target: `/health` answers within {TARGET_S:g} s while {connections} idle connections are "
        f"held (the rows *held*): {'met' if met else 'not met'}. The rows *re-opened* add a "
        "connection rate no target was set for.",
        END,
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--connections", type=int, default=20_000, help="idle connections in all")
    parser.add_argument("--clients", type=int, default=2, help="client processes, one address each")
    parser.add_argument("--seconds", type=float, default=30.0, help="how long each scenario holds them")
    parser.add_argument(
        "--client", nargs=5, metavar=("PORT", "SOURCE", "COUNT", "SECONDS", "REOPEN"), help=argparse.SUPPRESS
    )
    args = parser.parse_args(argv)
    if args.client:  # one of the client processes
        port, source, count, seconds, reopen = args.client
        print(json.dumps(client(int(port), source, int(count), float(seconds), reopen == "1")), flush=True)
        return
    load = os.getloadavg()[0]
    rows = [Row(name, options, reopen) for name, options, reopen in SCENARIOS]
    with tempfile.TemporaryDirectory() as scratch:
        for i, row in enumerate(rows):
            folder = Path(scratch) / str(i)
            folder.mkdir()
            run_scenario(row, folder, args.connections, args.clients, args.seconds)
            print(f"{row.name}: {row}", flush=True)
    section = document(rows, args.connections, args.clients, args.seconds, load)
    replace_section(DOC, START, END, section)
    print(section)


if __name__ == "__main__":
    main()
