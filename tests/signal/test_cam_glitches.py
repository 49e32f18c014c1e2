"""Glitches and stray pulses on a cam or a keyphasor are dropped and counted, not a refusal.

The captures are written here, pulse by pulse (not by the product's scene writer): a four-stroke
turning at a steady 1420 rpm with a 36-1 crank wheel, a once-per-cycle cam pulse at 100 deg after
cylinder 1's firing TDC, and glitches among the cam's (or the keyphasor's) pulses at random times, one
for every ten pulses, as a logic analyser records sub-microsecond spikes. And a cam wheel of several
teeth (Honda's 4+1), whose position 0 marks the cycle once its pattern is declared.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from monitor.errors import SignalError
from monitor.io.recording import Channel, Recording
from monitor.signal.cam import AGREEING, cycle_phase_from_cam
from monitor.signal.reference import angle_reference

SPEED = 1420 * math.pi / 30  # [rad/s]
TEETH = 36
CAM_DEG = 100.0  # the cam pulse's cycle angle after cylinder 1's firing TDC [deg]
CYCLES = 40
FIRING_AT = 2 * math.pi  # cylinder 1 fires in the second revolution: the cam must tell it


def _time(angle: np.ndarray) -> np.ndarray:
    """The time of a crank angle counted from the wheel's first tooth [s]."""
    return 0.01 + angle / SPEED


def _glitched(times: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The pulses with one glitch for every ten at a random time among them; the glitches' times."""
    glitches = rng.uniform(times[0], times[-1], size=times.size // 10)
    return np.sort(np.concatenate([times, glitches])), np.sort(glitches)


def _cam_times() -> np.ndarray:
    """One pulse a cycle at CAM_DEG after each firing TDC of cylinder 1 [s]."""
    return _time(FIRING_AT + math.radians(CAM_DEG) + 4 * math.pi * np.arange(CYCLES - 1))


def _recording(cam: np.ndarray | None = None, keyphasor: np.ndarray | None = None) -> Recording:
    """A 36-1 wheel's tooth edges with a cam's pulses, or a keyphasor's alone, all as event times."""
    channels = []
    if cam is not None:
        position = np.arange(2 * CYCLES * TEETH)
        tooth = _time(2 * math.pi * position[np.mod(position, TEETH) != TEETH - 1] / TEETH)
        fields = {"teeth": TEETH, "missing_teeth": 1, "first_tooth_angle_deg": 0.0}
        channels.append(Channel("crank", "tooth", "s", tooth, None, fields=fields))
        channels.append(Channel("cam", "cam", "s", cam, None, fields={"cam_angle_deg": CAM_DEG}))
    if keyphasor is not None:
        channels.append(Channel("kp", "keyphasor", "s", keyphasor, None, fields={"pulse_angle_deg": 0.0}))
    return Recording("medium-speed-6l32", "2026-11-22T10:15:00Z", tuple(channels))


@pytest.mark.parametrize("seed", range(5))
def test_a_cam_with_one_glitch_in_ten_gives_the_phase_and_counts_them(seed: int) -> None:
    cam, glitches = _glitched(_cam_times(), np.random.default_rng(seed))
    reference = angle_reference(_recording(cam=cam), cycle_revolutions=2)
    assert reference.cycle_phase == "cam"
    # cylinder 1's firing TDC is now at cycle angle 0 (mod 720 deg); the wrong phase would put it at 360
    firing = reference.angle_map.angle_at(_time(np.array([FIRING_AT])))[0]
    assert math.remainder(firing, 4 * math.pi) == pytest.approx(0.0, abs=1e-6)
    (said,) = [n for n in reference.notes if n.startswith("cam 'cam'")]
    # a glitch that falls within 90 deg of the stated angle in a cycle is no worse than any other: the
    # pulse nearer the stated angle is kept, so exactly the glitches are dropped
    assert f"{glitches.size} of {cam.size} pulses dropped" in said
    assert f"{glitches[0]:.6f} s" in said


def test_without_glitches_no_cam_note() -> None:
    reference = angle_reference(_recording(cam=_cam_times()), cycle_revolutions=2)
    assert reference.cycle_phase == "cam" and not [n for n in reference.notes if "cam" in n]


def test_without_a_consistent_majority_the_phase_is_refused_naming_the_pulses() -> None:
    """Every third cycle's pulse a revolution off (a cam read on the wrong wheel, two sensors on one
    input): a third disagree, more than the quarter AGREEING leaves; the message names them."""
    cam = _cam_times()
    cam[::3] = _time(
        FIRING_AT + 2 * math.pi + math.radians(CAM_DEG) + 4 * math.pi * np.arange(cam[::3].size) * 3
    )
    assert 1 - AGREEING < 1 / 3
    with pytest.raises(SignalError) as refused:
        angle_reference(_recording(cam=cam), cycle_revolutions=2)
    said = str(refused.value)
    assert said.startswith("cam 'cam': cycle phase: ")
    assert f"{cam.size - cam[::3].size} of {cam.size} cam pulses" in said
    assert f"{cam[0]:.6f} s" in said and "(their cycle angles 460.0, 460.0" in said


def test_a_cam_pulse_doubled_in_a_cycle_keeps_the_one_at_the_stated_angle() -> None:
    from monitor.signal.anglemap import AngleMap

    marks = 2 * math.pi * np.arange(0, 2 * CYCLES)
    angle_map = AngleMap(_time(marks), marks)  # angle 0: a TDC of cylinder 1 (not yet the firing one)
    cam = _cam_times()
    echo = _time(np.array([FIRING_AT + math.radians(CAM_DEG + 40.0)]))  # within 90 deg: a second pulse
    phase = cycle_phase_from_cam(
        angle_map, np.sort(np.concatenate([cam, echo])), cam_angle=math.radians(CAM_DEG)
    )
    assert phase.shift == pytest.approx(2 * math.pi)
    assert phase.dropped.tolist() == echo.tolist()


@pytest.mark.parametrize("seed", range(3))
def test_a_keyphasor_with_one_glitch_in_ten_is_repaired_and_counted(seed: int) -> None:
    revolutions = _time(2 * math.pi * np.arange(120))
    pulses, glitches = _glitched(revolutions, np.random.default_rng(100 + seed))
    reference = angle_reference(_recording(keyphasor=pulses), cycle_revolutions=1)
    (said,) = [n for n in reference.notes if n.startswith("keyphasor 'kp'")]
    assert f"{glitches.size} extra pulse(s) dropped" in said
    assert reference.repairs == glitches.size
    mean = (reference.angle_map.angles[-1] - reference.angle_map.angles[0]) / (
        reference.angle_map.times[-1] - reference.angle_map.times[0]
    )
    assert mean == pytest.approx(SPEED, rel=1e-9)


def _four_plus_one(extra_deg: float = 27.5) -> np.ndarray:
    """Honda's 4+1 cam wheel as written here, rising edges: teeth 90 cam deg apart, one more
    ``extra_deg`` after the tooth at position 0, which sits CAM_DEG of cycle after the firing TDC; a
    cam degree is two of crank [s]."""
    cam_deg = np.sort(np.array([0.0, 90.0, 180.0, 270.0, extra_deg]))
    cycle = (np.arange(CYCLES - 1)[:, None] * 720.0 + 2 * cam_deg).ravel()
    return _time(FIRING_AT + np.radians(CAM_DEG + cycle))


def test_a_four_plus_one_cam_wheel_marks_the_cycle_by_its_position_zero() -> None:
    """Declared 4+1, the wheel is decoded over the cam's turns and its position 0 gives the phase:
    cylinder 1's firing TDC at cycle angle 0, no pulse dropped. Undeclared, four of its five pulses
    a cycle disagree and the phase is refused; declared with the falling edges' spacing (0.217 of a
    pitch) the rising edges' extra tooth (0.306) breaks the pattern and the refusal gives its time."""
    cam = _four_plus_one()
    recording = _recording(cam=cam)
    declared = replace(recording.channel("cam"), fields={"cam_angle_deg": CAM_DEG, "pattern": "4+1"})
    reference = angle_reference(
        replace(recording, channels=(recording.channels[0], declared)), cycle_revolutions=2
    )
    assert reference.cycle_phase == "cam" and not [n for n in reference.notes if "cam" in n]
    firing = reference.angle_map.angle_at(_time(np.array([FIRING_AT])))[0]
    assert math.remainder(firing, 4 * math.pi) == pytest.approx(0.0, abs=1e-6)
    with pytest.raises(SignalError, match=r"cam 'cam': cycle phase: \d+ of \d+ cam pulses"):
        angle_reference(recording, cycle_revolutions=2)
    falling = replace(declared, fields={"cam_angle_deg": CAM_DEG, "pattern": "4: 0-3 + 0.217"})
    with pytest.raises(SignalError, match=r"cam 'cam': wheel 4: 0-3 \+ 0.217: the interval from t = "):
        angle_reference(replace(recording, channels=(recording.channels[0], falling)), cycle_revolutions=2)
