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
from monitor.errors import DiagnosisError
from monitor.io import read_recording
from monitor.io.hdf5 import open_hdf5, write_hdf5
from monitor.io.recording import Channel, Recording
from monitor.model.engine import load_engine
from monitor.scene import load_scene, simulate
from tests.conftest import ROOT

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


def test_a_clipped_float32_accelerometer_is_found_against_its_float64_range(misfire: Recording) -> None:
    """A logger stores its samples in float32 and its range in float64: a sample clipped at the
    range reads a float32 rounding off it. Cast to float64 before the check, the validation
    population's clipped sensors were read as knocking bearings (seed 300052: 20712 samples at the
    limits, no clipped span found)."""
    from monitor.diagnosis.sensors import screen_sensors

    data = np.asarray(misfire.channel("mb5-vertical").data, dtype=np.float64)
    near = np.float32(0.3 * float(np.max(np.abs(data))))
    limit = float(near) + 0.25 * float(np.spacing(near))  # a quarter of a float32 step above one
    stored = np.clip(data, -limit, limit).astype(np.float32)
    assert float(stored.max()) == float(near) < limit  # the float32 rounding the check has to allow for
    clipped = _spoiled(misfire, "mb5-vertical", stored, range=(-limit, limit))
    _, faults, _ = screen_sensors(clipped)
    assert [(f.channel, f.fault) for f in faults] == [("mb5-vertical", "unusable samples")]
    assert "clipped" in faults[0].detail


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

    data = np.asarray(misfire.channel("mb5-vertical").data, dtype=np.float64)
    limit = 0.3 * float(np.max(np.abs(data)))
    spoiled = _spoiled(misfire, "mb5-vertical", np.clip(data, -limit, limit), range=(-limit, limit))
    path = write_hdf5(spoiled, tmp_path / "clipped.h5")
    with open_hdf5(path) as recording:
        diagnosis = diagnose(recording, engine, baseline=baseline)
    assert "clipped" in _sensor_findings(diagnosis)["sensor mb5-vertical"]
    assert _names_the_misfire(diagnosis)


def _with_knocks(
    recording: Recording, channels: list[str], angles_deg: list[float], peak: float = 0.6
) -> Recording:
    """Decaying 2 kHz rings (``peak`` m/s^2, 2 ms) on the named channels at the given cycle angles of
    every revolution, placed in time by the recording's own angle reference."""
    from monitor.signal.reference import angle_reference

    angle_map = angle_reference(recording, cycle_revolutions=1).angle_map
    first, last = angle_map.angles[0], angle_map.angles[-1]
    turns = np.arange(np.ceil(first / (2 * np.pi)), np.floor(last / (2 * np.pi)))
    at = np.sort(np.concatenate([angle_map.time_at(2 * np.pi * turns + np.radians(a)) for a in angles_deg]))
    out = recording
    for name in channels:
        channel = recording.channel(name)
        data = np.asarray(channel.data, dtype=np.float64).copy()
        t = np.arange(data.size) / float(channel.sample_rate or 1.0)
        for start in at:
            i = int(np.searchsorted(t, start))
            tail = t[i : i + 200] - start
            data[i : i + tail.size] += peak * np.exp(-tail / 2e-3) * np.sin(2 * np.pi * 2000 * tail)
        out = _spoiled(out, name, data)
    return out


def test_without_a_baseline_only_a_knock_its_own_sensor_hears_loudest_is_a_bearing_finding(
    engine,  # type: ignore[no-untyped-def]
) -> None:
    """Without a baseline the reference is the recording's own median, and a healthy engine's
    high-frequency power is not even over the cycle. Rings at bearing 5's load reversals on both
    sensors (an engine-wide source: combustion, valves) are no bearing finding; on bearing 5's sensor
    alone (a knock at the bearing) they are a warning on main bearing 5, never an alarm without a
    baseline."""
    healthy = read_recording(SAMPLES / "7k98mc-baseline.h5")
    plain = diagnose(healthy, engine)
    own = next(b for b in plain.bearings if b.bearing == 5)
    reversals = next(s for s in own.impacts if s.bearing == 5).reversal_angles_deg
    everywhere = diagnose(_with_knocks(healthy, ["mb2-vertical", "mb5-vertical"], reversals), engine)
    loud = next(s for b in everywhere.bearings if b.bearing == 5 for s in b.impacts if s.bearing == 5)
    assert loud.score > 10  # as loud against its own median as a worn bearing ...
    assert [f for f in everywhere.findings if f.kind == "main bearing"] == []  # ... but heard alike elsewhere
    local = diagnose(_with_knocks(healthy, ["mb5-vertical"], reversals), engine)
    named = [(f.subject, f.severity) for f in local.findings if f.kind == "main bearing"]
    assert named == [("main bearing 5", "warning")]


def test_a_bearing_is_named_from_its_own_sensor_not_on_a_neighbour_with_a_quiet_one(
    engine,  # type: ignore[no-untyped-def]
) -> None:
    """Sensors on main bearings 4, 5 and 6 and a baseline of the same layout. Bearing 5's sensor hears
    knocks in its own load-reversal windows and, louder, in bearing 6's (a worn bearing 5 rings on in
    its neighbour's windows); bearing 6's own sensor is quiet. The rule that named the loudest window
    named bearing 6; bearing 5's own evidence comes first, and bearing 6 has a sensor of its own that
    speaks for it: only bearing 5 is named."""

    scene = load_scene(ROOT / "recordings" / "scenes" / "7k98mc-worn-bearing-5.toml")
    template = scene.sensors[1]
    sensors = [
        template.model_copy(update={"name": f"mb{b}-vertical", "location": f"main bearing {b}"})
        for b in (4, 5, 6)
    ] + list(scene.sensors[2:])
    effects = {k: v for k, v in scene.effects.items() if k != "worn_bearing"}
    effects["noise"] = {f"mb{b}-vertical": 0.005 for b in (4, 5, 6)}
    short = {"sensors": sensors, "duration_s": 15.0, "effects": effects}
    recording = simulate(scene.model_copy(update=short)).recording
    baseline = calibrate(simulate(scene.model_copy(update=short | {"seed": 7})).recording, engine)
    plain = diagnose(recording, engine, baseline=baseline)
    windows = {s.bearing: s.reversal_angles_deg for b in plain.bearings if b.bearing == 5 for s in b.impacts}
    knocked = _with_knocks(recording, ["mb5-vertical"], windows[5], peak=0.3)
    knocked = _with_knocks(knocked, ["mb5-vertical"], windows[6], peak=0.9)
    diagnosis = diagnose(knocked, engine, baseline=baseline)
    scores = {s.bearing: s.score for b in diagnosis.bearings if b.bearing == 5 for s in b.impacts}
    # heard in bearing 6's windows at least as loud as in its own (the windows may overlap and share the
    # loudest knock span), and clearly in its own
    assert scores[6] >= scores[5] >= 3.0
    named = {f.subject for f in diagnosis.findings if f.kind == "main bearing"}
    assert named == {"main bearing 5"}, [f.summary for f in diagnosis.findings]
