"""The service's error answers, made in one place (api/errors.py): the product's refusal of a request's
input, a malformed parameter, a method a path does not take; and the parameters' parsers."""

from __future__ import annotations

from collections.abc import Iterator
from datetime import UTC, datetime

import httpx
import pytest

from api import parameters
from api.errors import ApiError
from monitor.store import open_store
from tests.api.test_api import Server


@pytest.fixture(scope="module")
def client(tmp_path_factory: pytest.TempPathFactory) -> Iterator[httpx.Client]:
    """A server without analysis processes, and a client with fleet a's key."""
    folder = tmp_path_factory.mktemp("errors")
    url = f"sqlite:///{folder / 'store.db'}"
    store = open_store(url)
    try:
        keys = {"a": store.create_key(store.create_fleet("a"))}
    finally:
        store.close()
    running = Server("", url, folder / "data", keys, workers=0)
    running.start()
    try:
        with running.client() as client:
            yield client
    finally:
        running.kill()


def test_an_engine_description_the_product_refuses_answers_422_with_its_message(client: httpx.Client) -> None:
    answer = client.post("/engines", json={"description": {"id": "x", "cylinders": "many"}})
    assert answer.status_code == 422
    error = answer.json()["error"]
    assert error["code"] == "invalid_engine" and "cylinders" in error["message"]


def test_a_malformed_since_cursor_or_time_answers_422_naming_it(client: httpx.Client) -> None:
    trend = client.get("/engines/man-b-w-7k98mc/trend", params={"since": "yesterday"}).json()["error"]
    assert trend["code"] == "bad_since" and "since='yesterday'" in trend["message"]
    cursor = client.get("/recordings", params={"cursor": "nonsense"}).json()["error"]
    assert cursor["code"] == "invalid_request" and cursor["message"].startswith("cursor:")
    until = client.get("/recordings", params={"until": "soon"}).json()["error"]
    assert until["code"] == "invalid_request" and until["message"].startswith("until:")


@pytest.mark.parametrize(
    ("method", "path", "allowed"),
    [
        ("DELETE", "/recordings", "GET, POST"),
        ("PATCH", "/engines/x", "GET, PUT"),
        ("PATCH", "/webhooks/1", "DELETE, GET"),
        ("PUT", "/engines/x/baseline", "GET, POST"),
        ("PUT", "/health", "GET"),
    ],
)
def test_a_method_a_path_does_not_take_answers_405_with_every_method_it_takes(
    client: httpx.Client, method: str, path: str, allowed: str
) -> None:
    answer = client.request(method, path)
    assert answer.status_code == 405 and answer.json()["error"]["code"] == "method_not_allowed"
    assert answer.headers["Allow"] == allowed


def test_since_is_iso_8601_utc_unless_it_names_a_zone() -> None:
    assert parameters.parse_since("2026-11-01") == datetime(2026, 11, 1, tzinfo=UTC)
    assert parameters.parse_since("2026-11-01T06:00:00Z") == datetime(2026, 11, 1, 6, tzinfo=UTC)
    assert parameters.since(None) is None
    with pytest.raises(ValueError):
        parameters.parse_since("last week")
    with pytest.raises(ApiError) as refused:
        parameters.since("last week")
    assert (refused.value.status, refused.value.code) == (422, "bad_since")


def test_a_cursor_stands_for_the_upload_time_and_id_it_was_made_of() -> None:
    uploaded_at = datetime(2026, 11, 1, 6, 30, tzinfo=UTC)
    assert parameters.cursor(parameters.next_cursor(uploaded_at, 42)) == (uploaded_at, 42)
