"""Fairness and limits of the service: one fleet never stalls another, slow clients are cut off,
declared sizes are checked before anything is read.

Issue 14's probes: two HDF5 files declaring a 10^12-sample dataset made another fleet's upload take
118 s; 45 tiny uploads made a read take 117 s; 300 connections trickling a byte every 2 s were all
held for 60 s.
"""

from __future__ import annotations

import asyncio
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import h5py
import httpx
import numpy as np
import pytest
import uvicorn

from api.app import create_app
from api.settings import Settings
from api.validate import Validation
from monitor.errors import MonitorError
from monitor.store import open_store
from tests.api.test_api import SAMPLES, Server, _free_port, _upload

#: A thread that does not answer in this long is stuck, not slow (each request here takes milliseconds).
STUCK_S = 20.0


@pytest.fixture
def keys(tmp_path: Path) -> dict[str, str]:
    store = open_store(f"sqlite:///{tmp_path / 'store.db'}")
    try:
        return {name: store.create_key(store.create_fleet(name)) for name in ("a", "b")}
    finally:
        store.close()


#: The HDF5 signature: the stand-in validator's bodies begin with it, as the upload checks before validating.
HDF5 = b"\x89HDF\r\n\x1a\n"


def _in_thread(call, *args):  # type: ignore[no-untyped-def]
    """Run ``call`` in a thread; the thread and a box that will hold its result."""
    box: dict[str, object] = {}

    def run() -> None:
        box["result"] = call(*args)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return thread, box


def test_validations_wait_without_threads_and_one_fleet_never_takes_every_slot(
    tmp_path: Path, keys: dict[str, str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Fleet a's validations hang (a stand-in validator that waits to be released) while the server has
    4 threads: fleet b still uploads (its own validation slot) and reads; then fleet a's finish."""
    import api.uploads

    release = threading.Event()
    entered: list[str] = []

    async def validator(path: Path, **_: object) -> Validation:
        body = path.read_bytes()[len(HDF5) :]  # after the signature the upload's check asks for
        entered.append(body[:4].decode())
        while body.startswith(b"SLOW") and not release.is_set():
            await asyncio.sleep(0.01)
        return Validation(True, "man-b-w-7k98mc", "2026-01-01T00:00:00Z", ("x",))

    monkeypatch.setattr(api.uploads, "validate", validator)
    settings = Settings(
        store_url=f"sqlite:///{tmp_path / 'store.db'}",
        data_dir=tmp_path / "data",
        workers=0,
        uploads_per_fleet=8,
    )
    app = create_app(settings)

    async def four_threads(scope, receive, send):  # type: ignore[no-untyped-def]
        import anyio.to_thread

        anyio.to_thread.current_default_thread_limiter().total_tokens = 4  # as a busy server has left
        await app(scope, receive, send)

    port = _free_port()
    server = uvicorn.Server(uvicorn.Config(four_threads, host="127.0.0.1", port=port, log_level="warning"))
    serving = threading.Thread(target=server.run, daemon=True)
    serving.start()
    try:
        deadline = time.monotonic() + STUCK_S
        while not server.started and time.monotonic() < deadline:
            time.sleep(0.02)
        url = f"http://127.0.0.1:{port}"

        def upload(fleet: str, body: bytes) -> int:
            answer = httpx.post(
                f"{url}/recordings",
                params={"filename": "r.h5"},
                content=body,
                headers={"X-API-Key": keys[fleet]},
                timeout=60,
            )
            return answer.status_code

        def read(fleet: str) -> int:
            return httpx.get(f"{url}/recordings", headers={"X-API-Key": keys[fleet]}, timeout=60).status_code

        slow = [_in_thread(upload, "a", HDF5 + b"SLOW" + bytes([i])) for i in range(8)]
        while not entered and time.monotonic() < deadline:
            time.sleep(0.01)
        time.sleep(0.5)  # the other seven arrive and wait for fleet a's slot
        assert entered == ["SLOW"]  # fleet a validates one file at a time: the others wait their turn
        for call, args in ((upload, ("b", HDF5 + b"FAST")), (read, ("b",)), (read, ("a",))):
            thread, box = _in_thread(call, *args)
            thread.join(STUCK_S)
            assert not thread.is_alive(), (
                "another fleet's upload, or a read, waited for fleet a's validations"
            )
            assert box["result"] in (200, 201)
        assert entered.count("SLOW") == 1
        release.set()
        for thread, box in slow:
            thread.join(STUCK_S)
            assert box.get("result") == 201
        assert entered.count("SLOW") == 8
    finally:
        release.set()
        server.should_exit = True
        serving.join(STUCK_S)


@pytest.fixture
def limited(tmp_path: Path, keys: dict[str, str]) -> Iterator[Server]:
    """A server with 2 uploads per fleet, 1 s without bytes and 1000 bytes/s after it."""
    running = Server(
        "",
        f"sqlite:///{tmp_path / 'store.db'}",
        tmp_path / "data",
        keys,
        workers=0,
        extra=("--uploads-per-fleet", "2", "--upload-idle", "1", "--upload-min-rate", "1000"),
    )
    running.start()
    try:
        yield running
    finally:
        running.kill()


def _open_upload(server: Server, fleet: str, length: int, first: bytes = b"\x89HDF") -> socket.socket:
    """An upload whose headers promise ``length`` bytes, of which only ``first`` are sent."""
    host, port = server.url.removeprefix("http://").split(":")
    connection = socket.create_connection((host, int(port)), timeout=STUCK_S)
    connection.sendall(
        (
            f"POST /recordings?filename=slow.h5 HTTP/1.1\r\nHost: {host}\r\n"
            f"X-API-Key: {server.keys[fleet]}\r\nContent-Type: application/octet-stream\r\n"
            f"Content-Length: {length}\r\n\r\n"
        ).encode()
        + first
    )
    return connection


def _answer(connection: socket.socket) -> bytes:
    data = b""
    while b"\r\n\r\n" not in data or not data.rstrip().endswith(b"}"):
        piece = connection.recv(65536)
        if not piece:
            break
        data += piece
    return data


def test_a_silent_upload_and_a_trickle_are_cut_off_and_leave_no_file(limited: Server) -> None:
    silent = _open_upload(limited, "a", 10_000)
    trickle = _open_upload(limited, "b", 10_000)
    started = time.monotonic()
    try:
        trickled = 0
        while time.monotonic() - started < 1.8:  # a byte every 0.1 s: never silent for 1 s, 10 bytes/s
            trickle.sendall(b"x")
            trickled += 1
            time.sleep(0.1)
        answers = {"silent": _answer(silent), "trickle": _answer(trickle)}
    finally:
        silent.close()
        trickle.close()
    assert b"408" in answers["silent"].split(b"\r\n")[0] and b"upload_timeout" in answers["silent"]
    assert b"408" in answers["trickle"].split(b"\r\n")[0] and b"upload_too_slow" in answers["trickle"]
    assert time.monotonic() - started < 10
    assert list((limited.data / "incoming").glob("*")) == []


def test_a_fleet_s_third_upload_at_once_is_refused_and_another_fleet_goes_on(limited: Server) -> None:
    held = [_open_upload(limited, "a", 10_000, b"\x89HDF" * 300) for _ in range(2)]
    try:
        with limited.client("a") as a, limited.client("b") as b:
            deadline = time.monotonic() + STUCK_S
            answer = _upload(a, SAMPLES / "7k98mc-baseline.h5")
            while answer.status_code != 429 and time.monotonic() < deadline:  # until both are in progress
                answer = _upload(a, SAMPLES / "7k98mc-baseline.h5")
            assert answer.status_code == 429 and answer.json()["error"]["code"] == "too_many_uploads"
            assert answer.headers["retry-after"] == "5"
            assert _upload(b, SAMPLES / "6l32-misfire-cyl3.h5").status_code == 201
    finally:
        for connection in held:
            connection.close()


def test_a_file_declaring_far_more_samples_than_it_holds_is_refused_unread(
    limited: Server, tmp_path: Path
) -> None:
    """A dataset declared with 10^12 samples of which none were written: refused by its declared size
    in the time it takes to open it, not after reading a terabyte of fill values."""
    path = tmp_path / "declared.h5"
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "engine-monitor recording"
        f.attrs["format_version"] = 1
        f.attrs["engine_id"] = "man-b-w-7k98mc"
        f.attrs["start_time"] = "2026-01-01T00:00:00Z"
        ds = f.create_group("channels").create_dataset(
            "mb1", shape=(10**12,), dtype=np.float32, chunks=(4096,)
        )
        ds.attrs.update({"kind": "acceleration", "unit": "m/s^2", "sample_rate_hz": 25600.0})
    with limited.client("a") as client:
        started = time.monotonic()
        answer = client.post("/recordings", params={"filename": "declared.h5"}, content=path.read_bytes())
        elapsed = time.monotonic() - started
    assert answer.status_code == 422, answer.text
    message = answer.json()["error"]["message"]
    assert "declare 4000000000000 bytes of samples" in message and "refused unread" in message
    assert elapsed < STUCK_S


def test_the_declared_size_check_passes_real_recordings(tmp_path: Path) -> None:
    """The bundled samples (HDF5) and their MCAP copies (zstd) are far inside the limit."""
    from api.validate import MAX_EXPANSION, _check
    from monitor.io.hdf5 import read_hdf5
    from monitor.io.mcap.writer import write_mcap

    for sample in sorted(SAMPLES.glob("*.h5")):
        mcap = write_mcap(read_hdf5(sample), tmp_path / f"{sample.stem}.mcap")
        for path in (sample, mcap):
            assert _check(str(path), MAX_EXPANSION)["engine_id"]
    with pytest.raises(MonitorError, match="refused unread"):
        _check(str(SAMPLES / "7k98mc-baseline.h5"), 0.5)  # a float32 file holds about its samples' bytes


def test_a_client_that_goes_away_mid_upload_leaves_no_file_and_no_traceback(limited: Server) -> None:
    """Issue 14: each client disconnect logged an ERROR traceback."""
    for _ in range(3):
        connection = _open_upload(limited, "a", 10_000, b"\x89HDF" * 100)
        time.sleep(0.2)
        connection.close()
    time.sleep(0.5)
    with limited.client("a") as client:
        assert client.get("/recordings").status_code == 200
    assert list((limited.data / "incoming").glob("*")) == []
    log = limited.log.read_text(errors="replace")
    assert "Traceback" not in log and "ClientDisconnect" not in log
