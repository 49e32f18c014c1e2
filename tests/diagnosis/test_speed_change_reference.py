"""The impact reference at another speed than the baseline's: rings end at other crank angles.

A structure rings for a time after each of the engine's own events (combustion, valves, piston slap),
so a ring's tail ``t`` seconds after an event fixed in crank angle lies ``6 n t`` degrees after it:
at a speed ``n`` above the baseline's ``n0`` the tail reaches further, and a knock window on it hears
more power than the baseline did there, without any knock. These tests build such profiles from the
ring's law (power ``exp(-t / tau)`` after the event, in time) at two speeds and check that the
reference (:func:`monitor.diagnosis.bearings.reference_profile`) absorbs the move the speed change
explains, while a knock where the baseline is quiet still stands out. (Near a ring the allowance costs
sensitivity: a knock must then outgrow the ring's loudest bin within the allowance.)
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from monitor.diagnosis.bearings import RING_S, impact_score, reference_profile, widened
from monitor.diagnosis.findings import IMPACT_WARNING, SIGNIFICANCE
from monitor.signal.impact import HighFrequencyPower

BINS = 1024  # over a four-stroke's cycle: 0.7 deg a bin
CYCLES = 300
EVENT_DEG = 360.0  # firing top dead centre of the cylinder the sensor hears
TAU_S = 0.002  # the ring's power time constant [s]: a 1 kHz mode at 4 % of critical damping
RING = 300.0  # the ring's power at the event over the floor's [-]
REVERSAL_DEG = 390.0  # a load reversal whose knock window (20 deg before, 30 after) lies on the ring's tail
QUIET_DEG = 600.0  # one whose window the ring has long left


def _ringing(speed_rpm: float, *, knock_at_deg: float | None = None) -> HighFrequencyPower:
    """A sensor's profile: a floor of 1 and a ring of :data:`RING` after the event, decaying in time; a
    knock trebles the floor over 3 bins where given. Each bin's power spreads 100 % over the cycles."""
    centre = (np.arange(BINS) + 0.5) * 720.0 / BINS
    after_s = ((centre - EVENT_DEG) % 720.0) / (6.0 * speed_rpm)
    mean = 1.0 + RING * np.exp(-after_s / TAU_S)
    if knock_at_deg is not None:
        at = int(knock_at_deg / 720.0 * BINS)
        mean[at - 1 : at + 2] += 2.0
    return HighFrequencyPower(mean, mean.copy(), CYCLES, 25600.0, (1000.0, 10000.0), speed_rpm)


def _score(
    recording: HighFrequencyPower, baseline: HighFrequencyPower, reversal_deg: float = REVERSAL_DEG
) -> tuple[float, bool]:
    """A window's score and whether it would be heard (beyond the warning limit, significantly)."""
    profile, reference = reference_profile(baseline, recording, 2)
    s = impact_score(profile, np.radians([reversal_deg]), 1, 2, reference)
    return s.score, s.score >= IMPACT_WARNING and s.significance >= max(SIGNIFICANCE, s.significance_needed)


def test_a_ring_stretched_by_a_faster_run_is_no_knock_but_a_knock_on_it_still_is() -> None:
    """Baseline at 1000 rpm, the recording 10 % faster (a step along the propeller curve): compared bin
    by bin (no allowance for the speed) the ring's tail in the window reads as a knock; with the
    allowance of :data:`RING_S` it reads as the baseline, and a knock where the ring has died away is
    still heard."""
    baseline, faster = _ringing(1000.0), _ringing(1100.0)
    unmoved = impact_score(faster, np.radians([REVERSAL_DEG]), 1, 2, baseline)
    assert unmoved.score >= IMPACT_WARNING and unmoved.significance >= unmoved.significance_needed

    score, heard = _score(faster, baseline)
    assert not heard, score
    quiet_score, heard = _score(faster, baseline, QUIET_DEG)
    assert not heard, quiet_score
    knocked_score, knocked = _score(_ringing(1100.0, knock_at_deg=QUIET_DEG + 15.0), baseline, QUIET_DEG)
    assert knocked, knocked_score


def test_at_the_baseline_speed_the_reference_is_the_baseline_itself() -> None:
    """No speed change, no allowance: every bin of the reference is the baseline's."""
    baseline = _ringing(1000.0)
    _, reference = reference_profile(baseline, _ringing(1000.0), 2)
    assert reference is not None
    np.testing.assert_array_equal(reference.mean, baseline.mean)


def test_the_allowance_is_the_angle_a_ring_moves_in_ring_s() -> None:
    """A single loud bin spreads over ``6 |n - n0| RING_S`` degrees either side, rounded to bins."""
    mean = np.ones(BINS)
    mean[500] = 10.0
    baseline = HighFrequencyPower(mean, np.ones(BINS), CYCLES, 25600.0, (1000.0, 10000.0), 1000.0)
    recording = HighFrequencyPower(np.ones(BINS), np.ones(BINS), CYCLES, 25600.0, (1000.0, 10000.0), 1100.0)
    _, reference = reference_profile(baseline, recording, 2)
    assert reference is not None
    reach = round(6.0 * 100.0 * RING_S / (720.0 / BINS))
    assert np.flatnonzero(reference.mean == 10.0).tolist() == list(range(500 - reach, 501 + reach))


@settings(max_examples=60, deadline=None)
@given(
    mean=arrays(np.float64, st.integers(8, 256), elements=st.floats(0.0, 1e6)),
    angle=st.floats(0.0, 200.0),
    more=st.floats(0.0, 100.0),
)
def test_widening_never_lowers_a_bin_and_grows_with_the_angle(
    mean: np.ndarray, angle: float, more: float
) -> None:
    """Each bin of a widened profile is at least its own, keeps a value the profile has (with that
    bin's spread), and a wider angle never gives a lower bin; the loudest bin stays the loudest."""
    std = np.sqrt(mean) + 1.0
    profile = HighFrequencyPower(mean, std, 10, 25600.0)
    once, wider = widened(profile, angle, 2), widened(profile, angle + more, 2)
    assert np.all(once.mean >= mean)
    assert np.all(wider.mean >= once.mean)
    assert once.mean.max() == mean.max()
    for m, s in zip(once.mean, once.std, strict=True):
        assert any(m == a and s == b for a, b in zip(mean, std, strict=True))


def test_no_widening_under_half_a_bin() -> None:
    """Under half a bin's angle the profile is returned as it is."""
    profile = _ringing(1000.0)
    assert widened(profile, 0.49 * 720.0 / BINS, 2) is profile
    assert math.isclose(widened(profile, 0.51 * 720.0 / BINS, 2).mean.sum(), profile.mean.sum()) is False


@pytest.mark.parametrize("speed", [math.nan, 1000.0])
def test_a_profile_of_unknown_speed_is_compared_bin_by_bin(speed: float) -> None:
    """Where either speed is not known the allowance cannot be sized: none is made."""
    baseline = HighFrequencyPower(np.arange(BINS, dtype=float), np.ones(BINS), CYCLES, 25600.0)
    recording = HighFrequencyPower(np.ones(BINS), np.ones(BINS), CYCLES, 25600.0, speed_rpm=speed)
    _, reference = reference_profile(baseline, recording, 2)
    assert reference is not None
    np.testing.assert_array_equal(reference.mean, baseline.mean)
