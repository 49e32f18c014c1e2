"""Sensor faults are findings of their own; the rest of the recording is diagnosed without them.

The recordings are the shipped 7K98MC samples (a healthy baseline and a misfire of cylinder 4) with
one accelerometer spoiled the ways real ones fail: clipped at its range, dead, read in the wrong
unit. The product must say which sensor and why, leave it out, and still name the misfire.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from monitor.cli import main
from monitor.diagnosis import Baseline, calibrate, diagnose
from monitor.engine import load_engine
from monitor.errors import DiagnosisError
from monitor.io import read_recording
from monitor.io.hdf5 import write_hdf5
from monitor.recording import Channel, Recording

from .conftest import ROOT

SAMPLES = ROOT / "recordings" / "samples"


@pytest.fixture(scope="module")
def engine():  # type: ignore[no-untyped-def]
    return load_engine("man-b-w-7k98mc")


@pytest.fixture(scope="module")
def misfire() -> Recording:
    return read_recording(SAMPLES / "7k98mc-misfire-cyl4.h5")


@pytest.fixture(scope="module")
def baseline(engine) -> Baseline:  # type: ignore[no-untyped-def]
    return calibrate(read_recording(SAMPLES / "7k98mc-baseline.h5"), engine)


def _spoiled(recording: Recording, name: str, data: np.ndarray, **changes: object) -> Recording:
    channels = tuple(
        Channel(
            c.name,
            c.kind,
            c.unit,
            data,
            c.sample_rate,
            c.start_offset,
            c.location,
            c.direction,
            c.fields,
            **changes,
        )  # type: ignore[arg-type]
        if c.name == name
        else c
        for c in recording.channels
    )
    return replace(recording, channels=channels)


def _sensor_findings(diagnosis) -> dict[str, str]:  # type: ignore[no-untyped-def]
    return {f.subject: f.summary for f in diagnosis.findings if f.kind == "sensor"}


def _names_the_misfire(diagnosis) -> bool:  # type: ignore[no-untyped-def]
    return any(
        f.kind == "cylinder" and f.subject == "cylinder 4" and f.severity == "alarm"
        for f in diagnosis.findings
    )


def test_a_clipped_accelerometer_is_a_sensor_finding_and_the_misfire_is_still_named(
    engine,
    misfire: Recording,
    baseline: Baseline,  # type: ignore[no-untyped-def]
) -> None:
    data = np.asarray(misfire.channel("mb5-vertical").data, dtype=np.float64)
    limit = 0.3 * float(np.max(np.abs(data)))
    clipped = _spoiled(misfire, "mb5-vertical", np.clip(data, -limit, limit), range=(-limit, limit))
    diagnosis = diagnose(clipped, engine, baseline=baseline)
    told = _sensor_findings(diagnosis)
    assert list(told) == ["sensor mb5-vertical"]
    assert "clipped" in told["sensor mb5-vertical"] and "left out" in told["sensor mb5-vertical"]
    assert _names_the_misfire(diagnosis)
    assert "mb5-vertical" not in diagnosis.spectra.spectra


def test_a_dead_sensor_is_named_dead(engine, misfire: Recording, baseline: Baseline) -> None:  # type: ignore[no-untyped-def]
    flat = np.full(misfire.channel("mb2-vertical").data.shape, 0.0012)
    diagnosis = diagnose(_spoiled(misfire, "mb2-vertical", flat), engine, baseline=baseline)
    told = _sensor_findings(diagnosis)
    assert "dead" in told["sensor mb2-vertical"]
    assert _names_the_misfire(diagnosis)


@pytest.mark.parametrize(
    ("factor", "with_baseline", "how"),
    [
        (1000.0, True, "1e+03 times the baseline's"),
        (1 / 9.81, True, "0.102 times the baseline's"),
        (1e5, False, "more than a main bearing reaches"),
    ],
)
def test_a_sensor_in_the_wrong_unit_is_named(
    engine,
    misfire: Recording,
    baseline: Baseline,
    factor: float,
    with_baseline: bool,
    how: str,  # type: ignore[no-untyped-def]
) -> None:
    """mm/s^2 stored as m/s^2 (1000 times too large) or g stored as m/s^2 (9.81 times too small): the
    baseline's level says so, the other sensor agreeing with its own. Without a baseline only what no
    main bearing reaches (1000 m/s^2 rms) is told."""
    data = np.asarray(misfire.channel("mb2-vertical").data, dtype=np.float64) * factor
    spoiled = _spoiled(misfire, "mb2-vertical", data)
    diagnosis = diagnose(spoiled, engine, baseline=baseline if with_baseline else None)
    told = _sensor_findings(diagnosis)
    assert "implausible level" in told["sensor mb2-vertical"] and how in told["sensor mb2-vertical"]
    assert _names_the_misfire(diagnosis)


def test_the_healthy_samples_raise_no_sensor_finding(engine, misfire: Recording, baseline: Baseline) -> None:  # type: ignore[no-untyped-def]
    assert _sensor_findings(diagnose(misfire, engine, baseline=baseline)) == {}


def test_exclude_channel_leaves_a_sensor_out_and_says_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    baseline = tmp_path / "baseline.json"
    assert (
        main(
            [
                "calibrate",
                str(SAMPLES / "7k98mc-baseline.h5"),
                "-o",
                str(baseline),
                "--exclude-channel",
                "mb5-vertical",
            ]
        )
        == 0
    )
    assert set(Baseline.read(baseline).sensors) == {"mb2-vertical"}
    capsys.readouterr()
    status = main(
        [
            "compare",
            str(SAMPLES / "7k98mc-misfire-cyl4.h5"),
            "--baseline",
            str(baseline),
            "--exclude-channel",
            "mb5-vertical",
        ]
    )
    out = capsys.readouterr().out
    assert status == 2 and "cylinder 4" in out
    assert "mb5-vertical: left out at the user's request" in out
    assert main(["compare", str(SAMPLES / "7k98mc-misfire-cyl4.h5"), "--exclude-channel", "mb9"]) == 3
    err = capsys.readouterr().err
    assert "--exclude-channel mb9: no such channel" in err and "mb2-vertical" in err


def test_calibrating_on_a_faulty_sensor_is_refused_with_the_way_out(
    engine,
    misfire: Recording,
    tmp_path: Path,  # type: ignore[no-untyped-def]
) -> None:
    healthy = read_recording(SAMPLES / "7k98mc-baseline.h5")
    flat = np.zeros(healthy.channel("mb5-vertical").data.shape)
    with pytest.raises(DiagnosisError, match=r"mb5-vertical: dead.*--exclude-channel mb5-vertical"):
        calibrate(_spoiled(healthy, "mb5-vertical", flat), engine)


def test_a_clipped_sensor_read_from_a_file_is_found_while_reading(
    engine,
    misfire: Recording,
    baseline: Baseline,
    tmp_path: Path,  # type: ignore[no-untyped-def]
) -> None:
    """A channel opened in a file is read by slices and refuses clipped samples as they are read: the
    screening reads it once and turns that refusal into the sensor finding."""
    from monitor.io.hdf5 import open_hdf5

    data = np.asarray(misfire.channel("mb5-vertical").data, dtype=np.float64)
    limit = 0.3 * float(np.max(np.abs(data)))
    spoiled = _spoiled(misfire, "mb5-vertical", np.clip(data, -limit, limit), range=(-limit, limit))
    path = write_hdf5(spoiled, tmp_path / "clipped.h5")
    with open_hdf5(path) as recording:
        diagnosis = diagnose(recording, engine, baseline=baseline)
    assert "clipped" in _sensor_findings(diagnosis)["sensor mb5-vertical"]
    assert _names_the_misfire(diagnosis)
