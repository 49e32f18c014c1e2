"""The high-frequency profile's part that varies from cycle to cycle, and the impact rule that needs it.

An engine's own events ring at fixed crank angles with the same phase every cycle; a bearing's knock
comes a little earlier or later each cycle. The profile's varying part
(:attr:`monitor.signal.impact.HighFrequencyPower.varying`) is the power left after the synchronous
average's; a knock's span must stand out in it as well as in the whole power
(:func:`monitor.diagnosis.bearings.impact_score`) where the reference's repeating part is not known:
away from the speed it was measured at.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from monitor.diagnosis.baseline import Baseline, SensorBaseline
from monitor.diagnosis.bearings import REPEATING_SPEED_TOLERANCE, impact_score, repeats_at, varying_note
from monitor.diagnosis.impact_reference import between, loudest, widened
from monitor.signal.anglemap import AngleMap
from monitor.signal.impact import HighFrequencyPower
from monitor.signal.resample import to_angle_domain

FS = 51200.0  # [Hz]
RATE = 10.0  # revolutions per second: 5120 samples a revolution, so a fixed event repeats sample for sample
BINS = 512  # the profile's bins per revolution at this speed: 10 samples each
SECONDS = 12.0
SIGMA = 0.5  # the noise's rms
EVENT_BIN = 100  # where the engine's own event rings every cycle, alike
KNOCK_BIN = 300  # where a knock rings, 0 to 2 ms late and of either sign, cycle by cycle


def _burst(frequency_hz: float, samples: int = 64) -> np.ndarray:
    j = np.arange(samples)
    return 5 * SIGMA * np.hanning(samples) * np.sin(2 * math.pi * frequency_hz * j / FS)


def _profile(signal: np.ndarray, start: float) -> HighFrequencyPower:
    pulses = start + np.arange(int((SECONDS - 0.05) * RATE)) / RATE
    angle_map = AngleMap.from_keyphasor(pulses, pulse_angle=0.0)
    profile = to_angle_domain(
        signal, FS, angle_map, samples_per_cycle=BINS, high_frequency=True
    ).high_frequency
    assert profile is not None and profile.varying is not None and profile.mean.size == BINS
    return profile


def _at_bin(start: float, cycle: int, bin_: int) -> int:
    return round((start + (cycle + (bin_ + 0.25) / BINS) / RATE) * FS)


def test_a_ring_that_repeats_every_cycle_leaves_the_varying_part_as_the_noise_alone(
    rng: np.random.Generator,
) -> None:
    """White noise, a 2 kHz ring of 5 sigma at the same angle of every cycle (sample for sample), and a
    9 kHz knock of 5 sigma delayed 0 to 2 ms at random, of random sign:

    - the repeating ring lifts the whole power tens of times over the noise, and leaves the varying
      part as the noise alone makes it: in the synchronous average's deviations the ring cancels
      exactly, so the varying part with and without it agrees to round-off (1e-9 of the noise's);
    - the knock lifts the varying part by at least 90 % of what it lifts the whole power (its
      synchronous average is near nothing; each angle reads its nearest sample, which keeps every
      frequency's power, and the average takes its 1 / C). A linear interpolation between samples
      would keep about 80 % of a 9 kHz ring's power at 51.2 kHz.
    """
    n = int(SECONDS * FS)
    start = 0.0117
    noise = SIGMA * rng.standard_normal(n)
    ring, knock = _burst(2000.0), _burst(9000.0)
    repeating, varying = np.zeros(n), np.zeros(n)
    for cycle in range(int(SECONDS * RATE)):
        first = _at_bin(start, cycle, EVENT_BIN)
        if first + ring.size < n:
            repeating[first : first + ring.size] = ring
        first = _at_bin(start, cycle, KNOCK_BIN) + int(rng.integers(0, round(2e-3 * FS)))
        if first + knock.size < n:
            varying[first : first + knock.size] = rng.choice([-1.0, 1.0]) * knock
    quiet = _profile(noise, start)
    both = _profile(noise + repeating + varying, start)
    assert quiet.varying is not None and both.varying is not None

    event = slice(EVENT_BIN, EVENT_BIN + 7)  # the ring's 64 samples over 10-sample bins
    floor = float(np.median(quiet.mean))
    assert both.mean[event].max() > 20 * floor
    np.testing.assert_allclose(both.varying[event], quiet.varying[event], rtol=1e-9)

    span = slice(KNOCK_BIN, KNOCK_BIN + 7 + 10)  # the knock's 64 samples, up to 100 samples late
    lifted = float(np.sum(both.mean[span] - quiet.mean[span]))
    lifted_varying = float(np.sum(both.varying[span] - quiet.varying[span]))
    assert lifted > 3 * floor * 17, "the knock's span holds over three times the floor's power"
    assert lifted_varying >= 0.9 * lifted, lifted_varying / lifted


def _flat(mean: np.ndarray, varying: np.ndarray | None, speed_rpm: float = 1000.0) -> HighFrequencyPower:
    """A profile of 300 cycles whose bins spread 100 % from cycle to cycle."""
    return HighFrequencyPower(mean, mean.copy(), 300, 25600.0, (1000.0, 10000.0), speed_rpm, varying)


def test_away_from_the_references_speed_a_knock_must_stand_out_in_the_varying_part_too() -> None:
    """A four-stroke's profile of 1024 bins, a reversal window around 390 deg. The baseline: a floor of
    1 whose varying part is 0.7. The recording: an event seven times the floor in three bins of the
    window whose varying part is the baseline's (it repeats every cycle):

    - at the baseline's speed it is heard: the repeating part is known there, and a knock that
      repeats as exactly as the engine's events is a knock;
    - against a reference interpolated between points at 900 and 1100 rpm, or one at 1050 rpm (5 %
      away, beyond :data:`REPEATING_SPEED_TOLERANCE`), it is not: how the engine's own rings add is
      not known there (the validation case 200472); a knock that lifts the varying part as well is;
    - a baseline written before the varying part was measured judges the whole power alone.
    """
    bins = 1024
    at = int(390.0 / 720.0 * bins)
    window = np.radians([390.0])
    base = _flat(np.ones(bins), np.full(bins, 0.7))
    event = np.ones(bins)
    event[at - 1 : at + 2] = 7.0
    repeating = _flat(event, np.full(bins, 0.7))
    same = impact_score(repeating, window, 1, 2, base)
    # a knock span of 1.5 ms at 1000 rpm is 9 deg, 13 bins: the event's 3 at 7 and 10 at 1
    assert same.score == pytest.approx((3 * 7.0 + 10) / 13, rel=1e-9)
    assert same.significance > 20.0 > same.significance_needed
    # the limit, pinned from both sides: 0.9 % away the repeating part holds, 1.1 % away it does not
    assert REPEATING_SPEED_TOLERANCE == 0.01
    assert repeats_at(repeating, _flat(np.ones(bins), None, 1009.0))
    assert not repeats_at(repeating, _flat(np.ones(bins), None, 1011.0))
    assert not repeats_at(repeating, _flat(np.ones(bins), None, 989.0))
    spanning = between(
        _flat(np.ones(bins), np.full(bins, 0.7), 900.0), _flat(np.ones(bins), np.full(bins, 0.7), 1100.0), 0.5
    )
    assert spanning is not None and spanning.speed_span() == (900.0, 1100.0)
    assert spanning.speed_rpm == pytest.approx(1000.0)
    for reference in (spanning, _flat(np.ones(bins), np.full(bins, 0.7), 1050.0)):
        assert not repeats_at(repeating, reference)
        score = impact_score(repeating, window, 1, 2, reference)
        assert score.significance < 1.0 < score.significance_needed
        knocking = np.full(bins, 0.7)
        knocking[at - 1 : at + 2] = 6.7
        knock = impact_score(_flat(event, knocking), window, 1, 2, reference)
        assert knock.significance > 20.0 > knock.significance_needed
        assert knock.angle_deg == pytest.approx(390.0, abs=4.5)  # every 9 deg span holding the 3 bins alike
        old = impact_score(repeating, window, 1, 2, replace(reference, varying=None))
        assert old.significance > 20.0 > old.significance_needed


def test_the_diagnosis_says_where_a_knock_must_stand_out_in_the_varying_part_too() -> None:
    """The note names the speeds the reference was measured at (one, or the points' span) and the
    recording's; none at the reference's own speed or against a reference without a varying part."""
    bins = 64
    recording = _flat(np.ones(bins), np.full(bins, 0.7), 1053.0)
    one = _flat(np.ones(bins), np.full(bins, 0.7), 1000.0)
    assert varying_note(recording, one) == (
        "the bearings' impacts are judged also on the part of the high-frequency power that varies from "
        "cycle to cycle: the reference was measured at 1000 rpm, the recording runs at 1053 rpm, where the "
        "engine's own rings may add otherwise"
    )
    spanning = between(one, _flat(np.ones(bins), np.full(bins, 0.7), 1100.0), 0.5)
    assert spanning is not None
    said = varying_note(recording, spanning)
    assert said is not None and "measured at 1000 to 1100 rpm, the recording runs at 1053 rpm" in said
    assert varying_note(recording, _flat(np.ones(bins), np.full(bins, 0.7), 1050.0)) is None  # 0.3 % away
    assert varying_note(recording, replace(one, varying=None)) is None
    assert varying_note(recording, None) is None


def test_the_varying_part_follows_the_profile_through_the_reference() -> None:
    """Coarsened, interpolated between two points, the loudest over several, widened for a speed
    change (an event's bins only): the varying part is carried as the whole power is (each of its own),
    and is lost (None) where one of the profiles combined has none."""
    mean = np.arange(1.0, 9.0)
    one = _flat(mean, 0.5 * mean)
    other = _flat(3.0 * mean[::-1], np.full(8, 2.0))
    coarse = one.coarsened(4)
    assert coarse.varying is not None
    np.testing.assert_allclose(coarse.varying, 0.5 * coarse.mean)
    middle = between(one, other, 0.25)
    assert middle is not None and middle.varying is not None
    np.testing.assert_allclose(middle.varying, 0.75 * 0.5 * mean + 0.25 * 2.0)
    most = loudest([one, other])
    assert most is not None and most.varying is not None
    np.testing.assert_allclose(most.varying, np.maximum(0.5 * mean, 2.0))
    assert loudest([one, _flat(mean, None, 900.0)]).speed_span() == (900.0, 1000.0)  # type: ignore[union-attr]
    most_without = loudest([one, _flat(mean, None)])
    assert most_without is not None and most_without.varying is None
    # one bin either side: the event (three times the median: at least RING_CLASS's twice) carried, the
    # floor's scatter (up to 1.2 times) not
    ringing = np.array([1.0, 1.2, 0.9, 1.1, 1.0, 0.8, 3.0, 1.0])
    wide = widened(_flat(ringing, 0.5 * ringing), 720.0 / 8, 2)
    assert wide.varying is not None
    carried = np.array([1.0, 1.2, 0.9, 1.1, 1.0, 3.0, 3.0, 3.0])
    np.testing.assert_allclose(wide.mean, carried)
    np.testing.assert_allclose(wide.varying, 0.5 * carried)


def test_a_baseline_keeps_the_varying_part_and_reads_one_written_without_it(tmp_path: Path) -> None:
    """The baseline document holds ``high_frequency_varying`` per sensor, exactly (JSON keeps doubles);
    a document without the key (written before it was measured) reads as a profile without one."""
    profile = _flat(np.arange(1.0, 9.0), np.linspace(0.1, 0.8, 8))
    sensor = SensorBaseline(
        "mb1-vertical", "acceleration", "m/s^2", 1, "vertical", 25600.0, np.array([1.0]),
        np.array([1e-6 + 0j]), np.array([1e-8]), profile, 2.0,
    )  # fmt: skip
    baseline = Baseline("e", 1000.0, 1.0, [1.0] * 6, 128, {"mb1-vertical": sensor}, "b.h5")
    read = Baseline.read(baseline.write(tmp_path / "b.json")).sensors["mb1-vertical"].high_frequency
    assert read is not None and read.varying is not None
    assert read.speed_rpm == 1000.0  # the baseline's: its rings are carried from it to a recording's speed
    np.testing.assert_array_equal(read.varying, profile.varying)
    document = baseline.to_document()
    del document["sensors"]["mb1-vertical"]["high_frequency_varying"]
    old = Baseline.from_document(document).sensors["mb1-vertical"].high_frequency
    assert old is not None and old.varying is None and old.varying_part() is None
