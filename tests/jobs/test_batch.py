"""The nightly batch: idempotent, resumable after a crash, failures retried then set aside."""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import replace
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import httpx
import pytest
import sqlalchemy as sa
from hypothesis import example, given
from hypothesis import strategies as st
from PIL import Image

from monitor.cli import main
from monitor.diagnosis import ANALYSIS_VERSION
from monitor.io.hdf5 import read_hdf5, write_hdf5
from monitor.jobs import batch as batch_module
from monitor.jobs.analyse import diagnose_file
from monitor.jobs.batch import run_batch
from monitor.jobs.plots import plot_names
from monitor.jobs.registration import content_hash, register
from monitor.scene import load_scene, simulate
from monitor.store import MAX_ATTEMPTS, open_store

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = ROOT / "recordings" / "samples"
#: the bundled samples of in-line engines, whose counts and verdicts these tests know (a V engine's
#: sample, 12v32-misfire-b3, is diagnosed in tests/cli/test_cli_vee.py)
IN_LINE = ("7k98mc-baseline.h5", "7k98mc-misfire-cyl4.h5", "6l32-misfire-cyl3.h5")
SCENES = ROOT / "recordings" / "scenes"


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    """The three in-line samples, a copy of one under another name, and a file that is no recording."""
    out = tmp_path / "recordings"
    (out / "ship-a").mkdir(parents=True)
    for name in IN_LINE:
        shutil.copy(SAMPLES / name, out / "ship-a" / name)
    shutil.copy(SAMPLES / "7k98mc-baseline.h5", out / "copy-of-baseline.h5")
    (out / "notes.h5").write_text("not a recording")
    return out


def test_a_batch_diagnoses_each_recording_once_and_a_rerun_does_nothing(folder: Path, store_url: str) -> None:
    store = open_store(store_url)
    try:
        fleet = store.create_fleet("ships")
        first = run_batch(store, fleet, path=folder, workers=2)
        assert (first.registered, first.known, first.diagnosed, first.failed) == (3, 1, 3, [])
        assert first.held == 0  # the copy is the same recording, not a job another run holds
        assert [name for name, _ in first.unreadable] == ["notes.h5"]
        assert dict(first.by_engine["man-b-w-7k98mc"]) == {"healthy": 1, "alarm": 1}
        assert dict(first.by_engine["medium-speed-6l32"]) == {"alarm": 1}
        text = first.text()
        assert (
            "7k98mc-misfire-cyl4.h5: cylinder 4 at" in text and "6l32-misfire-cyl3.h5: cylinder 3 at" in text
        )
        again = run_batch(store, fleet, path=folder, workers=2)
        assert (again.registered, again.known, again.diagnosed) == (0, 4, 0)
        # a diagnosis and a spectrum per recording, once each
        assert store.count("results") == 6 and store.count("jobs") == 3 and store.count("recordings") == 3
        recording = next(r for r in store.recordings(fleet) if r.filename == "7k98mc-misfire-cyl4.h5")
        document = store.result(recording.id, ANALYSIS_VERSION, "diagnosis")
        assert document is not None and [f["subject"] for f in document["findings"]] == ["cylinder 4"]
    finally:
        store.close()


def test_a_failing_recording_is_retried_then_set_aside(tmp_path: Path) -> None:
    """A readable recording of an engine nobody describes fails with the reason, each run retries
    it, and after MAX_ATTEMPTS it is set aside and left alone."""
    unknown = tmp_path / "unknown-engine.h5"
    write_hdf5(replace(read_hdf5(SAMPLES / "7k98mc-baseline.h5"), engine_id="unknown-engine"), unknown)
    store = open_store(f"sqlite:///{tmp_path / 's.db'}")
    try:
        fleet = store.create_fleet("ships")
        states = []
        for _ in range(MAX_ATTEMPTS + 1):
            summary = run_batch(store, fleet, path=unknown, workers=1)
            states += [state for _, _, state in summary.failed]
            # failed, then set aside: not diagnosed, 3, and the summary says why on every run
            assert summary.exit_status == 3
            [outcome] = summary.recordings
            assert outcome.status in ("failed", "set_aside") and "unknown-engine" in outcome.error
            if summary.failed:
                assert (
                    "engine 'unknown-engine' is neither in the fleet's engines nor bundled"
                    in summary.failed[0][1]
                )
        assert states == ["queued"] * (MAX_ATTEMPTS - 1) + ["set_aside"]
        assert summary.recordings[0].status == "set_aside" and summary.failed == []  # left alone
        assert "not diagnosed (set aside): unknown-engine.h5" in summary.text()
        assert store.count("results") == 0
    finally:
        store.close()


def test_a_batch_over_the_stores_recordings_since_a_date(tmp_path: Path) -> None:
    store = open_store(f"sqlite:///{tmp_path / 's.db'}")
    try:
        fleet = store.create_fleet("ships")
        path = SAMPLES / "6l32-misfire-cyl3.h5"
        store.add_recording(
            fleet,
            content_hash=content_hash(path),
            engine_id="medium-speed-6l32",
            filename=path.name,
            path=str(path),
            size_bytes=path.stat().st_size,
        )
        tomorrow = datetime.now(UTC) + timedelta(days=1)
        assert run_batch(store, fleet, since=tomorrow).diagnosed == 0
        assert run_batch(store, fleet, since=tomorrow - timedelta(days=2)).diagnosed == 1
        assert store.count("results") == 2
    finally:
        store.close()


def test_a_batch_killed_midway_resumes_without_duplicates(tmp_path: Path) -> None:
    """Six recordings, one worker: the batch process (and its worker) is killed once the first
    results are stored. The next run, started at once, takes back the killed batch's jobs at once
    (their holder, a process of this host, is gone: no waiting for the lease, an hour here),
    finishes the others, and each recording has its two results once."""
    folder = tmp_path / "recordings"
    folder.mkdir()
    scene = load_scene(SCENES / "6l32-baseline.toml").model_copy(update={"duration_s": 3.0})
    for seed in range(6):
        write_hdf5(simulate(scene, seed=100 + seed).recording, folder / f"r{seed}.h5")
    url = f"sqlite:///{tmp_path / 's.db'}"
    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "monitor",
            "batch",
            str(folder),
            "--store",
            url,
            "--workers",
            "1",
            "--data",
            str(tmp_path / "data"),
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
        cwd=ROOT,
    )
    deadline = time.monotonic() + 120
    results = 0
    while time.monotonic() < deadline and process.poll() is None:
        time.sleep(0.2)
        try:
            store = open_store(url)
            results = store.count("results")
            store.close()
        except Exception:  # the batch may be creating the file
            results = 0
        if results >= 2:
            break
    os.killpg(process.pid, signal.SIGKILL)
    process.wait()
    assert 2 <= results < 12, "the batch should have been killed part way"
    store = open_store(url)
    try:
        fleet = store.fleet_id("local")
        started = time.monotonic()
        summary = run_batch(store, fleet, path=folder, workers=2, lease=timedelta(hours=1))
        assert time.monotonic() - started < 120  # it did not wait for the lease (an hour)
        assert 1 <= summary.requeued <= 2 and summary.held == 0  # it keeps two jobs per worker claimed
        assert summary.diagnosed == 6 - results // 2
        assert store.count("results") == 12 and store.count("jobs") == 6
    finally:
        store.close()


def test_a_batch_waits_for_the_jobs_another_run_holds_and_reports_them(tmp_path: Path) -> None:
    """Issue 14: a batch rerun while another run's jobs were running reported them as nothing, exit 0.
    Now it runs its own jobs, then waits: a held job whose holder (another host here) goes silent
    is taken back after the lease (1 s) and run; the summary says so."""
    from monitor.store.schema import jobs

    folder = tmp_path / "recordings"
    folder.mkdir()
    for name in ("7k98mc-baseline.h5", "6l32-misfire-cyl3.h5"):
        shutil.copy(SAMPLES / name, folder / name)
    store = open_store(f"sqlite:///{tmp_path / 's.db'}")
    try:
        fleet = store.create_fleet("ships")
        held_id, _ = register(store, fleet, folder / "6l32-misfire-cyl3.h5")
        job = store.claim_job(store.enqueue(held_id, ANALYSIS_VERSION).id)
        assert job is not None
        with store.transaction() as c:  # a live run on another host holds it, then falls silent
            c.execute(sa.update(jobs).where(jobs.c.id == job.id).values(holder="another-host:7:1"))
        summary = run_batch(store, fleet, path=folder, workers=1, lease=timedelta(seconds=1))
        assert (summary.diagnosed, summary.held, summary.finished_elsewhere, summary.requeued) == (2, 1, 0, 1)
        assert summary.waited_s >= 0.3
        assert "1 job(s) were running in another process when this run started" in summary.text()
        assert store.job(held_id, ANALYSIS_VERSION).state == "done"  # type: ignore[union-attr]
        assert store.count("results") == 4
    finally:
        store.close()


def test_the_batch_command_prints_the_summary(
    folder: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    url = f"sqlite:///{tmp_path / 's.db'}"
    data = tmp_path / "data"
    # notes.h5 is no recording: the batch could not diagnose it, 3
    assert main(["batch", str(folder), "--store", url, "--workers", "1", "--data", str(data)]) == 3
    # the plots are kept where the service keeps them, named after their recordings' files (a copy of
    # one content is one recording, under the name it was first found by)
    store = open_store(url)
    try:
        registered = [Path(r.filename).stem for r in store.recordings(store.fleet_id("local"))]
    finally:
        store.close()
    assert len(registered) == 3
    plots = {p.name for p in (data / "plots").glob("*.png")}
    assert plots == {f"{stem}-v{ANALYSIS_VERSION}.png" for stem in registered}
    out = capsys.readouterr().out
    assert "3 recording(s) registered, 1 already known, 3 diagnosed, 0 failed" in out
    assert "man-b-w-7k98mc: 1 healthy, 1 alarm" in out
    assert main(["batch", "--since", "yesterday", "--store", url, "--data", str(data)]) == 3
    assert "expected a date or time in ISO 8601" in capsys.readouterr().err


def test_a_batch_on_a_dask_cluster_survives_a_worker_killed_midway(tmp_path: Path) -> None:
    """A local Dask cluster of two worker processes; one is killed once the first results are stored.
    The scheduler runs its tasks again on the other (or on the worker its nanny restarts): every
    recording is diagnosed, each result stored once."""
    import threading

    import distributed

    folder = tmp_path / "recordings"
    folder.mkdir()
    scene = load_scene(SCENES / "6l32-baseline.toml").model_copy(update={"duration_s": 3.0})
    for seed in range(8):
        write_hdf5(simulate(scene, seed=200 + seed).recording, folder / f"r{seed}.h5")
    store = open_store(f"sqlite:///{tmp_path / 's.db'}")
    fleet = store.create_fleet("ships")
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        pids = list(client.run(os.getpid).values())
        outcome: dict[str, object] = {}

        def batch() -> None:
            outcome["summary"] = run_batch(store, fleet, path=folder, scheduler=cluster.scheduler_address)

        thread = threading.Thread(target=batch)
        thread.start()
        deadline = time.monotonic() + 120
        while store.count("results") < 2 and time.monotonic() < deadline and thread.is_alive():
            time.sleep(0.05)
        killed = store.count("results") < 16
        os.kill(pids[0], signal.SIGKILL)
        thread.join(timeout=300)
    try:
        assert killed, "the worker should have been killed part way"
        summary = outcome["summary"]
        assert summary.diagnosed == 8 and summary.failed == []  # type: ignore[attr-defined]
        assert store.count("results") == 16 and store.count("jobs") == 8
    finally:
        store.close()


# ------------------------------------------------------------------ exit status, --json, plot names
def _batch_json(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, dict[str, Any]]:
    """Run ``batch --json``: its exit status and its document (stdout holds the document alone)."""
    status = main([*argv, "--json"])
    return status, json.loads(capsys.readouterr().out)


def test_the_batch_exits_with_the_worst_over_its_scope_and_says_so_in_json(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 16. Night 1, the healthy baseline: 0. Night 2 adds the cylinder 4 misfire, under the
    same file name in its own folder: 2, an alarm, with its finding as the store keeps it, and its plot
    named after the file with its id added (the name is taken). Run again, nothing to do: still 2 (the
    alarm was found before this run). A file that is no recording added: 3."""
    baseline = tmp_path / "baseline.json"
    assert main(["calibrate", str(SAMPLES / "7k98mc-baseline.h5"), "-o", str(baseline)]) == 0
    folder, data = tmp_path / "recordings", tmp_path / "data"
    (folder / "night-1").mkdir(parents=True)
    shutil.copy(SAMPLES / "7k98mc-baseline.h5", folder / "night-1" / "recording.h5")
    url = f"sqlite:///{tmp_path / 's.db'}"
    argv = ["batch", str(folder), "--store", url, "--data", str(data), "--baseline", str(baseline)]
    capsys.readouterr()

    status, first = _batch_json([*argv, "--workers", "1"], capsys)
    assert status == 0 and first["exit_status"] == 0
    [healthy] = first["recordings"]
    assert healthy["file"] == "recording.h5"
    assert (healthy["status"], healthy["diagnosed"]) == ("healthy", "this run")
    assert Path(healthy["plot"]) == data / "plots" / f"recording-v{ANALYSIS_VERSION}.png"

    (folder / "night-2").mkdir()
    shutil.copy(SAMPLES / "7k98mc-misfire-cyl4.h5", folder / "night-2" / "recording.h5")
    status, second = _batch_json(argv, capsys)
    assert status == 2 and second["exit_status"] == 2
    by_id = {r["id"]: r for r in second["recordings"]}
    assert by_id[healthy["id"]]["diagnosed"] == "before" and by_id[healthy["id"]]["status"] == "healthy"
    [alarm] = [r for r in second["recordings"] if r["id"] != healthy["id"]]
    store = open_store(url)
    try:
        stored = store.result(alarm["id"], ANALYSIS_VERSION, "diagnosis")
        row = store.recording(store.fleet_id("local"), alarm["id"])
    finally:
        store.close()
    assert stored is not None and row is not None
    assert alarm["status"] == stored["status"] == "alarm" and alarm["diagnosed"] == "this run"
    assert (alarm["file"], alarm["engine_id"], alarm["recorded_at"]) == (
        row.filename,
        row.engine_id,
        row.recorded_at,
    )
    keys = ("kind", "subject", "severity", "summary")
    assert alarm["findings"] == [{k: f[k] for k in keys} for f in stored["findings"]]
    assert [f["subject"] for f in alarm["findings"]] == ["cylinder 4"] and alarm["error"] is None
    plot = Path(alarm["plot"])
    assert plot == data / "plots" / f"recording+{alarm['id']}-v{ANALYSIS_VERSION}.png"
    # the PNG says what was found: the status word first, then the finding (its title, kept in the file)
    with Image.open(plot) as image:
        title = image.text["Title"]
    assert title.startswith("ALARM: " + alarm["findings"][0]["summary"][:40])
    totals = second["totals"]
    assert (totals["registered"], totals["known"], totals["diagnosed"], totals["failed"]) == (1, 1, 1, 0)
    assert totals["by_engine"] == {"man-b-w-7k98mc": {"alarm": 1}}
    assert second["unreadable"] == []

    assert main(argv) == 2  # nothing left to do: the alarm found before still counts
    text = capsys.readouterr().out
    assert "0 diagnosed" in text and "diagnosed before this run: 2 (1 healthy, 1 alarm)" in text
    assert f"recording.h5: {alarm['findings'][0]['summary']}" in text

    (folder / "notes.h5").write_text("not a recording")
    status, third = _batch_json(argv, capsys)
    assert status == 3 and third["exit_status"] == 3
    assert [u["file"] for u in third["unreadable"]] == ["notes.h5"] and third["totals"]["unreadable"] == 1
    assert "notes.h5" in third["unreadable"][0]["error"]


def test_an_unreadable_file_alone_exits_3(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Nothing diagnosed, nothing healthy: a file the batch could not read is 'cannot diagnose'."""
    (tmp_path / "in").mkdir()
    (tmp_path / "in" / "cut.h5").write_bytes((SAMPLES / "7k98mc-baseline.h5").read_bytes()[:4096])
    argv = [
        "batch",
        str(tmp_path / "in"),
        "--store",
        f"sqlite:///{tmp_path / 's.db'}",
        "--data",
        str(tmp_path),
    ]
    status, document = _batch_json(argv, capsys)
    assert status == 3 and document["recordings"] == []
    assert [u["file"] for u in document["unreadable"]] == ["cut.h5"] and document["unreadable"][0]["error"]


def _diagnosed_as_a_warning(*args: Any) -> dict[str, tuple[str, dict[str, Any]]]:
    """:func:`monitor.jobs.analyse.diagnose_file` with the status a warning (no bundled sample gives one)."""
    documents = diagnose_file(*args)
    return {kind: ("warning", {**document, "status": "warning"}) for kind, (_, document) in documents.items()}


def test_a_warning_exits_1(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The diagnosis' status, a warning here, is the batch's exit status 1 (the worker processes are
    forked, or import this module: either way they run the function given)."""
    monkeypatch.setattr(batch_module, "diagnose_file", _diagnosed_as_a_warning)
    (tmp_path / "in").mkdir()
    shutil.copy(SAMPLES / "7k98mc-baseline.h5", tmp_path / "in")
    argv = [
        "batch",
        str(tmp_path / "in"),
        "--store",
        f"sqlite:///{tmp_path / 's.db'}",
        "--data",
        str(tmp_path),
    ]
    status, document = _batch_json([*argv, "--workers", "1"], capsys)
    assert status == 1 and [r["status"] for r in document["recordings"]] == ["warning"]


def test_plot_names_follow_the_files_and_add_the_id_only_for_a_stem_taken() -> None:
    """The first recording of a stem keeps it; a later one adds its id; stems compared as a file system
    that ignores case would, after the characters a name leaves out are replaced."""
    v = ANALYSIS_VERSION
    files = [(3, "night.h5"), (1, "night.mcap"), (7, "NIGHT.h5"), (9, "other night.h5"), (12, "night+3.h5")]
    assert plot_names(files) == {
        1: f"night-v{v}.png",
        3: f"night+3-v{v}.png",
        7: f"NIGHT+7-v{v}.png",
        9: f"other_night-v{v}.png",
        12: f"night_3-v{v}.png",  # a '+' of its own is replaced: the names of ids added stay apart
    }


filenames = st.text(alphabet="aA12+._- /b", min_size=1, max_size=12).map(lambda s: s.strip("/") or "x")


@given(st.lists(filenames, min_size=1, max_size=25))
@example(["a.h5", "a.mcap", "a-2.h5", "a+2.h5", "a_2.h5"])  # named as another's stem and id
def test_plot_names_never_collide_and_a_later_recording_renames_none(files: list[str]) -> None:
    """Names distinct however the files are named (even one named as another's stem and id), as a
    file system that ignores case sees them, and each recording's name kept when more are registered."""
    recordings = list(enumerate(files, start=1))
    names = plot_names(recordings)
    assert len({n.casefold() for n in names.values()}) == len(recordings)
    assert all("/" not in n and not n.startswith(".") for n in names.values())
    for count in range(1, len(recordings)):
        earlier = plot_names(recordings[:count])
        assert all(names[i] == earlier[i] for i in earlier)


# ------------------------------------------------------------- every name kept, artefacts by id
STAND_IN_FINDING = "cylinder 1: a stand-in finding"


def _stand_in_diagnosis(
    path: str,
    engine_description: dict[str, Any] | None,
    baseline_document: dict[str, Any] | None,
    plot: str | None = None,
    name: str | None = None,
) -> dict[str, tuple[str, dict[str, Any]]]:
    """A stand-in for :func:`monitor.jobs.analyse.diagnose_file` where what is tested is how results and
    plots are named and found, not the analysis (seconds a recording): an alarm with one finding, and a
    small PNG whose ``Title`` text is the name the batch gave the recording, so a test can tell whose
    plot it was served."""
    from PIL.PngImagePlugin import PngInfo

    name = name or Path(path).name
    if plot is not None:
        info = PngInfo()
        info.add_text("Title", name)
        Image.new("RGB", (4, 4)).save(plot, pnginfo=info)
    finding = {"kind": "misfire", "subject": "cylinder 1", "severity": "alarm", "summary": STAND_IN_FINDING}
    document = {"recording": name, "status": "alarm", "findings": [finding]}
    return {"diagnosis": ("alarm", document), "spectrum": ("alarm", {"recording": name, "channels": {}})}


COPIES = ["copy1.h5", "copy2.h5", "copy3.h5"]


def _copies_and_another(tmp_path: Path) -> tuple[Path, list[str]]:
    """A folder of three copies of one content (:data:`COPIES`) and another file, ``other.h5``; and the
    batch's options for a store and a data folder beside it (one worker)."""
    folder = tmp_path / "in"
    folder.mkdir()
    for name in COPIES:
        shutil.copy(SAMPLES / "7k98mc-baseline.h5", folder / name)
    shutil.copy(SAMPLES / "6l32-misfire-cyl3.h5", folder / "other.h5")
    options = [
        "--store",
        f"sqlite:///{tmp_path / 's.db'}",
        "--data",
        str(tmp_path / "data"),
        "--workers",
        "1",
    ]
    return folder, options


def test_every_file_given_is_reported_under_its_own_name_with_its_recording_s_id(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Three copies of one content and another file: four files, two recordings. --json lists every
    file under its own name and path, the copies with their one recording's id and result; the text
    says which files share a content; the store keeps every name; --since reports each recording under
    every name it was stored under. (Before, copies were one entry under the first name: 24 files gave
    9 entries.)"""
    monkeypatch.setattr(batch_module, "diagnose_file", _stand_in_diagnosis)
    folder, options = _copies_and_another(tmp_path)
    capsys.readouterr()

    status, document = _batch_json(["batch", str(folder), *options], capsys)
    assert status == 2
    files = {r["file"]: r for r in document["recordings"]}
    assert sorted(files) == [*COPIES, "other.h5"] and len(document["recordings"]) == 4
    shared = files["copy1.h5"]["id"]
    assert files["other.h5"]["id"] != shared
    for name in COPIES:
        entry = files[name]
        assert entry["path"] == str(folder / name)
        same = {k: v for k, v in entry.items() if k not in ("file", "path")}
        assert same == {k: v for k, v in files["copy1.h5"].items() if k not in ("file", "path")}
    assert files["copy3.h5"]["id"] == shared and files["copy3.h5"]["status"] == "alarm"
    assert files["copy3.h5"]["findings"][0]["summary"] == STAND_IN_FINDING
    totals = document["totals"]
    assert (totals["registered"], totals["known"], totals["diagnosed"]) == (2, 2, 2)
    assert totals["by_status"] == {"alarm": 2}  # recordings, each once

    assert main(["batch", str(folder), *options]) == 2  # run again: the text names every file
    text = capsys.readouterr().out
    assert f"one content, 3 files: copy1.h5, copy2.h5, copy3.h5 (recording {shared})" in text
    assert f"copy1.h5, copy2.h5, copy3.h5: {STAND_IN_FINDING}" in text
    assert "worst over 2 recording(s) in scope (4 files)" in text

    status, since = _batch_json(["batch", "--since", "2000-01-01", *options], capsys)
    assert sorted((r["file"], r["id"]) for r in since["recordings"]) == sorted(
        (name, entry["id"]) for name, entry in files.items()
    )
    assert {r["path"] for r in since["recordings"]} == {None}
    store = open_store(options[1])
    try:
        kept = store.recording_names(store.fleet_id("local"), [shared])
    finally:
        store.close()
    assert kept == {shared: COPIES}


def test_a_copy_given_alone_is_reported_under_its_own_name(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """After the folder's batch, 'batch copy3.h5' reports copy3.h5, with the id and the result its
    content got as copy1.h5, in --json and in the text (before, it reported copy1.h5)."""
    monkeypatch.setattr(batch_module, "diagnose_file", _stand_in_diagnosis)
    folder, options = _copies_and_another(tmp_path)
    capsys.readouterr()
    _, document = _batch_json(["batch", str(folder), *options], capsys)
    [shared] = {r["id"] for r in document["recordings"] if r["file"] in COPIES}

    status, alone = _batch_json(["batch", str(folder / "copy3.h5"), *options], capsys)
    [entry] = alone["recordings"]
    assert status == 2 and (entry["file"], entry["id"], entry["diagnosed"]) == ("copy3.h5", shared, "before")
    assert entry["path"] == str(folder / "copy3.h5") and entry["findings"][0]["summary"] == STAND_IN_FINDING
    assert main(["batch", str(folder / "copy3.h5"), *options]) == 2
    text = capsys.readouterr().out
    assert f"copy3.h5: {STAND_IN_FINDING}" in text and "copy1.h5" not in text


def _png_title(answer: Any) -> str:
    """The ``Title`` text of a PNG answered by the service."""
    import io

    assert answer.status_code == 200 and answer.headers["content-type"] == "image/png", answer.text
    with Image.open(io.BytesIO(answer.content)) as image:
        return str(image.text["Title"])


@contextmanager
def _service(store_url: str, data: Path) -> Iterator[str]:
    """The service (no analysis worker) on a loopback port, in a thread of this process: its URL."""
    import threading

    import uvicorn

    from api.app import create_app
    from api.settings import Settings

    app = create_app(Settings(store_url=store_url, data_dir=data, workers=0))
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = int(probe.getsockname()[1])
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning"))
    serving = threading.Thread(target=server.run, daemon=True)
    serving.start()
    try:
        deadline = time.monotonic() + 30
        while not server.started:
            assert time.monotonic() < deadline and serving.is_alive(), "the service did not start"
            time.sleep(0.02)
        yield f"http://127.0.0.1:{port}"
    finally:
        server.should_exit = True
        serving.join(30)


def test_a_missing_plot_is_404_and_never_another_fleet_s(
    store_url: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Fleet a's recording is diagnosed by the batch into the service's data folder; fleet b's file is
    named after a's recording id ('1.h5' for recording 1), so its plot is named as the service once
    named a's by id. With a's plot file gone (deleted, a data folder restored without it, or kept by
    a worker with another --data), a's plot is 404, as b's recording is to a: it was b's picture."""
    monkeypatch.setattr(batch_module, "diagnose_file", _stand_in_diagnosis)
    data = tmp_path / "data"
    (tmp_path / "a").mkdir()
    shutil.copy(SAMPLES / "7k98mc-baseline.h5", tmp_path / "a" / "engine-room.h5")
    store = open_store(store_url)
    try:
        a, b = store.create_fleet("a"), store.create_fleet("b")
        keys = {"a": store.create_key(a), "b": store.create_key(b)}
        [mine] = run_batch(store, a, path=tmp_path / "a", workers=1, data_dir=data).recordings
        (tmp_path / "b").mkdir()
        shutil.copy(SAMPLES / "6l32-misfire-cyl3.h5", tmp_path / "b" / f"{mine.id}.h5")
        [theirs] = run_batch(store, b, path=tmp_path / "b", workers=1, data_dir=data).recordings
    finally:
        store.close()
    assert Path(theirs.plot).name == f"{mine.id}-v{ANALYSIS_VERSION}.png"  # the name plots had by id
    with _service(store_url, data) as url, httpx.Client(base_url=url, timeout=30) as client:

        def plot(fleet: str, recording: int) -> Any:
            return client.get(f"/recordings/{recording}/plot", headers={"X-API-Key": keys[fleet]})

        assert _png_title(plot("a", mine.id)) == "engine-room.h5"
        assert _png_title(plot("b", theirs.id)) == f"{mine.id}.h5"
        Path(mine.plot).unlink()
        gone = plot("a", mine.id)
        assert gone.status_code == 404 and gone.json()["error"]["code"] == "not_found", gone.content[:60]
        assert "no plot is kept" in gone.json()["error"]["message"]
        assert plot("b", mine.id).status_code == 404 and plot("a", theirs.id).status_code == 404
        assert _png_title(plot("b", theirs.id)) == f"{mine.id}.h5"
