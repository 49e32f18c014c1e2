"""Alerts: webhooks get one signed event per new finding, from the service and from the batch, and a
receiver that was down gets its events once it is back.

The receivers are real HTTP servers on loopback (``http.server`` in a thread) that check each
event's signature with ``hmac`` themselves, not with the product's :func:`monitor.report.events.verify`.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import shutil
import socket
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
import uvicorn

from api.app import create_app
from api.settings import Settings
from monitor.cli import main
from monitor.diagnosis.trends import drift
from monitor.jobs.delivery import DeliveryPolicy, deliver_due
from monitor.store import Store, open_store
from monitor.store.webhooks import add_webhook, deliveries
from tests.api.test_api import SAMPLES, _free_port, _upload, _wait_done

SECRET = "s3cret-of-the-receiver-0123456789"
#: The tests' retries: a receiver that is down is tried again within a fraction of a second.
QUICK = DeliveryPolicy(timeout_s=2.0, backoff_s=0.2, max_backoff_s=0.2, max_attempts=100, poll_s=0.1)
WAIT_S = 60.0  # a test that waits this long for an event is stuck, not slow


@dataclass
class Received:
    headers: dict[str, str]
    body: bytes
    signed: bool


@dataclass
class Receiver:
    """An HTTP server on loopback that takes POSTs, checks their signature and keeps them."""

    port: int
    secret: str = SECRET
    events: list[Received] = field(default_factory=list)
    _server: ThreadingHTTPServer | None = None

    def __enter__(self) -> Receiver:
        outer = self

        class Handler(BaseHTTPRequestHandler):
            def do_POST(self) -> None:
                body = self.rfile.read(int(self.headers["Content-Length"]))
                expected = "sha256=" + hmac.new(outer.secret.encode(), body, hashlib.sha256).hexdigest()
                signed = hmac.compare_digest(expected, self.headers.get("X-Engine-Monitor-Signature", ""))
                outer.events.append(Received(dict(self.headers), body, signed))
                self.send_response(204)
                self.end_headers()

            def log_message(self, *_: Any) -> None:
                pass

        self._server = ThreadingHTTPServer(("127.0.0.1", self.port), Handler)
        threading.Thread(target=self._server.serve_forever, daemon=True).start()
        return self

    def __exit__(self, *_: object) -> None:
        assert self._server is not None
        self._server.shutdown()
        self._server.server_close()

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}/hook"

    def wait_for(self, count: int) -> list[Received]:
        deadline = time.monotonic() + WAIT_S
        while len(self.events) < count:
            assert time.monotonic() < deadline, f"{len(self.events)} event(s) came, {count} expected"
            time.sleep(0.05)
        return self.events


def _events(received: list[Received]) -> list[dict[str, Any]]:
    assert all(r.signed for r in received), "an event whose signature is not its body's HMAC"
    return [json.loads(r.body) for r in received]


# ------------------------------------------------------------------------------------ the store
@pytest.fixture
def store(store_url: str) -> Iterator[Store]:
    opened = open_store(store_url)
    try:
        yield opened
    finally:
        opened.close()


def _diagnosed(store: Store, fleet: int, night: float, document: dict[str, Any], engine: str = "e") -> int:
    """A recording of ``night`` (a day apart) whose job completes with ``document``; its id."""
    row, _ = store.add_recording(
        fleet,
        content_hash=hashlib.sha256(f"{fleet}/{engine}/{night}".encode()).hexdigest(),
        engine_id=engine,
        filename=f"night-{night}.h5",
        path=f"/nowhere/night-{night}.h5",
        size_bytes=1,
        recorded_at=(datetime(2026, 1, 1, tzinfo=UTC) + timedelta(days=night)).isoformat(),
    )
    store.enqueue(row.id, "1")
    job = store.claim("1")
    assert job is not None and job.recording_id == row.id
    documents = {"diagnosis": (document.get("status", "healthy"), document)}
    assert store.complete(job, documents)
    assert not store.complete(job, documents)  # done again (a worker that lost its lease): no second result
    return row.id


def _finding(kind: str, subject: str, severity: str) -> dict[str, Any]:
    return {"kind": kind, "subject": subject, "severity": severity, "summary": f"{subject} {severity}"}


def _queued(store: Store, fleet: int, webhook: int) -> list[dict[str, Any]]:
    with store.db.connect() as c:
        rows = deliveries(c, fleet, webhook, limit=500)
    assert rows is not None
    return [json.loads(r.body) for r in reversed(rows)]


def test_each_new_finding_is_queued_once_with_its_diagnosis(store: Store) -> None:
    """New against the engine's previous diagnosis: first seen, or at a higher severity. A finding that
    stays, or eases, is not; a completion repeated queues nothing more; another fleet gets nothing."""
    fleet, other = store.create_fleet("f"), store.create_fleet("g")
    with store.transaction() as c:
        hook = add_webhook(c, fleet, "http://127.0.0.1:9/hook", SECRET).id
        elsewhere = add_webhook(c, other, "http://127.0.0.1:9/other", SECRET).id
    cylinder, bearing = ("cylinder", "cylinder 4"), ("main bearing", "main bearing 5")
    nights = [
        [_finding(*cylinder, "warning")],  # the engine's first diagnosis: new
        [_finding(*cylinder, "warning"), _finding(*bearing, "alarm")],  # the bearing is new
        [_finding(*cylinder, "alarm"), _finding(*bearing, "warning")],  # cylinder worse: new; bearing eased
        [_finding(*cylinder, "alarm")],  # unchanged
    ]
    recordings = [
        _diagnosed(store, fleet, night, {"status": "alarm", "findings": found})
        for night, found in enumerate(nights)
    ]
    events = _queued(store, fleet, hook)
    assert [(e["recording"]["id"], e["finding"]["subject"], e["finding"]["severity"]) for e in events] == [
        (recordings[0], "cylinder 4", "warning"),
        (recordings[1], "main bearing 5", "alarm"),
        (recordings[2], "cylinder 4", "alarm"),
    ]
    assert {e["type"] for e in events} == {"diagnosis.finding"}
    assert len({e["id"] for e in events}) == 3
    assert _queued(store, other, elsewhere) == []
    # a recording of an earlier time diagnosed late is compared with the one just before it (night 0's)
    late = _diagnosed(
        store,
        fleet,
        0.5,
        {"status": "alarm", "findings": [_finding(*cylinder, "warning"), _finding(*bearing, "alarm")]},
    )
    events = _queued(store, fleet, hook)
    assert len(events) == 4
    assert (events[-1]["recording"]["id"], events[-1]["finding"]["subject"]) == (late, "main bearing 5")


def test_a_trend_finding_is_queued_at_the_recording_that_finds_it(
    store: Store, rng: np.random.Generator
) -> None:
    """Cylinder 1's strength falls by five sigmas from night 14: one trend event, on the first night whose
    trend (the nights up to it) finds the drift, worked out here by running the rule on each prefix."""
    fleet = store.create_fleet("f")
    with store.transaction() as c:
        hook = add_webhook(c, fleet, "http://127.0.0.1:9/hook", SECRET).id
    values = 1.0 + 0.01 * rng.standard_normal(26)
    values[14:] -= 0.05
    times = [datetime(2026, 1, 1, tzinfo=UTC) + timedelta(days=n) for n in range(values.size)]
    found_on = next(n for n in range(values.size) if drift(times[: n + 1], list(values[: n + 1])) is not None)
    recordings = [
        _diagnosed(
            store, fleet, n, {"status": "healthy", "findings": [], "cylinder_balance": {"relative": [v]}}
        )
        for n, v in enumerate(values.tolist())
    ]
    events = _queued(store, fleet, hook)
    assert [(e["type"], e["finding"]["subject"], e["recording"]["id"]) for e in events] == [
        ("trend.finding", "cylinder 1 strength", recordings[found_on])
    ]
    assert events[0]["finding"]["direction"] == "down"


def test_two_senders_post_each_event_once(store: Store) -> None:
    """Two passes at once (a service and a batch) never post the same delivery twice: each is claimed."""
    fleet = store.create_fleet("f")
    with Receiver(_free_port()) as receiver:
        with store.transaction() as c:
            hook = add_webhook(c, fleet, receiver.url, SECRET).id
        for night in range(8):
            _diagnosed(
                store,
                fleet,
                night,
                {"status": "alarm", "findings": [_finding("cylinder", f"c{night}", "alarm")]},
                engine=f"e{night}",
            )
        passes = [threading.Thread(target=deliver_due, args=(store, QUICK)) for _ in range(2)]
        for thread in passes:
            thread.start()
        for thread in passes:
            thread.join(WAIT_S)
        events = _events(receiver.wait_for(8))
    assert sorted(e["finding"]["subject"] for e in events) == [f"c{n}" for n in range(8)]
    with store.db.connect() as c:
        log = deliveries(c, fleet, hook)
    assert log is not None and {(d.state, d.attempts) for d in log} == {("delivered", 1)}


# ---------------------------------------------------------------------------------- the service
@pytest.fixture
def keys(tmp_path: Path) -> dict[str, str]:
    store = open_store(f"sqlite:///{tmp_path / 'store.db'}")
    try:
        return {name: store.create_key(store.create_fleet(name)) for name in ("a", "b")}
    finally:
        store.close()


def test_webhooks_are_the_fleet_s_own_and_bad_ones_are_refused(tmp_path: Path, keys: dict[str, str]) -> None:
    """Registration checks the URL and the secret and stores nothing it refuses; the secret is answered
    once; another fleet's webhook answers 404 on every route, as an unknown one."""
    with _serving(tmp_path, workers=0) as url, httpx.Client(base_url=url, timeout=60) as client:
        a, b = ({"X-API-Key": keys[f]} for f in ("a", "b"))
        for url in (
            "ftp://host/x",
            "http:///x",
            "https://user:pw@host/x",
            "http://host/x#f",
            "x",
            "http://h:99999/",
            "http://host/" + "x" * 2048,
            "http://host/a b",
            "http://hôte/x",
        ):
            answer = client.post("/webhooks", json={"url": url}, headers=a)
            assert answer.status_code == 422, url
            assert answer.json()["error"]["code"] in ("invalid_webhook", "invalid_request"), answer.text
        assert (
            client.post("/webhooks", json={"url": "http://h/", "secret": "short"}, headers=a).status_code
            == 422
        )
        assert client.get("/webhooks", headers=a).json() == []
        made = client.post("/webhooks", json={"url": "https://alerts.example.com/hook"}, headers=a)
        assert made.status_code == 201 and len(made.json()["secret"]) >= 32
        hook = made.json()["id"]
        listed = client.get("/webhooks", headers=a).json()
        assert [h["id"] for h in listed] == [hook] and "secret" not in listed[0]
        assert "secret" not in client.get(f"/webhooks/{hook}", headers=a).json()
        for method, path in (("GET", ""), ("GET", "/deliveries"), ("DELETE", "")):
            theirs = client.request(method, f"/webhooks/{hook}{path}", headers=b)
            unknown = client.request(method, f"/webhooks/{hook + 1000}{path}", headers=b)
            assert theirs.status_code == unknown.status_code == 404
            assert theirs.json()["error"]["message"].replace(str(hook), "N") == unknown.json()["error"][
                "message"
            ].replace(str(hook + 1000), "N")
        assert client.get("/webhooks", headers=b).json() == []
        assert client.delete(f"/webhooks/{hook}", headers=a).status_code == 204
        assert client.get(f"/webhooks/{hook}", headers=a).status_code == 404
        assert client.get("/webhooks", headers=a).json() == []


@contextmanager
def _serving(tmp_path: Path, workers: int) -> Iterator[str]:
    """The service (``workers`` analysis processes, quick retries) in a thread; its URL."""
    settings = Settings(
        store_url=f"sqlite:///{tmp_path / 'store.db'}",
        data_dir=tmp_path / "data",
        workers=workers,
        alerts=QUICK,
    )
    port = _free_port()
    server = uvicorn.Server(
        uvicorn.Config(create_app(settings), host="127.0.0.1", port=port, log_level="warning")
    )
    serving = threading.Thread(target=server.run, daemon=True)
    serving.start()
    deadline = time.monotonic() + WAIT_S
    while not server.started:
        assert time.monotonic() < deadline, "the service did not start"
        time.sleep(0.02)
    try:
        yield f"http://127.0.0.1:{port}"
    finally:
        server.should_exit = True
        serving.join(WAIT_S)


@pytest.fixture
def service(tmp_path: Path, keys: dict[str, str]) -> Iterator[str]:
    """The service with one analysis worker."""
    with _serving(tmp_path, workers=1) as url:
        yield url


def test_the_service_posts_a_new_finding_to_a_receiver_once_it_is_back(
    service: str, keys: dict[str, str]
) -> None:
    """A webhook whose receiver is down (its port bound, not listening: refused) when the worker stores a
    misfire's diagnosis: the delivery log shows the failed attempts; once the receiver listens, it gets
    the one event, signed, and no other."""
    with socket.socket() as down:  # closed by then, or if the test fails before: no socket left behind
        down.bind(("127.0.0.1", 0))
        port = down.getsockname()[1]
        with httpx.Client(base_url=service, headers={"X-API-Key": keys["a"]}, timeout=60) as client:
            hook = client.post("/webhooks", json={"url": f"http://127.0.0.1:{port}/hook", "secret": SECRET})
            assert hook.status_code == 201 and hook.json()["secret"] == SECRET
            log = f"/webhooks/{hook.json()['id']}/deliveries"
            recording = int(_upload(client, SAMPLES / "7k98mc-misfire-cyl4.h5").json()["id"])
            assert _wait_done(client, recording)["diagnosis_status"] == "alarm"
            deadline = time.monotonic() + WAIT_S
            while not (entries := client.get(log).json()) or entries[0]["attempts"] < 2:
                assert time.monotonic() < deadline, "no attempt was made"
                time.sleep(0.05)
            assert entries[0]["state"] == "pending" and "no connection" in entries[0]["last_error"]
            assert entries[0]["last_status"] is None
            down.close()
            with Receiver(port) as receiver:
                (event,) = _events(receiver.wait_for(1))
                time.sleep(10 * QUICK.poll_s + QUICK.backoff_s)  # time for a second event, if one were sent
                assert len(receiver.events) == 1
            (entry,) = client.get(log).json()
    assert event["type"] == "diagnosis.finding" and event["recording"]["id"] == recording
    assert (event["finding"]["subject"], event["finding"]["severity"]) == ("cylinder 4", "alarm")
    assert event["fleet"] == "a" and event["engine_id"] == "man-b-w-7k98mc"
    headers = receiver.events[0].headers
    assert headers["X-Engine-Monitor-Delivery"] == str(entry["id"])
    assert headers["X-Engine-Monitor-Event"] == event["id"] == entry["event_id"]
    assert abs(int(headers["X-Engine-Monitor-Timestamp"]) - time.time()) < WAIT_S
    assert entry["body"].encode() == receiver.events[0].body  # the log holds the bytes that were signed
    assert entry["state"] == "delivered" and entry["last_status"] == 204 and entry["attempts"] >= 3


# ------------------------------------------------------------------------------------ the batch
def test_the_batch_posts_its_new_findings_before_it_exits(tmp_path: Path) -> None:
    """``engine-monitor batch`` diagnoses a misfire and has posted its one new finding when it returns;
    run again, it diagnoses nothing and posts nothing."""
    url = f"sqlite:///{tmp_path / 'store.db'}"
    folder = tmp_path / "night"
    folder.mkdir()
    shutil.copy(SAMPLES / "7k98mc-misfire-cyl4.h5", folder)
    store = open_store(url)
    with Receiver(_free_port()) as receiver:
        try:
            with store.transaction() as c:
                add_webhook(c, store.create_fleet("ships"), receiver.url, SECRET)
        finally:
            store.close()
        command = ["batch", str(folder), "--store", url, "--fleet", "ships", "--workers", "1", "--json"]
        assert main(command) == 2  # an alarm
        (event,) = _events(receiver.events)  # already there: posted before the batch returned
        assert main(command) == 2
        assert len(receiver.events) == 1
    assert (event["type"], event["finding"]["subject"], event["finding"]["severity"]) == (
        "diagnosis.finding",
        "cylinder 4",
        "alarm",
    )
