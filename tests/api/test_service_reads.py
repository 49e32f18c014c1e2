"""The service's reads: results answered as stored, entity tags and 304, keyset pages, keys revoked.

One server for the module (fleets a and b), with one recording analysed, as
test_api's ``running`` fixture; the tests here only read, except the one that
adds and revokes a key of its own.
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Iterator

import httpx
import pytest
import sqlalchemy as sa

from api.reads import KEY_TTL_S, matches
from monitor.store import open_store
from tests.api.test_api import SAMPLES, Server, _upload, _wait_done, two_fleet_server
from tests.jobs.test_batch import IN_LINE


@pytest.fixture(scope="module")
def running(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    server = two_fleet_server(tmp_path_factory.mktemp("reads"))
    with server.client() as client:
        for name in IN_LINE:
            assert _upload(client, SAMPLES / name).status_code == 201
        recording = next(
            r["id"] for r in client.get("/recordings").json()["items"] if r["filename"].startswith("6l32")
        )
        _wait_done(client, recording)
    try:
        yield server
    finally:
        server.kill()


def _analysed(server: Server) -> int:
    with server.client() as client:
        return int(next(r["id"] for r in client.get("/recordings").json()["items"] if r["status"] == "done"))


def _stored_text(server: Server, recording: int, kind: str) -> str:
    """The result's text as the store's column holds it, read with plain SQL."""
    engine = sa.create_engine(server.store_url)
    try:
        with engine.connect() as c:
            return str(
                c.execute(
                    sa.text(
                        "SELECT CAST(document AS TEXT) FROM results WHERE recording_id = :r AND kind = :k"
                    ),
                    {"r": recording, "k": kind},
                ).scalar_one()
            )
    finally:
        engine.dispose()


@pytest.mark.parametrize("kind", ["diagnosis", "spectrum"])
def test_a_result_is_answered_byte_for_byte_as_stored_and_tagged_by_its_digest(
    running: Server, kind: str
) -> None:
    recording = _analysed(running)
    with running.client() as client:
        answer = client.get(f"/recordings/{recording}/{kind}")
    assert answer.status_code == 200 and answer.headers["content-type"] == "application/json"
    stored = _stored_text(running, recording, kind)
    assert answer.content == stored.encode("utf-8")
    assert answer.headers["etag"] == f'"{hashlib.sha256(answer.content).hexdigest()}"'
    assert answer.headers["cache-control"] == "private, no-cache"
    assert answer.headers["vary"] == "X-API-Key, Cookie"  # the key, or a browser's session
    assert answer.json()["recording"] if kind == "diagnosis" else answer.json()["channels"]


@pytest.mark.parametrize("route", ["", "/diagnosis", "/spectrum"])
def test_if_none_match_with_the_current_tag_answers_304_without_a_body(running: Server, route: str) -> None:
    recording = _analysed(running)
    path = f"/recordings/{recording}{route}"
    with running.client() as client:
        first = client.get(path)
        tag = first.headers["etag"]
        for sent in (tag, f"W/{tag}", f'"other", {tag}', "*"):
            again = client.get(path, headers={"If-None-Match": sent})
            assert again.status_code == 304 and again.content == b"", sent
            assert again.headers["etag"] == tag and again.headers["cache-control"] == "private, no-cache"
        for sent in ('"other"', tag.strip('"'), ""):
            assert client.get(path, headers={"If-None-Match": sent}).content == first.content, sent


def test_a_tag_opens_nothing_another_fleet_or_no_key_may_not_read(running: Server) -> None:
    """The key and the fleet are checked before the tag: fleet b with fleet a's current tag gets the
    404 of an unknown id, a request without a key 401, never 304."""
    recording = _analysed(running)
    with running.client("a") as a, running.client("b") as b:
        for route in ("", "/diagnosis", "/spectrum"):
            tag = a.get(f"/recordings/{recording}{route}").headers["etag"]
            answer = b.get(f"/recordings/{recording}{route}", headers={"If-None-Match": tag})
            assert answer.status_code == 404 and answer.json()["error"]["code"] == "not_found"
            anonymous = httpx.get(
                f"{running.url}/recordings/{recording}{route}", headers={"If-None-Match": tag}
            )
            assert anonymous.status_code == 401


def test_a_revoked_key_is_refused_within_the_key_cache_s_time(running: Server) -> None:
    """A key used (so remembered), then revoked in the store as `engine-monitor keys revoke` does it
    from another process: refused with 401 on every read, a conditional one included, once
    KEY_TTL_S has passed since the revocation."""
    recording = _analysed(running)
    store = open_store(running.store_url)
    try:
        key = store.create_key(store.fleet_id("a"), "revoked by the test")
        key_id = max(k.id for k in store.list_keys("a"))
        headers = {"X-API-Key": key}
        tag = httpx.get(f"{running.url}/recordings/{recording}/diagnosis", headers=headers).headers["etag"]
        assert httpx.get(f"{running.url}/recordings", headers=headers).status_code == 200
        assert store.revoke_key(key_id)
    finally:
        store.close()
    revoked = time.monotonic()
    time.sleep(KEY_TTL_S + 0.1)
    for path, extra in (
        ("/recordings", {}),
        (f"/recordings/{recording}", {}),
        (f"/recordings/{recording}/diagnosis", {}),
        (f"/recordings/{recording}/diagnosis", {"If-None-Match": tag}),
        (f"/recordings/{recording}/spectrum", {}),
    ):
        answer = httpx.get(f"{running.url}{path}", headers={**headers, **extra})
        assert answer.status_code == 401 and answer.json()["error"]["code"] == "unknown_key", path
    assert time.monotonic() - revoked < KEY_TTL_S + 5


def test_cursor_pages_give_the_listing_once_in_order(running: Server) -> None:
    with running.client() as client:
        whole = client.get("/recordings").json()
        assert whole["next_cursor"] is None and len(whole["items"]) == 3
        seen = []
        cursor = None
        while True:
            params: dict[str, str | int] = {"limit": 1} | ({"cursor": cursor} if cursor else {})
            page = client.get("/recordings", params=params).json()
            seen += [r["id"] for r in page["items"]]
            assert page["next_offset"] is None or cursor is None
            cursor = page["next_cursor"]
            if cursor is None:
                break
        assert seen == [r["id"] for r in whole["items"]]
        by_offset = client.get("/recordings", params={"limit": 2}).json()
        assert by_offset["next_offset"] == 2 and by_offset["next_cursor"] is not None
        for bad in ("not-a-cursor", "W1sxXV0", "eyJ4IjogMX0", "WyIyMDI2LTAxLTAxIiwgMV0"):
            answer = client.get("/recordings", params={"cursor": bad})
            assert answer.status_code == 422 and answer.json()["error"]["code"] == "invalid_request", bad
            assert "cursor: expected the next_cursor of a previous page" in answer.json()["error"]["message"]


def test_matching_follows_the_weak_comparison_of_if_none_match() -> None:
    assert matches('"a"', '"a"') and matches('W/"a"', '"a"') and matches(' "b" , W/"a" ', '"a"')
    assert matches("*", '"a"')
    assert not matches(None, '"a"') and not matches('"b"', '"a"') and not matches("a", '"a"')
