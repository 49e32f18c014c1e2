"""Input validation at the boundary: impossible recordings, uploads that are not recordings, names.

Each file here is a real recording (a bundled sample) with one field made
impossible, as a hostile or broken acquisition would write it. The service
refuses it at upload with a 4xx whose message names the field, the value
and what was expected, in the product's words (never an exception's class
name); the product's readers, which the command line shares, say the same.
"""

from __future__ import annotations

import copy
import re
import shutil
import sqlite3
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import h5py
import pytest

from monitor.cli import main
from monitor.diagnosis import ANALYSIS_VERSION
from monitor.errors import FormatError
from monitor.io import read_recording
from monitor.io.hdf5 import read_hdf5
from monitor.io.mcap.writer import write_mcap
from monitor.store import open_store
from tests.api.test_api import SAMPLES, Server

SAMPLE = SAMPLES / "7k98mc-baseline.h5"
#: Words of Python's own exceptions that a message in the product's words never holds.
INTERNALS = ("Error", "recursion", "Traceback", "longer than 200 characters")


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    """One server for the module (each test's files are refused, so none sees another's)."""
    folder = tmp_path_factory.mktemp("service")
    url = f"sqlite:///{folder / 'store.db'}"
    store = open_store(url)
    keys = {"a": store.create_key(store.create_fleet("a"))}
    store.close()
    running = Server("", url, folder / "data", keys)
    running.start()
    try:
        yield running
    finally:
        running.kill()


def _edited(folder: Path, name: str, edit: Any) -> Path:
    """A copy of the sample whose HDF5 objects ``edit(file)`` changed."""
    path = folder / name
    shutil.copy(SAMPLE, path)
    with h5py.File(path, "r+") as f:
        edit(f)
    return path


def _first_channel(f: h5py.File) -> h5py.Dataset:
    return f["channels"][next(iter(f["channels"]))]


def _refused(server: Server, path: Path) -> str:
    """Upload ``path``; its 422's message, once checked to be in the product's words with nothing stored."""
    with server.client() as client:
        answer = client.post("/recordings", params={"filename": path.name}, content=path.read_bytes())
        assert answer.status_code == 422, answer.text
        assert answer.json()["error"]["code"] == "not_a_recording"
        assert path.name not in [r["filename"] for r in client.get("/recordings").json()["items"]]
    message = str(answer.json()["error"]["message"])
    assert not any(word in message for word in INTERNALS), message
    assert str(server.data) not in message
    return message


def _clock_left_out(message: str) -> str:
    """``message`` with the machine's clock it quotes (``(2026-11-30T09:09Z)``) left out."""
    return re.sub(r"\(\d{4}-\d\d-\d\dT\d\d:\d\dZ\)", "(clock)", message)


@pytest.mark.parametrize("start", ["9999-12-31T00:00:00Z", "0001-01-01T00:00:00Z"])
def test_a_recording_dated_outside_1980_to_tomorrow_is_refused_here_and_by_the_cli(
    server: Server, tmp_path: Path, start: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """Year 9999 would stay the engine's latest recording for ever; year 1 is before any acquisition.
    The upload's message and the readers' (as ``compare`` prints it) name the field, value and range."""
    path = _edited(tmp_path, "dated.h5", lambda f: f.attrs.__setitem__("start_time", start))
    message = _refused(server, path)
    assert f"start_time {start!r}" in message and "from 1980-01-01 to a day past" in message
    with pytest.raises(FormatError) as refused:
        read_recording(path)
    # the same words, after the file's name; the clock each read (to the minute) may differ by one
    assert _clock_left_out(str(refused.value).split(": ", 1)[1]) in _clock_left_out(message)
    assert main(["compare", str(path)]) == 3  # the command line, in this process
    said = capsys.readouterr().err
    assert "from 1980-01-01 to a day past" in said and "Traceback" not in said, said


def test_a_start_offset_of_1e300_s_is_refused_at_upload(server: Server, tmp_path: Path) -> None:
    path = _edited(
        tmp_path, "offset.h5", lambda f: _first_channel(f).attrs.__setitem__("start_offset_s", 1e300)
    )
    message = _refused(server, path)
    assert "start_offset_s = 1e+300" in message and "within 86400 s" in message


def test_a_recording_stored_with_an_impossible_offset_is_set_aside_at_its_first_attempt(
    server: Server, tmp_path: Path
) -> None:
    """A recording stored before the readers refused it (an older version's upload, a batch): its
    analysis fails on the recording's content, an input fault, so its job is set aside at once, as
    docs/service.md says, not retried three times as if the failure could pass."""
    path = _edited(
        tmp_path, "stored.h5", lambda f: _first_channel(f).attrs.__setitem__("start_offset_s", 1e300)
    )
    kept = server.data / "recordings" / f"{'e' * 64}.h5"
    shutil.copy(path, kept)
    store = open_store(server.store_url)
    try:
        row, _ = store.add_recording(
            store.fleet_id("a"),
            content_hash="e" * 64,
            engine_id="man-b-w-7k98mc",
            filename="stored.h5",
            path=str(kept),
            size_bytes=kept.stat().st_size,
            recorded_at="2026-11-22T10:15:00Z",
        )
        store.enqueue(row.id, ANALYSIS_VERSION)
    finally:
        store.close()
    try:
        _set_aside_at_once(server, row.id)
    finally:  # the module's server is shared: leave no recording for the other tests
        with sqlite3.connect(server.store_url.removeprefix("sqlite:///")) as db:
            db.execute("PRAGMA foreign_keys = ON")  # its job and results go with it
            db.execute("DELETE FROM recordings WHERE id = ?", (row.id,))


def _set_aside_at_once(server: Server, recording: int) -> None:
    """Wait for the recording's first attempt; check it was set aside then, in the product's words."""
    with server.client() as client:
        deadline = time.monotonic() + 60
        body = client.get(f"/recordings/{recording}").json()
        while body["attempts"] == 0 or body["status"] == "running":
            assert time.monotonic() < deadline, body
            time.sleep(0.2)
            body = client.get(f"/recordings/{recording}").json()
        assert (body["status"], body["attempts"]) == ("set_aside", 1), body
        assert "start_offset_s = 1e+300" in body["error"] and str(server.data) not in body["error"]
        diagnosis = client.get(f"/recordings/{recording}/diagnosis")
        assert diagnosis.status_code == 422 and diagnosis.json()["error"]["code"] == "analysis_failed"
        assert "Error" not in diagnosis.json()["error"]["message"]


@pytest.mark.parametrize(("name", "said"), [("..", "'.' and '..'"), ("mb\u202e1", "U+202E")])
def test_a_channel_named_dot_dot_or_with_a_bidirectional_override_is_refused(
    server: Server, tmp_path: Path, name: str, said: str
) -> None:
    """Channel names become topics, plot legends and file names: '..' and a right-to-left override
    (which makes a name display as another) are refused, the channel named with the character's code."""
    path = _edited(tmp_path, "named.h5", lambda f: f["channels"].move(next(iter(f["channels"])), name))
    message = _refused(server, path)
    assert said in message and "expected 1 to 200 printable characters" in message


def test_a_sample_rate_of_zero_is_refused_by_name_not_by_a_division_error(
    server: Server, tmp_path: Path
) -> None:
    path = _edited(tmp_path, "rate.h5", lambda f: _first_channel(f).attrs.__setitem__("sample_rate_hz", 0.0))
    message = _refused(server, path)
    assert "sample_rate_hz = 0.0" in message and "expected a positive rate from 0.001 Hz to 10 MHz" in message


def test_groups_nested_2000_deep_are_refused_by_their_depth(server: Server, tmp_path: Path) -> None:
    def nest(f: h5py.File) -> None:
        group = f.create_group("x_deep")
        for _ in range(2000):
            group = group.create_group("g")

    message = _refused(server, _edited(tmp_path, "deep.h5", nest))
    assert "groups nested more than 8 deep" in message


def test_a_nul_in_the_engine_id_is_refused_as_unprintable(server: Server, tmp_path: Path) -> None:
    """The MCAP metadata holds any string; the reader refuses the NUL by its code, not by a length."""
    recording = copy.copy(read_hdf5(SAMPLE))
    object.__setattr__(recording, "engine_id", "man-b-w-7k98mc\x00x")  # past the validation, as a file can be
    message = _refused(server, write_mcap(recording, tmp_path / "nul.mcap"))
    assert "engine_id" in message and "U+0000" in message


@pytest.mark.parametrize(
    ("body", "content_type", "looks"),
    [
        (b"\x89PNG\r\n\x1a\n" + bytes(64), "image/png", "a PNG image"),
        (b"hello, this is not a recording\n", "text/plain", "text ('hello, this is not a rec'"),
        (bytes(range(256)) * 4, None, "binary data of no format the product knows"),
        (b"%PDF-1.7\n", "application/octet-stream", "a PDF document"),
    ],
)
def test_a_body_that_is_neither_hdf5_nor_mcap_is_refused_by_its_bytes(
    server: Server, body: bytes, content_type: str | None, looks: str
) -> None:
    """Whatever the content type says, the bytes decide: 415, the message says what they look like and
    what was expected; the reader is never started on them."""
    headers = {"Content-Type": content_type} if content_type else {}
    with server.client() as client:
        answer = client.post("/recordings", params={"filename": "x.h5"}, content=body, headers=headers)
        assert answer.status_code == 415, answer.text
        error = answer.json()["error"]
        assert error["code"] == "unsupported_format" and looks in error["message"]
        assert "expected HDF5" in error["message"] and "MCAP" in error["message"]
        assert client.get("/recordings").json()["items"] == []
    assert list((server.data / "incoming").iterdir()) == []


def test_a_recording_sent_with_curl_s_default_form_type_is_accepted_a_multipart_form_is_not(
    server: Server, tmp_path: Path
) -> None:
    """``curl --data-binary @f.h5 URL`` sends application/x-www-form-urlencoded (docs/service.md's
    example): the bytes are a recording's, so it is one. ``curl -F`` (multipart) is still told how to
    send the file. An HDF5 file after a 512-byte user block is HDF5 by its signature, and read."""
    with server.client() as client:
        form = client.post(
            "/recordings",
            params={"filename": "a.h5"},
            files={"file": ("a.h5", SAMPLE.read_bytes())},
        )
        assert form.status_code == 400 and form.json()["error"]["code"] == "form_upload"
        curl = client.post(
            "/recordings",
            params={"filename": SAMPLE.name},
            content=SAMPLE.read_bytes(),
            headers={"Content-Type": "application/x-www-form-urlencoded"},
        )
        assert curl.status_code == 201, curl.text
        blocked = tmp_path / "user-block.h5"
        with h5py.File(blocked, "w", userblock_size=512) as f, h5py.File(SAMPLE) as source:
            for name, value in source.attrs.items():
                f.attrs[name] = value
            source.copy("channels", f)
        with_block = client.post(
            "/recordings", params={"filename": blocked.name}, content=blocked.read_bytes()
        )
        assert with_block.status_code == 201, with_block.text
        assert with_block.json()["engine_id"] == "man-b-w-7k98mc"


def test_the_cli_s_readers_and_the_upload_check_say_alike_what_a_non_recording_looks_like(
    tmp_path: Path,
) -> None:
    """The readers the command line uses and the service's upload check give the same words for a file
    that is not a recording: what its bytes look like, not "unknown signature"."""
    from api.validate import format_refusal

    text = tmp_path / "notes.h5"
    text.write_text("engine log, not a recording\n")
    zeros = tmp_path / "zeros.h5"
    zeros.write_bytes(bytes(1 << 20))
    for path, looks in ((text, "text ('engine log"), (zeros, "binary data of no format the product knows")):
        with pytest.raises(FormatError) as refused:
            read_recording(path)
        assert f"its bytes look like {looks}" in str(refused.value)
        refusal = format_refusal(path)
        assert refusal is not None and f"look like {looks}" in refusal
