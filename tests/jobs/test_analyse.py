"""One analysis of a recording (monitor.jobs.analyse): ``compare``, the batch and the service's worker
choose the engine, the baseline and the options alike, and say the same; one spectrum document
(monitor.report.spectrum_json) for the command, the store and the service, which reads earlier ones."""

from __future__ import annotations

import json
import math
import shutil
import time
from datetime import timedelta
from pathlib import Path
from typing import Any

import pytest

from monitor.cli import main
from monitor.diagnosis import ANALYSIS_VERSION, Baseline
from monitor.jobs.registration import register
from monitor.jobs.worker import Worker
from monitor.report.spectrum_json import read_spectrum_document
from monitor.store import Store, open_store

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = ROOT / "recordings" / "samples"
RECORDING = SAMPLES / "7k98mc-misfire-cyl4.h5"
HEALTHY = SAMPLES / "7k98mc-baseline.h5"

# The three paths run the same code on the same bytes; they differ only in the process that runs it
# (this one, a forked batch process, a spawned worker process). Numbers can then differ only by the
# order of floating-point operations (none is expected: the threaded stages are combined in a fixed
# order), i.e. by some ulps over the thousands of operations behind a number: 1e-9 relative leaves a
# factor of a million over that, while a different choice of engine, baseline, load or cycle phase
# moves the numbers compared by a percent or more (the misfire's strength, the bearings' deviations).
RELATIVE = 1e-9
ABSOLUTE = 1e-12  # for numbers that are zero up to round-off (a phase, an order-0 term)


def _same(a: Any, b: Any, where: str = "") -> list[str]:
    """Where two documents differ: keys, types, text, or numbers beyond the tolerance."""
    if isinstance(a, dict) and isinstance(b, dict):
        if set(a) != set(b):
            return [f"{where}: keys {sorted(set(a) ^ set(b))}"]
        return [d for k in a for d in _same(a[k], b[k], f"{where}.{k}")]
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{where}: {len(a)} against {len(b)} items"]
        return [d for i, (x, y) in enumerate(zip(a, b, strict=True)) for d in _same(x, y, f"{where}[{i}]")]
    numbers = (int, float)
    if isinstance(a, numbers) and isinstance(b, numbers) and not isinstance(a, bool):
        close = math.isclose(a, b, rel_tol=RELATIVE, abs_tol=ABSOLUTE)
        return [] if close else [f"{where}: {a!r} against {b!r}"]
    return [] if a == b else [f"{where}: {a!r} against {b!r}"]


def _keys(document: dict[str, Any]) -> dict[str, Any]:
    """A spectrum document's keys: its own, its angle reference's and each channel's."""
    return {
        "top": sorted(document),
        "angle_reference": sorted(document["angle_reference"]),
        "channels": {name: sorted(channel) for name, channel in document["channels"].items()},
    }


def _stored(store: Store, recording_id: int) -> dict[str, dict[str, Any]]:
    documents = {
        kind: store.result(recording_id, ANALYSIS_VERSION, kind) for kind in ("diagnosis", "spectrum")
    }
    assert all(d is not None for d in documents.values()), documents
    return documents  # type: ignore[return-value]


def _by_batch(
    tmp_path: Path, baseline: Path, capsys: pytest.CaptureFixture[str]
) -> dict[str, dict[str, Any]]:
    folder = tmp_path / "batch" / "in"
    folder.mkdir(parents=True)
    shutil.copy(RECORDING, folder)
    url = f"sqlite:///{tmp_path / 'batch.db'}"
    argv = ["batch", str(folder), "--store", url, "--data", str(tmp_path / "batch")]
    assert main([*argv, "--baseline", str(baseline), "--workers", "1", "--json"]) == 2
    (recording,) = json.loads(capsys.readouterr().out)["recordings"]
    store = open_store(url)
    try:
        return _stored(store, recording["id"])
    finally:
        store.close()


def _by_worker(tmp_path: Path, baseline: Path) -> dict[str, dict[str, Any]]:
    """The service's path: the fleet's baseline in the store, a queued job, the worker's process."""
    data = tmp_path / "service"
    (data / "recordings").mkdir(parents=True)
    store = open_store(f"sqlite:///{tmp_path / 'service.db'}")
    try:
        fleet = store.create_fleet("ship")
        paths = [Path(shutil.copy(f, data / "recordings")) for f in (HEALTHY, RECORDING)]
        healthy_id, _ = register(store, fleet, paths[0])
        recording_id, _ = register(store, fleet, paths[1])
        document = Baseline.read(baseline).to_document()
        store.put_baseline(fleet, "man-b-w-7k98mc", healthy_id, ANALYSIS_VERSION, document)
        store.enqueue(recording_id, ANALYSIS_VERSION)
        worker = Worker(store, data, 1, lease=timedelta(seconds=60))
        worker.start()
        try:
            deadline = time.monotonic() + 300
            while (job := store.job(recording_id, ANALYSIS_VERSION)) is None or job.state != "done":
                assert job is None or job.state in ("queued", "running"), job
                assert time.monotonic() < deadline, "the worker did not finish the analysis"
                time.sleep(0.2)
        finally:
            worker.stop()
        return _stored(store, recording_id)
    finally:
        store.close()


def test_compare_the_batch_and_the_worker_give_one_diagnosis_and_one_spectrum(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The misfire sample against a baseline of the healthy sample: calibrated on the spot by compare,
    a calibrate file for the batch, the fleet's stored baseline for the worker. Same findings, same
    numbers (within :data:`RELATIVE`); the spectra of the command, the store and the service have the
    same keys."""
    baseline = tmp_path / "baseline.json"
    assert main(["calibrate", str(HEALTHY), "-o", str(baseline)]) == 0
    assert main(["compare", str(RECORDING), "--baseline", str(HEALTHY), "--json"]) == 2
    compared = json.loads(capsys.readouterr().out)
    assert main(["spectrum", str(RECORDING), "--json"]) == 0
    command_spectrum = json.loads(capsys.readouterr().out)
    batch = _by_batch(tmp_path, baseline, capsys)
    service = _by_worker(tmp_path, baseline)

    findings = [(f["kind"], f["subject"], f["severity"]) for f in compared["findings"]]
    assert ("cylinder", "cylinder 4", "alarm") in findings
    assert compared["baseline"] == HEALTHY.name and compared["status"] == "alarm"
    for name, documents in (("batch", batch), ("worker", service)):
        diagnosis = documents["diagnosis"]
        assert [(f["kind"], f["subject"], f["severity"]) for f in diagnosis["findings"]] == findings, name
        assert not _same(compared, diagnosis), (name, _same(compared, diagnosis)[:10])
    assert not _same(batch["spectrum"], service["spectrum"])
    assert _keys(command_spectrum) == _keys(batch["spectrum"]) == _keys(service["spectrum"])
    assert batch["spectrum"]["recording"] == command_spectrum["recording"] == RECORDING.name
    assert read_spectrum_document(batch["spectrum"]) == batch["spectrum"]  # the current form reads as it is


OLD_STORED = {  # a stored spectrum result before the one schema: no recording time, no angle reference
    "recording": "night.h5",
    "engine_id": "man-b-w-7k98mc",
    "mean_speed_rpm": 104.0,
    "cycle_revolutions": 1,
    "channels": {
        "mb2-vertical": {
            "unit": "m/s^2",
            "blocks": 16,
            "orders": [0.0, 1.0],
            "amplitude": [0.01, 0.2],
            "phase_deg": [0.0, 12.0],
            "standard_error": [0.001, 0.002],
        }
    },
}

OLD_COMMAND = {  # spectrum --json before the one schema: the recording an object, the spread magnitude_std
    "recording": {"engine_id": "man-b-w-7k98mc", "start_time": "2026-01-01T00:00:00Z", "truncated": False},
    "angle_reference": {
        "channel": "tooth",
        "repairs": 0,
        "cycle_phase": "",
        "pitch_correction": None,
        "notes": [],
    },
    "mean_speed_rpm": 104.0,
    "cycle_revolutions": 1,
    "channels": {
        "crank speed": {
            "unit": "rad/s",
            "blocks": 16,
            "orders": [1.0],
            "amplitude": [0.02],
            "phase_deg": [30.0],
            "magnitude_std": [0.003],
        }
    },
}


def test_earlier_spectrum_documents_still_read() -> None:
    """A stored result of an earlier version reads with what it held, None for what it did not say; the
    command's earlier document too, its ``magnitude_std`` (another quantity) kept, its standard error
    unknown. The documents given are left as they are."""
    stored = read_spectrum_document(OLD_STORED)
    assert stored["recording"] == "night.h5" and stored["engine_id"] == "man-b-w-7k98mc"
    assert (stored["start_time"], stored["truncated"], stored["angle_reference"]) == (None, None, None)
    assert stored["channels"]["mb2-vertical"] == OLD_STORED["channels"]["mb2-vertical"]
    command = read_spectrum_document(OLD_COMMAND)
    assert command["recording"] == "" and command["engine_id"] == "man-b-w-7k98mc"
    assert (command["start_time"], command["truncated"]) == ("2026-01-01T00:00:00Z", False)
    speed = command["channels"]["crank speed"]
    assert speed["standard_error"] is None and speed["magnitude_std"] == [0.003]
    current = {"recording", "engine_id", "start_time", "truncated", "angle_reference", "mean_speed_rpm"}
    assert current | {"cycle_revolutions", "channels"} == set(stored) == set(command)
    assert isinstance(OLD_COMMAND["recording"], dict) and "start_time" not in OLD_STORED
