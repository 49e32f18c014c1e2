"""Scenes with angle sensors as real ones deliver them: Hall and VR tooth wheels, encoders with an index.

Each recording is simulated from a scene, written to HDF5 and read back, and its angle reference is
built by the product's pipeline (:func:`monitor.signal.reference.angle_reference`); what it finds is compared
with what the scene put in: the crank angle of the scene's speed (without ``crank_speed`` the crank
turns at the trend's speed, so its angle is the trend's integral) and the truth the simulation
records (each tooth's spacing error, and where a VR sensor's zero crossing sits against its tooth).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from monitor.errors import SceneError
from monitor.io import read_recording
from monitor.io.hdf5 import write_hdf5
from monitor.io.recording import Recording
from monitor.scene import Scene, load_scene, parse_scene, simulate
from monitor.signal.pulses import detect_edges
from monitor.signal.reference import angle_reference

SCENES = Path(__file__).resolve().parents[2] / "recordings" / "scenes"
PITCH = 2 * math.pi / 60


def _scene(
    sensors: list[dict[str, Any]], effects: dict[str, Any], *, rpm: float = 1000.0, **top: Any
) -> Scene:
    data = {
        "engine": "zubaydi-1cyl-2stroke",
        "duration_s": 4.0,
        "operating_point": {"speed_rpm": rpm},
        "sensors": sensors,
        "effects": effects,
        **top,
    }
    return parse_scene(data)


def _through_hdf5(recording: Recording, tmp_path: Path, name: str = "r.h5") -> Recording:
    return read_recording(write_hdf5(recording, tmp_path / name))


def _off_by(angles: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Measured minus true crank angle, wrapped to +-pi (the map counts revolutions from its first gap,
    and a four-stroke's cycle phase adds 0 or 2 pi) [rad]."""
    return np.asarray(np.remainder(angles - truth + math.pi, 2 * math.pi) - math.pi)


def _ramp_angle(t: np.ndarray, rpm_from: float, rpm_to: float, duration: float) -> np.ndarray:
    """The crank angle of a linear ramp of the mean speed, from 0 at t = 0 [rad]."""
    w0, w1 = rpm_from * math.pi / 30, rpm_to * math.pi / 30
    return np.asarray(w0 * t + (w1 - w0) * t**2 / (2 * duration))


def _check_run_up(recording: Recording, rpm_from: float, rpm_to: float, duration: float) -> Any:
    """Every revolution of a run-up decoded with no repair, each tooth where the crank was.

    Tolerance 0.15 deg: the simulator integrates time against angle numerically (0.04 deg off the
    closed form over this minute), and noise jitters the slowest teeth (20 rpm: 0.2 V lobes with 10 mV
    of noise, 0.02 deg rms); measured: under 0.08 deg.
    """
    reference = angle_reference(recording, cycle_revolutions=2)
    assert reference.source == "tooth" and reference.cycle_phase == "cam"
    assert reference.repairs == 0
    times, angles = reference.angle_map.times, reference.angle_map.angles
    steps = np.rint(np.diff(angles) / PITCH)
    assert set(steps.tolist()) == {1.0, 3.0}  # teeth one pitch apart, the gap three
    assert np.count_nonzero(steps == 3.0) == pytest.approx((angles[-1] - angles[0]) / (2 * math.pi), abs=1)
    true = _ramp_angle(times, rpm_from, rpm_to, duration)
    # every revolution between the first gap (the recording starts at the tooth after a gap, at 0) and
    # the last whose next tooth is recorded; the teeth outside them may be dropped
    end = float(_ramp_angle(np.array(duration), rpm_from, rpm_to, duration))
    last_gap = 2 * math.pi * math.floor((end - PITCH) / (2 * math.pi))
    assert true[0] < 2 * math.pi + 0.5 * PITCH and true[-1] > last_gap - 0.5 * PITCH
    assert math.degrees(np.max(np.abs(_off_by(angles, true)))) < 0.15
    return reference


@pytest.mark.slow
def test_a_vr_wheel_over_a_run_up_from_20_to_2000_rpm_decodes_every_revolution(tmp_path: Path) -> None:
    """The shipped scene: a 60-2 VR wheel, 0.2 V peak at 20 rpm to 20 V at 2000 rpm, 10 mV of noise,
    over a minute of linear ramp (the trend's ramp expresses 20 to 2000 rpm as asked). Every revolution
    between the first gap and the last (1009 of the 1010 turned) is decoded, no tooth inserted or
    removed; the product corrects the gap's two neighbours by what the truth says their zero crossings
    are moved (0.36 deg, within 0.02 deg)."""
    scene = load_scene(SCENES / "kluczyk-1cyl-vr-run-up.toml")
    simulation = simulate(scene)
    recording = _through_hdf5(simulation.recording, tmp_path)
    assert recording.channel("tooth").fields["sensor"] == "vr"
    assert "polarity" not in recording.channel("tooth").fields
    reference = _check_run_up(recording, 20.0, 2000.0, scene.duration_s)
    assert not any("inferred" in note for note in reference.notes)  # the sensor kind was stated
    offsets = simulation.truth["expected_orders"]["tooth timing"]["timing_offset_deg"]
    assert offsets[0] > 0.3 and offsets[-1] < -0.3 and max(abs(o) for o in offsets[1:-1]) < 1e-3
    correction = reference.pitch_correction
    assert correction is not None
    assert math.degrees(correction.errors[0]) == pytest.approx(offsets[0], abs=0.02)
    assert math.degrees(correction.errors[-1]) == pytest.approx(offsets[-1], abs=0.02)


@pytest.mark.slow
def test_a_hall_wheel_over_the_same_run_up_decodes_every_revolution(tmp_path: Path) -> None:
    """The same run-up read by a Hall sensor (square pulses 0.2 to 5 V, 50 mV of noise): every
    revolution decoded with no repair, each tooth within 0.15 deg of the crank angle; its teeth are
    timed at their angles, so the gap's neighbours need no correction (the product leaves them)."""
    shipped = load_scene(SCENES / "kluczyk-1cyl-vr-run-up.toml")
    hall = shipped.sensors[0].model_copy(update={"signal": "hall"})
    scene = shipped.model_copy(
        update={"sensors": [hall, *shipped.sensors[1:]], "effects": {"noise": {"tooth": 0.05}}}
    )
    simulation = simulate(scene)
    data = simulation.recording.channel("tooth").data
    low, high = np.percentile(data, [5, 95])  # the rails, with the noise
    assert low == pytest.approx(0.2, abs=0.1) and high == pytest.approx(5.0, abs=0.1)
    recording = _through_hdf5(simulation.recording, tmp_path)
    assert recording.channel("tooth").fields["sensor"] == "hall"
    reference = _check_run_up(recording, 20.0, 2000.0, scene.duration_s)
    assert reference.pitch_correction is None or reference.pitch_correction.largest == 0.0
    assert simulation.truth["expected_orders"]["tooth timing"]["timing_offset_deg"] == [0.0] * 58


def _steady_errors(recording: Recording, rpm: float) -> np.ndarray:
    """Each present tooth's measured angle error at steady speed: the true crank angle at its time
    minus the nominal angle the map gives it, averaged over the revolutions [deg]."""
    reference = angle_reference(recording, cycle_revolutions=1, pitch_correction="none")
    times, angles = reference.angle_map.times, reference.angle_map.angles
    error = _off_by(rpm * math.pi / 30 * times, angles)
    tooth = np.mod(np.rint(angles / PITCH).astype(np.int64), 60)
    return np.degrees([np.mean(error[tooth == k]) for k in range(58)])


@pytest.mark.parametrize("signal", ["vr", "hall"])
def test_tooth_spacing_errors_are_where_the_truth_says(signal: str, tmp_path: Path) -> None:
    """Tooth errors of rms 0.1 deg, steady 1000 rpm, noise: the angle map before any correction puts
    each tooth where the truth says, within 0.02 deg after removing a constant (measured: 0.002 deg for
    both). The truth is the tooth's error plus its sensor's timing offset: zero for Hall;
    for VR the gap's field moves the zero crossings of the two teeth beside it by 0.36 deg, and the
    truth says so (without the offsets those two are 0.36 deg off; every other tooth is within 0.02)."""
    sensor = {"name": "wheel", "kind": "tooth", "signal": signal}
    noise = 0.01 if signal == "vr" else 0.05
    effects = {"tooth_spacing_errors": {"sensor": "wheel", "rms_deg": 0.1}, "noise": {"wheel": noise}}
    simulation = simulate(_scene([sensor], effects))
    recording = _through_hdf5(simulation.recording, tmp_path)
    measured = _steady_errors(recording, 1000.0)
    truth = simulation.truth["expected_orders"]
    errors = np.asarray(truth["wheel tooth errors"]["error_deg"][:58])
    assert np.sqrt(np.mean(np.square(truth["wheel tooth errors"]["error_deg"]))) == pytest.approx(0.1)
    offsets = np.asarray(truth["wheel timing"]["timing_offset_deg"])
    off = measured - (errors + offsets)
    assert np.max(np.abs(off - off.mean())) < 0.02
    plain = measured - errors
    plain -= np.median(plain)
    if signal == "vr":
        assert abs(plain[0]) > 0.3 and abs(plain[57]) > 0.3 and np.max(np.abs(plain[1:57])) < 0.02
    else:
        assert np.max(np.abs(plain)) < 0.02


def test_a_vr_voltage_grows_with_speed_and_takes_the_scenes_noise() -> None:
    """An ordinary lobe (away from the gap) peaks at vr_peak_v_at_1000_rpm at 1000 rpm and at half of it
    at 500 rpm (within 1 %: the peak falls between samples); the gap's lobes are larger (the flux's dip).
    The noise effect adds Gaussian noise of the stated rms to the waveform, as to any channel."""
    sensor = {"name": "wheel", "kind": "tooth", "signal": "vr", "vr_peak_v_at_1000_rpm": 8.0}
    for rpm in (500.0, 1000.0):
        clean = simulate(_scene([sensor], {}, rpm=rpm, duration_s=1.0))
        assert clean.evaluated == ()
        channel = clean.recording.channel("wheel")
        lobes = detect_edges(channel.data, 25600.0, timing="zero-crossing", direction="falling").swings
        assert np.median(lobes) == pytest.approx(8.0 * rpm / 1000.0, rel=0.01)
        assert np.max(lobes) > 2.5 * np.median(lobes)
    noisy = simulate(_scene([sensor], {"noise": {"wheel": 0.03}}, duration_s=1.0))
    difference = noisy.recording.channel("wheel").data.astype(np.float64) - channel.data
    assert np.std(difference) == pytest.approx(0.03, rel=0.02)


def test_a_vr_sensor_wired_the_wrong_way_round_is_recognised(tmp_path: Path) -> None:
    """polarity = "reversed" inverts the voltage (the wires swapped). Left unstated, as nobody knows the
    wires are swapped, the product recognises it, says to swap them, and times every tooth where the
    crank was (0.05 deg); stated, the product decodes it so directly, with nothing to say."""
    sensor = {"name": "wheel", "kind": "tooth", "signal": "vr", "polarity": "reversed"}
    unknown = simulate(_scene([{**sensor, "unstated": ["polarity"]}], {"noise": {"wheel": 0.01}}, rpm=600.0))
    recording = _through_hdf5(unknown.recording, tmp_path, "unknown.h5")
    assert recording.channel("wheel").fields["sensor"] == "vr"
    assert "polarity" not in recording.channel("wheel").fields
    reference = angle_reference(recording, cycle_revolutions=1)
    assert reference.repairs == 0
    assert any("reversed polarity" in note and "swap" in note for note in reference.notes)
    map_ = reference.angle_map
    assert math.degrees(np.max(np.abs(_off_by(map_.angles, 600 * math.pi / 30 * map_.times)))) < 0.05
    stated = simulate(_scene([sensor], {"noise": {"wheel": 0.01}}, rpm=600.0))
    recording = _through_hdf5(stated.recording, tmp_path, "stated.h5")
    assert recording.channel("wheel").fields["polarity"] == "reversed"
    told = angle_reference(recording, cycle_revolutions=1)
    assert told.repairs == 0 and not told.notes
    np.testing.assert_allclose(told.angle_map.times, map_.times, rtol=0, atol=2e-6)
    inferred = simulate(_scene([{**sensor, "unstated": ["sensor", "polarity"]}], {}, rpm=600.0))
    notes = angle_reference(inferred.recording, cycle_revolutions=1).notes
    assert any("'vr' inferred" in note for note in notes) and any("swap" in note for note in notes)


@pytest.mark.parametrize("representation", ["waveform", "events"])
def test_an_encoder_with_its_index_is_the_angle_reference(representation: str, tmp_path: Path) -> None:
    """A 360-pulse encoder (square 0-5 V pulses, or their edge times) and a keyphasor as its index, 600
    rpm: the product takes the encoder as the angle reference, its mean speed is the scene's (1e-6),
    and every pulse is at the crank angle (0.01 deg; sampled at 25.6 kHz a pulse is 7 samples long)."""
    sensors = [
        {
            "name": "enc",
            "kind": "encoder",
            "pulses_per_revolution": 360,
            "first_pulse_angle_deg": 30.0,
            "representation": representation,
        },
        {"name": "index", "kind": "keyphasor", "pulse_angle_deg": 30.2},
    ]
    simulation = simulate(_scene(sensors, {"noise": {"enc": 0.02, "index": 0.02}}, rpm=600.0))
    recording = _through_hdf5(simulation.recording, tmp_path)
    encoder = recording.channel("enc")
    assert encoder.kind == "encoder" and encoder.unit == ("V" if representation == "waveform" else "s")
    assert encoder.fields == {"pulses_per_revolution": 360, "first_pulse_angle_deg": 30.0}
    reference = angle_reference(recording, cycle_revolutions=1)
    assert reference.source == "enc" and reference.pulses_per_revolution == 360 and reference.repairs == 0
    assert reference.angle_map.mean_speed * 30 / math.pi == pytest.approx(600.0, rel=1e-6)
    map_ = reference.angle_map
    assert math.degrees(np.max(np.abs(_off_by(map_.angles, 20 * math.pi * map_.times)))) < 0.01


def test_an_encoder_names_its_index_and_the_index_must_be_at_its_first_pulse() -> None:
    """index_channel names the keyphasor holding the index (written as the channel's attribute); an
    index more than a quarter pulse from first_pulse_angle_deg is refused, with the angle to state."""
    sensors = [
        {"name": "kp", "kind": "keyphasor", "pulse_angle_deg": 100.0, "representation": "events"},
        {"name": "index", "kind": "keyphasor", "pulse_angle_deg": 10.0, "representation": "events"},
        {"name": "enc", "kind": "encoder", "first_pulse_angle_deg": 10.0, "index_channel": "index"},
    ]
    simulation = simulate(_scene(sensors, {}, rpm=600.0))
    assert simulation.recording.channel("enc").fields["index_channel"] == "index"
    reference = angle_reference(simulation.recording, cycle_revolutions=1)
    assert reference.source == "enc"
    map_ = reference.angle_map
    assert math.degrees(np.max(np.abs(_off_by(map_.angles, 20 * math.pi * map_.times)))) < 0.01
    with pytest.raises(
        SceneError, match=r"index 'kp' is at pulse_angle_deg = 100.*first_pulse_angle_deg = 100"
    ):
        _scene([*sensors[:2], {**sensors[2], "index_channel": None}], {})
    with pytest.raises(SceneError, match="index_channel 'enc2' is not a keyphasor sensor"):
        _scene([*sensors[:2], {**sensors[2], "index_channel": "enc2"}], {})


@pytest.mark.parametrize(
    ("sensor", "message"),
    [
        ({"name": "kp", "kind": "keyphasor", "signal": "vr"}, "signal = 'vr' is a tooth wheel's"),
        ({"name": "w", "kind": "tooth", "signal": "hall", "representation": "events"}, "shapes a waveform"),
        ({"name": "w", "kind": "tooth", "signal": "hall", "polarity": "reversed"}, "needs signal = 'vr'"),
        ({"name": "w", "kind": "tooth", "unstated": ["sensor"]}, "unstated names attributes of a hall or vr"),
        (
            {"name": "w", "kind": "tooth", "signal": "vr", "unstated": ["teeth"]},
            "unstated.0: Input should be",
        ),
        ({"name": "w", "kind": "tooth", "index_channel": "kp"}, "index_channel is an encoder's"),
        (
            {"name": "e", "kind": "encoder", "sample_rate_hz": 20000.0},
            r"fewer than 4 samples per pulse at 1000 rpm",
        ),
        (
            {"name": "w", "kind": "tooth", "signal": "vr", "sample_rate_hz": 2000.0},
            "raise it to at least 4000",
        ),
    ],
)
def test_sensor_options_that_cannot_be_simulated_as_written_are_refused(
    sensor: dict[str, Any], message: str
) -> None:
    with pytest.raises(SceneError, match=message):
        _scene([sensor], {})


def test_a_plain_tooth_wheel_is_written_as_before() -> None:
    """signal defaults to "pulse": the flat-bottomed pulses and the three attributes of before, no
    sensor or polarity attribute and no timing entry in the truth (the committed samples are checked
    against a fresh simulation in test_scene.py)."""
    simulation = simulate(_scene([{"name": "tooth", "kind": "tooth"}], {}, duration_s=1.0))
    tooth = simulation.recording.channel("tooth")
    assert tooth.fields == {"teeth": 60, "missing_teeth": 2, "first_tooth_angle_deg": 0.0}
    assert simulation.truth["expected_orders"] == {}
    assert 0.19 < float(np.min(tooth.data)) and float(np.max(tooth.data)) < 3.21


def test_tooth_errors_that_would_make_teeth_collide_are_refused() -> None:
    """A Hall or VR wheel's teeth move with their errors; errors that bring two teeth within half a pitch
    of each other cannot be a wheel, and are refused with what to change."""
    sensor = {"name": "w", "kind": "tooth", "teeth": 120, "missing_teeth": 10, "signal": "hall"}
    scene = _scene([sensor], {"tooth_spacing_errors": {"sensor": "w", "rms_deg": 0.9}}, duration_s=0.5)
    with pytest.raises(SceneError, match=r"within half a pitch \(1.5 deg\) of each other.*lower rms_deg"):
        simulate(scene)
