"""The service as its operator and a first visitor meet it: its root, its documentation's text, the lines
its log promises, and its shutdown. Each against a real server on loopback (tests/api/test_api.py's)."""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

import httpx
import pytest

from monitor.store import open_store
from tests.api.test_api import (
    ROOT,
    SAMPLES,
    Server,
    _free_port,
    _upload,
    _upload_and_wait_running,
    _wait_done,
)

#: reStructuredText that the docs page (Markdown) would show as typed
_RST = re.compile(r":(mod|attr|func|class|meth|data|obj|exc):`|``")


@pytest.fixture
def live(tmp_path: Path) -> Iterator[Server]:
    """A server with one analysis process and a fleet 'a', its log beside its data folder."""
    url = f"sqlite:///{tmp_path / 'store.db'}"
    store = open_store(url)
    keys = {"a": store.create_key(store.create_fleet("a"))}
    store.close()
    running = Server("", url, tmp_path / "data", keys)
    running.start()
    try:
        yield running
    finally:
        running.kill()


def _descriptions(document: Any) -> list[str]:
    if isinstance(document, dict):
        found = [v for k, v in document.items() if k == "description" and isinstance(v, str)]
        return found + [d for v in document.values() for d in _descriptions(v)]
    if isinstance(document, list):
        return [d for v in document for d in _descriptions(v)]
    return []


def _wait_for_line(server: Server, pattern: str, timeout: float = 30) -> str:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        log = server.log.read_text()
        if re.search(pattern, log):
            return log
        time.sleep(0.1)
    raise AssertionError(f"no line matching {pattern!r} in the server's log:\n{server.log.read_text()}")


def test_the_root_sends_a_browser_to_the_pages_and_tells_a_client_where_to_go(live: Server) -> None:
    """``GET /`` without a key: a browser is redirected to /ui; an API client gets JSON naming the entry
    points, each of which answers there."""
    browser = httpx.get(f"{live.url}/", headers={"Accept": "text/html,application/xhtml+xml"})
    assert browser.status_code == 303 and browser.headers["location"] == "/ui"
    client = httpx.get(f"{live.url}/")
    assert client.status_code == 200 and client.headers["content-type"] == "application/json"
    pointer = client.json()
    assert {pointer[k] for k in ("ui", "docs", "openapi", "health")} == {
        "/ui",
        "/docs",
        "/openapi.json",
        "/health",
    }
    assert httpx.get(f"{live.url}{pointer['health']}").status_code == 200
    with live.client() as keyed:
        assert keyed.get(pointer["openapi"]).json()["info"]["title"] == "engine-monitor"


def test_the_openapi_descriptions_are_markdown_not_restructured_text(live: Server) -> None:
    """The docs page renders the OpenAPI descriptions (the app's module docstring, the routes') as
    Markdown: no reStructuredText role or double backquote may reach it, as code spans instead."""
    with live.client() as client:
        document = client.get("/openapi.json").json()
    texts = _descriptions(document)
    assert document["info"]["description"] in texts and len(texts) > 10
    shown = [t for t in texts if _RST.search(t)]
    assert shown == [], shown
    assert "`api.auth`" in document["info"]["description"]  # the role's target kept, as code


def test_the_log_has_each_job_state_and_an_upload_whose_client_went_away(live: Server) -> None:
    """The lines docs/service.md promises: ``job=... state=...`` per change of a job's state, and one line
    (not a traceback) for an upload whose client went away mid-body."""
    with live.client() as client:
        recording = _upload(client, SAMPLES / "6l32-misfire-cyl3.h5").json()["id"]
        assert _wait_done(client, recording)["status"] == "done"
    log = _wait_for_line(live, rf"job=\d+ recording={recording} attempt=1 state=done")
    assert re.search(rf"job=\d+ recording={recording} attempt=1 state=running", log), log
    key = live.keys["a"]
    address = urlsplit(live.url)
    with socket.create_connection((address.hostname, address.port)) as raw:
        raw.sendall(
            b"POST /recordings?filename=cut.h5 HTTP/1.1\r\nHost: x\r\nX-API-Key: " + key.encode() + b"\r\n"
            b"Content-Type: application/octet-stream\r\nContent-Length: 1000000\r\n\r\n" + b"\x89HDF" * 1000
        )
        time.sleep(0.3)  # the server has begun the body
    log = _wait_for_line(live, r"filename='cut.h5': the client went away; nothing kept")
    assert "Traceback" not in log, log
    # the line is logged before the handler's ``finally`` removes the part file: allow it that moment
    deadline = time.monotonic() + 5.0
    while list((live.data / "incoming").glob("*.part")) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert list((live.data / "incoming").glob("*.part")) == []


def test_a_server_stopped_mid_analysis_exits_cleanly_without_leaked_semaphores(live: Server) -> None:
    """SIGTERM (as ``docker compose stop`` sends) while an analysis runs: the server shuts down, exits
    with status 0, leaves no process, and the resource tracker finds nothing of it to clean up (it says
    "leaked semaphore objects" when the analysis pool's queues outlive an exit that skipped the exit
    handlers)."""
    with live.client() as client:
        _upload_and_wait_running(client, live.data.parent)
    assert live.process is not None
    pid = live.process.pid
    os.kill(pid, signal.SIGTERM)
    status = live.process.wait(timeout=60)
    from monitor.runtime.processes import session_processes

    deadline = time.monotonic() + 30
    while session_processes(pid) and time.monotonic() < deadline:  # the tracker writes as it ends
        time.sleep(0.1)
    assert session_processes(pid) == []
    log = live.log.read_text()
    assert "Finished server process" in log, log
    assert "leaked" not in log and "resource_tracker" not in log, log
    assert status == 0, log


def _catches_sigterm(pid: int) -> bool:
    """Whether the process has a handler of its own for SIGTERM (Linux's ``SigCgt`` mask)."""
    status = Path(f"/proc/{pid}/status").read_text()
    mask = next(line.split()[1] for line in status.splitlines() if line.startswith("SigCgt:"))
    return bool(int(mask, 16) >> (signal.SIGTERM - 1) & 1)


def _stopped_while_loading(command: list[str], log: Path) -> str:
    """Start ``engine-monitor COMMAND``, send it SIGTERM as soon as it has a handler for it, and return what
    it said, after checking that it exited with status 0 and without a traceback."""
    with open(log, "wb") as out:
        process = subprocess.Popen(
            [sys.executable, "-m", "monitor", *command],
            stdout=out,
            stderr=subprocess.STDOUT,
            start_new_session=True,
            cwd=ROOT,
        )
    try:
        deadline = time.monotonic() + 60
        while process.poll() is None and not _catches_sigterm(process.pid):
            assert time.monotonic() < deadline, log.read_text()
            time.sleep(0.005)
        process.send_signal(signal.SIGTERM)
        status = process.wait(timeout=30)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
    said = log.read_text()
    assert status == 0, said
    assert "Traceback" not in said and "Exception ignored" not in said, said
    return said


@pytest.mark.skipif(
    not Path("/proc/self/status").exists() and not os.environ.get("CI"), reason="needs Linux's /proc"
)
def test_a_server_stopped_while_it_loads_exits_cleanly(tmp_path: Path) -> None:
    """SIGTERM as soon as ``serve`` takes it, while it still loads uvicorn and the service (a container
    stopped right after its start): it must take it before that loading, which lasts seconds, and exit
    with status 0 without a traceback, never having served. Killed by the signal (status -15) until it
    did."""
    store = f"sqlite:///{tmp_path / 'store.db'}"
    command = ["serve", "--port", str(_free_port()), "--store", store, "--data", str(tmp_path / "data")]
    said = _stopped_while_loading(command, tmp_path / "server.log")
    # stopped while it loaded: before serve says its connection limits, long before uvicorn starts
    assert "connections:" not in said and "Started server process" not in said, said


@pytest.mark.skipif(
    not Path("/proc/self/status").exists() and not os.environ.get("CI"), reason="needs Linux's /proc"
)
def test_a_worker_stopped_while_it_loads_exits_cleanly_without_claiming_a_job(tmp_path: Path) -> None:
    """SIGTERM as soon as ``worker`` takes it, while it still loads the store and the analyses: status 0,
    no traceback, and it never started (it says how many processes it runs only once started). Killed
    by the signal (status -15) while it took SIGTERM only after loading."""
    store = f"sqlite:///{tmp_path / 'store.db'}"
    command = ["worker", "--store", store, "--data", str(tmp_path / "data")]
    said = _stopped_while_loading(command, tmp_path / "worker.log")
    assert "process(es) on" not in said, said


#: a process with serve's SIGTERM handler, stopped by SIGTERM, whose exit handler is sent SIGTERM again
_STOPPED_TWICE = """
import atexit, os, signal, time
from monitor.cli.service import _exit_on_sigterm

def cleanup():
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(0.1)
    print("cleaned up; SIGTERM ignored:", signal.getsignal(signal.SIGTERM) == signal.SIG_IGN, flush=True)

atexit.register(cleanup)
signal.signal(signal.SIGTERM, _exit_on_sigterm)
signal.raise_signal(signal.SIGTERM)
print("went on after SIGTERM", flush=True)
"""


def test_a_second_sigterm_while_serve_exits_is_ignored() -> None:
    """serve's SIGTERM handler: the first SIGTERM is a normal exit (status 0); one more while the exit
    handlers run (the analysis pool's release among them) neither interrupts them nor, ignored by the
    system rather than by a handler the interpreter's finalization takes away, kills the process."""
    done = subprocess.run(
        [sys.executable, "-c", _STOPPED_TWICE], capture_output=True, text=True, cwd=ROOT, timeout=60
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout == "cleaned up; SIGTERM ignored: True\n", done.stdout + done.stderr
    assert "Traceback" not in done.stderr and "ignored" not in done.stderr, done.stderr
