"""From a recording file to order spectra through the pipeline and the CLI."""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import cumulative_trapezoid

from monitor.cli import main
from monitor.errors import FormatError, SignalError
from monitor.io import open_recording, read_recording
from monitor.io.hdf5 import write_hdf5
from monitor.io.mcap.writer import write_mcap
from monitor.io.recording import Channel, Recording
from monitor.signal.measure import spectra

FS = 10240.0
ORDERS = {1: (0.8, 0.5), 2: (0.3, -1.2), 7: (0.05, 2.0)}


def _synthetic(rng: np.random.Generator, *, tooth: bool = True, keyphasor: bool = False) -> Recording:
    """A two-stroke at about 104 rpm with +-10 % speed variation: an accelerometer with known orders,
    a 60-2 tooth wheel as edge times (first tooth after the gap 30 deg after TDC of cylinder 1)."""
    t = np.arange(int(30.0 * FS)) / FS
    w = 104 * math.pi / 30 * (1 + 0.1 * np.sin(2 * np.pi * 0.05 * t))
    alpha = cumulative_trapezoid(w, t, initial=0.0) + 0.2
    acc = sum(a * np.cos(k * alpha + ph) for k, (a, ph) in ORDERS.items()) + 1e-3 * rng.standard_normal(
        t.size
    )
    channels = [
        Channel(
            "mb1-vertical",
            "acceleration",
            "m/s^2",
            acc.astype(np.float32),
            FS,
            location="main bearing 1",
            direction="vertical",
        )
    ]
    pitch = math.pi / 30
    if tooth:
        k = np.arange(
            math.ceil((alpha[0] - math.radians(30)) / pitch),
            math.floor((alpha[-1] - math.radians(30)) / pitch),
        )
        k = k[np.mod(k, 60) < 58]
        edges = np.interp(math.radians(30) + k * pitch, alpha, t)
        channels.append(
            Channel(
                "tooth",
                "tooth",
                "s",
                edges,
                None,
                fields={"teeth": 60, "missing_teeth": 2, "first_tooth_angle_deg": 30.0},
            )
        )
    if keyphasor:
        revs = np.arange(math.ceil(alpha[0] / (2 * math.pi)), math.floor(alpha[-1] / (2 * math.pi)))
        channels.append(
            Channel(
                "kp",
                "keyphasor",
                "s",
                np.interp(revs * 2 * math.pi, alpha, t),
                None,
                fields={"pulse_angle_deg": 0.0},
            )
        )
    return Recording("man-b-w-7k98mc", "2026-11-22T10:15:00Z", tuple(channels))


@pytest.mark.parametrize("reference", ["tooth", "keyphasor"])
def test_pipeline_recovers_the_orders(rng: np.random.Generator, reference: str) -> None:
    recording = _synthetic(rng, tooth=reference == "tooth", keyphasor=reference == "keyphasor")
    result = spectra(recording, cycle_revolutions=1, max_order=12)
    s = result.spectra["mb1-vertical"]
    for k, (a, ph) in ORDERS.items():
        assert s.magnitude[k] == pytest.approx(a, rel=5e-3)
        assert abs(math.degrees(math.remainder(s.phase[k] - ph, 2 * math.pi))) < 1.0
    t = np.arange(int(30.0 * FS)) / FS  # the synthetic speed's own mean over the record
    true_mean = float(np.mean(104 * math.pi / 30 * (1 + 0.1 * np.sin(2 * np.pi * 0.05 * t))))
    assert result.mean_speed == pytest.approx(true_mean, rel=2e-3)
    # the crank speed's fluctuation: about +-10 % at 0.05 Hz is far below order 1, so little at orders >= 1
    assert result.spectra["crank speed"].magnitude[0] == pytest.approx(result.mean_speed, rel=0.02)


def test_a_recording_without_angle_reference_is_refused(rng: np.random.Generator) -> None:
    with pytest.raises(SignalError, match="no usable angle reference"):
        spectra(_synthetic(rng, tooth=False), cycle_revolutions=1)


@pytest.mark.parametrize("suffix", [".h5", ".mcap"])
def test_cli_spectrum_json_and_plot(
    tmp_path: Path, rng: np.random.Generator, suffix: str, capsys: pytest.CaptureFixture[str]
) -> None:
    recording = _synthetic(rng)
    path = (write_hdf5 if suffix == ".h5" else write_mcap)(recording, tmp_path / f"r{suffix}")
    assert (
        main(["spectrum", str(path), "--json", "--orders", "1,2,7", "--plot", str(tmp_path / "s.png")]) == 0
    )
    doc = json.loads(capsys.readouterr().out)
    channel = doc["channels"]["mb1-vertical"]
    assert channel["orders"] == [1.0, 2.0, 7.0] and channel["unit"] == "m/s^2"
    np.testing.assert_allclose(channel["amplitude"], [a for a, _ in ORDERS.values()], rtol=5e-3)
    assert doc["angle_reference"]["channel"] == "tooth"
    assert (tmp_path / "s.png").read_bytes()[:4] == b"\x89PNG"


def test_cli_spectrum_refuses_unknown_files(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "notes.txt"
    bad.write_text("hello")
    assert main(["spectrum", str(bad)]) == 2
    assert "neither HDF5 nor MCAP" in capsys.readouterr().err
    with pytest.raises(FormatError):
        read_recording(bad)


def _speed_recording(pulse: str) -> Recording:
    """Crank speed defined in angle: w(a) = w0 (1 + 0.02 cos 7a + 0.01 cos(2a + 1)); the times of the
    wheel's teeth (or the keyphasor's pulses) follow from t(a) = int da / w(a)."""
    w0 = 104 * math.pi / 30
    a = np.linspace(0, 2 * math.pi * 60, 60 * 4096 + 1)
    w = w0 * (1 + 0.02 * np.cos(7 * a) + 0.01 * np.cos(2 * a + 1))
    t = cumulative_trapezoid(1 / w, a, initial=0.0)
    pitch = math.pi / 30
    if pulse == "tooth":
        k = np.arange(1, 60 * 60 - 1)
        k = k[np.mod(k, 60) < 58]
        channel = Channel(
            "tooth",
            "tooth",
            "s",
            np.interp(k * pitch, a, t),
            None,
            fields={"teeth": 60, "missing_teeth": 2, "first_tooth_angle_deg": 0.0},
        )
    else:
        revs = np.arange(1, 59) * 2 * math.pi
        channel = Channel(
            "kp", "keyphasor", "s", np.interp(revs, a, t), None, fields={"pulse_angle_deg": 0.0}
        )
    return Recording("man-b-w-7k98mc", "2026-11-22T10:15:00Z", (channel,))


def test_crank_speed_orders_from_a_tooth_wheel_and_from_a_keyphasor() -> None:
    """Review finding: a keyphasor-only map reported a speed spectrum of exact zeros. A tooth wheel
    recovers the speed's orders 7 and 2 (amplitude and phase); a keyphasor gives only the mean."""
    w0 = 104 * math.pi / 30
    tooth = spectra(_speed_recording("tooth"), cycle_revolutions=1, max_order=12).spectra["crank speed"]
    assert tooth.magnitude[7] == pytest.approx(0.02 * w0, rel=2e-3)
    assert tooth.magnitude[2] == pytest.approx(0.01 * w0, rel=2e-3)
    assert abs(tooth.phase[7]) < math.radians(0.5) and tooth.phase[2] == pytest.approx(
        1.0, abs=math.radians(0.5)
    )
    keyphasor = spectra(_speed_recording("kp"), cycle_revolutions=1, max_order=12).spectra["crank speed"]
    assert keyphasor.orders.tolist() == [0.0]
    assert keyphasor.magnitude[0] == pytest.approx(tooth.magnitude[0], rel=1e-3)


def test_grid_too_coarse_for_the_orders_is_refused(rng: np.random.Generator) -> None:
    """Review finding: orders above the anti-alias passband at the fastest speed were silently attenuated."""
    with pytest.raises(SignalError, match=r"samples_per_cycle = 32: .* use at least \d+"):
        spectra(_synthetic(rng), cycle_revolutions=1, max_order=24, samples_per_cycle=32)
    with pytest.raises(SignalError, match="max_order = 0: expected a positive order"):
        spectra(_synthetic(rng), cycle_revolutions=1, max_order=0)


def test_cli_orders_selects_exact_orders(
    tmp_path: Path, rng: np.random.Generator, capsys: pytest.CaptureFixture[str]
) -> None:
    """Review finding: with blocks of several cycles, --orders matched the neighbouring bins too."""
    path = write_hdf5(_synthetic(rng), tmp_path / "r.h5")
    assert main(["spectrum", str(path), "--json", "--orders", "1,2,7", "--block-cycles", "4"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["channels"]["mb1-vertical"]["orders"] == [1.0, 2.0, 7.0]
    assert main(["spectrum", str(path), "--orders", "1.1"]) == 2
    assert "not on the grid" in capsys.readouterr().err
    with pytest.raises(SystemExit) as refused:  # argparse refuses it before anything runs
        main(["spectrum", str(path), "--max-order", "0"])
    assert refused.value.code == 2


def test_a_ttl_keyphasor_read_from_a_file_drives_the_spectrum(
    tmp_path: Path, rng: np.random.Generator
) -> None:
    """Review finding: a 0/5 V keyphasor read back from a file was masked as clipped and refused."""
    recording = _synthetic(rng, tooth=False)
    t = np.arange(recording.channels[0].data.size) / FS
    w = 104 * math.pi / 30 * (1 + 0.1 * np.sin(2 * np.pi * 0.05 * t))
    alpha = cumulative_trapezoid(w, t, initial=0.0) + 0.2
    ttl = np.where(np.mod(alpha, 2 * math.pi) < 0.05, 5.0, 0.0).astype(np.float32)
    channels = (
        *recording.channels,
        Channel("kp", "keyphasor", "V", ttl, FS, fields={"pulse_angle_deg": 0.0}, range=(0.0, 5.0)),
    )
    path = write_hdf5(Recording(recording.engine_id, recording.start_time, channels), tmp_path / "kp.h5")
    result = spectra(read_recording(path), cycle_revolutions=1, max_order=12)
    assert result.reference.source == "kp"
    for k, (a, _) in ORDERS.items():
        assert result.spectra["mb1-vertical"].magnitude[k] == pytest.approx(a, rel=5e-3)


def test_cli_speed_map_of_a_recording(
    tmp_path: Path, rng: np.random.Generator, capsys: pytest.CaptureFixture[str]
) -> None:
    """Order amplitudes against speed through the CLI: the synthetic orders are constant over speed."""
    path = write_hdf5(_synthetic(rng), tmp_path / "r.h5")
    assert (
        main(
            [
                "spectrum",
                str(path),
                "--json",
                "--speed-map",
                "4",
                "--max-order",
                "8",
                "--map-plot",
                str(tmp_path / "map.png"),
            ]
        )
        == 0
    )
    doc = json.loads(capsys.readouterr().out)
    speed_map = doc["speed_maps"]["mb1-vertical"]
    assert len(speed_map["speed_rpm"]) == 4 and sum(speed_map["cycles"]) > 10
    filled = [row for row, n in zip(speed_map["amplitude"], speed_map["cycles"], strict=True) if n]
    np.testing.assert_allclose([row[1] for row in filled], ORDERS[1][0], rtol=0.01)
    assert (tmp_path / "map.png").read_bytes()[:4] == b"\x89PNG"
    assert main(["spectrum", str(path), "--map-plot", str(tmp_path / "x.png")]) == 2


@pytest.mark.parametrize("suffix", ["h5", "mcap"])
def test_a_file_opened_for_slices_gives_the_spectra_of_the_file_read_whole(
    tmp_path: Path, rng: np.random.Generator, suffix: str
) -> None:
    """open_recording reads waveforms by slices (bounded memory): the numbers of reading the file whole."""
    write = write_hdf5 if suffix == "h5" else write_mcap
    path = write(_synthetic(rng), tmp_path / f"r.{suffix}")
    whole = spectra(read_recording(path), cycle_revolutions=1, max_order=12).spectra
    with open_recording(path) as recording:
        assert not isinstance(recording.channel("mb1-vertical").data, np.ndarray)
        sliced = spectra(recording, cycle_revolutions=1, max_order=12).spectra
    for name, spectrum in whole.items():
        np.testing.assert_allclose(sliced[name].amplitude, spectrum.amplitude, rtol=0, atol=1e-9)


def test_bad_samples_met_while_reading_by_slices_are_refused_with_their_time(
    tmp_path: Path, rng: np.random.Generator
) -> None:
    recording = _synthetic(rng)
    acc = recording.channels[0].data.copy()
    acc[int(12.5 * FS) : int(12.5 * FS) + 3] = np.nan
    bad = Recording(
        recording.engine_id,
        recording.start_time,
        (Channel("mb1-vertical", "acceleration", "m/s^2", acc, FS), recording.channels[1]),
    )
    path = write_hdf5(bad, tmp_path / "nan.h5")
    with open_recording(path) as opened, pytest.raises(FormatError, match=r"'mb1-vertical'.*nan 12\.500"):
        spectra(opened, cycle_revolutions=1, max_order=12)


def test_crank_angular_vibration_from_a_tooth_wheel() -> None:
    """The crank's lead over a uniform rotation at each revolution's mean speed, computed independently
    from the fine trajectory of the test's speed law (t(a) by quadrature, per revolution, FFT), against
    the pipeline's; to first order it is the speed's order amplitude over k times the mean speed."""
    result = spectra(_speed_recording("tooth"), cycle_revolutions=1, max_order=12)
    vibration = result.spectra["crank angular vibration"]
    assert result.units["crank angular vibration"] == "rad"
    w0 = 104 * math.pi / 30
    a = np.linspace(0, 2 * math.pi, 4096 + 1)
    w = w0 * (1 + 0.02 * np.cos(7 * a) + 0.01 * np.cos(2 * a + 1))  # every revolution is alike
    t = cumulative_trapezoid(1 / w, a, initial=0.0)
    lead = a[:-1] - (2 * math.pi / t[-1]) * t[:-1]
    expected = np.fft.rfft(lead) * 2 / lead.size
    for k in (2, 7):
        assert abs(vibration.amplitude[k] - expected[k]) < 2e-3 * abs(expected[k])
    assert abs(vibration.amplitude[7]) == pytest.approx(0.02 / 7, rel=0.03)  # first order in 0.02


def test_spectra_report_progress_and_the_time_of_each_stage(rng: np.random.Generator) -> None:
    """Progress climbs to 1 without going back; every stage the pipeline runs has a time, and the
    channels' resampling is among them."""
    reports: list[float] = []
    result = spectra(_synthetic(rng), cycle_revolutions=1, max_order=12, progress=reports.append)
    assert reports and reports[-1] == pytest.approx(1.0)
    assert all(b >= a for a, b in itertools.pairwise(reports))
    stages = result.stage_seconds
    for name in (
        "angle reference: pulses and decoding",
        "grid times",
        "reading",
        "resampling",
        "steady-speed check",
    ):
        assert name in stages and stages[name] >= 0.0, name
    assert "order spectra" in stages


@pytest.mark.parametrize(("rise", "noted"), [(0.0, False), (0.3, True)])
def test_spectra_say_when_the_speed_is_not_steady(rise: float, noted: bool) -> None:
    """A keyphasor's pulses at a steady 600 rpm, and on a run-up by 30 % over 80 revolutions (times from
    a speed rising linearly with the angle, integrated exactly: t = ln(w(a) / w0) / k). Only the run-up
    is noted, with its first and last cycles' speeds."""
    w0 = 600 * math.pi / 30
    angle = 2 * math.pi * np.arange(81)
    k = rise * w0 / angle[-1]  # d(omega)/d(angle) [1/s]
    times = angle / w0 if rise == 0 else np.log1p(k * angle / w0) / k
    channel = Channel("kp", "keyphasor", "s", times + 0.01, None, fields={"pulse_angle_deg": 0.0})
    result = spectra(Recording("man-b-w-7k98mc", "2026-11-22T10:15:00Z", (channel,)), cycle_revolutions=1)
    said = [n for n in result.reference.notes if n.startswith("the speed is not steady")]
    assert bool(said) is noted
    if noted:
        assert said[0].startswith("the speed is not steady: 601.") and "no steady span" in said[0]
