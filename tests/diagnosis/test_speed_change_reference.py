"""The impact reference at another speed and load than the baseline's: rings end at other crank
angles, and the engine's own noise is louder.

A structure rings for a time after each of the engine's own events (combustion, valves, piston slap),
so a ring's tail ``t`` seconds after an event fixed in crank angle lies ``6 n t`` degrees after it:
at a speed ``n`` above the baseline's ``n0`` the tail reaches further, and a knock window on it hears
more power than the baseline did there, without any knock. These tests build such profiles from the
ring's law (power ``exp(-t / tau)`` after the event, in time) at two speeds and check that the
reference (:func:`monitor.diagnosis.impact_reference.reference_profile`) absorbs the move the speed change
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

from monitor.diagnosis.bearings import impact_score
from monitor.diagnosis.findings import IMPACT_WARNING, SIGNIFICANCE
from monitor.diagnosis.impact_reference import (
    CLASS_BINS,
    MatchedProfiles,
    class_levels,
    engine_level,
    reference_profile,
    widened,
)
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
    knock makes the floor five times as loud over 3 bins where given. Each bin's power spreads 100 %
    over the cycles."""
    centre = (np.arange(BINS) + 0.5) * 720.0 / BINS
    after_s = ((centre - EVENT_DEG) % 720.0) / (6.0 * speed_rpm)
    mean = 1.0 + RING * np.exp(-after_s / TAU_S)
    if knock_at_deg is not None:
        at = int(knock_at_deg / 720.0 * BINS)
        mean[at - 1 : at + 2] += 4.0
    return HighFrequencyPower(mean, mean.copy(), CYCLES, 25600.0, (1000.0, 10000.0), speed_rpm)


def _score(
    recording: HighFrequencyPower, baseline: HighFrequencyPower, reversal_deg: float = REVERSAL_DEG
) -> tuple[float, bool]:
    """A window's score and whether it would be heard (beyond the warning limit, significantly)."""
    matched = reference_profile(baseline, recording, 2)
    s = impact_score(matched.profile, np.radians([reversal_deg]), 1, 2, matched.reference)
    return s.score, s.score >= IMPACT_WARNING and s.significance >= max(SIGNIFICANCE, s.significance_needed)


def test_a_ring_stretched_by_a_faster_run_is_no_knock_but_a_knock_on_it_still_is() -> None:
    """Baseline at 1000 rpm, the recording 20 % faster (a step along the propeller curve): compared bin
    by bin (no allowance for the speed) the ring's tail in the window reads as a knock; with the
    allowance of :data:`RING_S` it reads as the baseline, and a knock where the ring has died away is
    still heard."""
    baseline, faster = _ringing(1000.0), _ringing(1200.0)
    unmoved = impact_score(faster, np.radians([REVERSAL_DEG]), 1, 2, baseline)
    assert unmoved.score >= IMPACT_WARNING and unmoved.significance >= unmoved.significance_needed

    score, heard = _score(faster, baseline)
    assert not heard, score
    quiet_score, heard = _score(faster, baseline, QUIET_DEG)
    assert not heard, quiet_score
    knocked_score, knocked = _score(_ringing(1200.0, knock_at_deg=QUIET_DEG + 15.0), baseline, QUIET_DEG)
    assert knocked, knocked_score


def test_a_knock_on_a_scattered_floor_is_heard_at_another_speed() -> None:
    """A short baseline's floor scatters from bin to bin (20 cycles of a power that spreads 100 % per
    cycle: 22 % a bin). Carried by the speed allowance, the highest of a dozen floor bins would raise a
    quiet window's reference and hide a knock (the floor read as rings: heard in none of these 20);
    carried only where events ring, the knock is heard in at least 18 of 20 drawn profiles, and a
    healthy run's ring and floor in none."""
    rng = np.random.default_rng(20)

    def scattered(profile: HighFrequencyPower) -> HighFrequencyPower:
        off = 1.0 + rng.standard_normal(profile.mean.size) / math.sqrt(20)
        return HighFrequencyPower(
            profile.mean * off, profile.std, 20, 25600.0, profile.band_hz, profile.speed_rpm
        )

    heard, false = 0, 0
    for _ in range(20):
        baseline = scattered(_ringing(1000.0))
        knocked = scattered(_ringing(1200.0, knock_at_deg=QUIET_DEG + 15.0))
        healthy = scattered(_ringing(1200.0))
        heard += _score(knocked, baseline, QUIET_DEG)[1]
        false += _score(healthy, baseline, QUIET_DEG)[1] + _score(healthy, baseline)[1]
    assert heard >= 18 and false == 0, (heard, false)


def test_at_the_baseline_speed_the_reference_is_the_baseline_itself() -> None:
    """No speed change, no allowance: every bin of the reference is the baseline's."""
    baseline = _ringing(1000.0)
    reference = reference_profile(baseline, _ringing(1000.0), 2).reference
    assert reference is not None
    np.testing.assert_array_equal(reference.mean, baseline.mean)


def test_the_allowance_is_the_angle_a_ring_moves_in_ring_s() -> None:
    """A single loud bin spreads over ``6 |n - n0| RING_S`` degrees either side, rounded to bins."""
    mean = np.ones(BINS)
    mean[500] = 10.0
    baseline = HighFrequencyPower(mean, np.ones(BINS), CYCLES, 25600.0, (1000.0, 10000.0), 1000.0)
    recording = HighFrequencyPower(np.ones(BINS), np.ones(BINS), CYCLES, 25600.0, (1000.0, 10000.0), 1100.0)
    reference = reference_profile(baseline, recording, 2).reference
    assert reference is not None
    # 100 rpm apart over 10 ms of ringing: 6 deg, 8.5 bins of 0.70 deg, rounded to 9 either side
    reach = 9
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
    baseline = HighFrequencyPower(np.arange(1.0, BINS + 1.0), np.ones(BINS), CYCLES, 25600.0)
    recording = HighFrequencyPower(np.full(BINS, 0.5), np.ones(BINS), CYCLES, 25600.0, speed_rpm=speed)
    matched = reference_profile(baseline, recording, 2)
    assert matched.reference is not None and matched.moved_deg == 0.0
    np.testing.assert_array_equal(matched.reference.mean, baseline.mean)


# --- the engine's own noise at another load -------------------------------------------------------


def _louder(factor: float, *, knock_at_deg: float | None = None) -> HighFrequencyPower:
    """The ringing profile at a higher load: the ring ``factor`` times louder, the floor as it was."""
    one = _ringing(1000.0, knock_at_deg=knock_at_deg)
    mean = 1.0 + factor * (one.mean - 1.0)
    return HighFrequencyPower(mean, mean.copy(), CYCLES, 25600.0, one.band_hz, 1000.0)


def test_an_engine_louder_where_it_rings_is_no_knock_but_a_knock_on_its_floor_still_is() -> None:
    """At a higher load the engine's events ring 1.8 times louder, the sensor's floor stays: compared
    with the baseline as it is, the window on the ring reads as a knock; with each class of the
    baseline's bins raised by its own level it reads as the baseline, while a knock on the floor
    (where the level is 1) still stands out."""
    baseline = _ringing(1000.0)
    unraised = impact_score(_louder(1.8), np.radians([REVERSAL_DEG]), 1, 2, baseline)
    assert unraised.score >= IMPACT_WARNING and unraised.significance >= unraised.significance_needed
    matched = reference_profile(baseline, _louder(1.8), 2)
    assert matched.level == pytest.approx(1.8, rel=0.05)
    score, heard = _score(_louder(1.8), baseline)
    assert not heard, score
    knocked_score, knocked = _score(_louder(1.8, knock_at_deg=QUIET_DEG + 15.0), baseline, QUIET_DEG)
    assert knocked, knocked_score


def _narrow_event(height: float, *, at: int = 500, width: int = CLASS_BINS - 3) -> HighFrequencyPower:
    """A floor of 1 and one event narrower than a class can tell, ``height`` above it."""
    mean = np.ones(BINS)
    mean[at : at + width] += height
    return HighFrequencyPower(mean, mean.copy(), CYCLES, 25600.0, (1000.0, 10000.0), 1000.0)


def test_a_sensor_whose_events_are_too_narrow_to_tell_is_raised_by_the_engines_level() -> None:
    """A sensor that hears the engine's own event in a few bins only cannot tell its own level: its
    event 2.5 times louder reads as a knock on its own, and as the engine's noise when the other
    sensors say the engine is 2.5 times louder."""
    baseline, louder = _narrow_event(20.0), _narrow_event(50.0)
    window = np.radians([(500 + 2) * 720.0 / BINS])
    alone = reference_profile(baseline, louder, 2)
    on_its_own = impact_score(alone.profile, window, 1, 2, alone.reference)
    assert on_its_own.score >= IMPACT_WARNING
    told = reference_profile(baseline, louder, 2, engine=2.5)
    with_engine = impact_score(told.profile, window, 1, 2, told.reference)
    assert with_engine.score < IMPACT_WARNING, with_engine.score


def test_the_engine_level_is_the_sensors_median_so_one_knocking_sensor_cannot_set_it() -> None:
    """Three sensors whose events ring as on the baseline, one whose loud bins a knock lifts three
    times: the engine's level is 1; a sensor with no class of events does not vote."""
    quiet = _ringing(1000.0)
    knocked = _louder(3.0)
    flat = HighFrequencyPower(np.ones(BINS), np.ones(BINS), CYCLES, 25600.0, (1000.0, 10000.0), 1000.0)
    pairs = [(quiet, quiet), (quiet, quiet), (quiet, quiet), (quiet, knocked), (flat, flat)]
    assert engine_level(pairs) == pytest.approx(1.0)
    assert math.isnan(engine_level([(flat, flat), (None, quiet)]))
    told = reference_profile(quiet, knocked, 2, engine=1.0)
    assert told.level == 1.0
    assert told.reference is not None
    np.testing.assert_array_equal(told.reference.mean, quiet.mean)


def test_a_quieter_engine_is_judged_against_the_baseline_as_it_is() -> None:
    """At a lower load no class is lowered: a knock must still outgrow the baseline's own noise."""
    baseline = _ringing(1000.0)
    matched = reference_profile(baseline, _louder(0.5), 2)
    assert matched.level == 1.0
    assert matched.reference is not None
    np.testing.assert_array_equal(matched.reference.mean, baseline.mean)


@settings(max_examples=60, deadline=None)
@given(
    baseline=arrays(np.float64, st.integers(16, 512), elements=st.floats(1e-6, 1e6)),
    factor=st.floats(0.1, 10.0),
)
def test_a_uniformly_louder_profile_has_that_level_in_every_class(
    baseline: np.ndarray, factor: float
) -> None:
    """Classes double from the median up (bins at or below it are class 0); a recording that is the
    baseline times a factor has that factor as every class's level."""
    classes, levels = class_levels(factor * baseline, baseline)
    median = np.median(baseline)
    assert np.all(classes[baseline <= median] == 0)
    assert np.all(baseline[classes >= 1] >= 2 * median * (1 - 1e-12))
    np.testing.assert_allclose(levels, factor, rtol=1e-9)


def test_a_class_needs_eight_bins_to_tell_its_level() -> None:
    """Eight bins at four times the median, twice as loud in the recording: their class's level is 2;
    with seven, the class takes the level of the one below (1)."""
    for count, level in ((8, 2.0), (7, 1.0)):
        baseline = np.ones(BINS)
        baseline[:count] = 4.0
        recording = baseline.copy()
        recording[:count] = 8.0
        classes, levels = class_levels(recording, baseline)
        assert levels[classes[0]] == pytest.approx(level), count


def test_events_four_times_the_median_speak_for_the_engine_twice_do_not() -> None:
    """A sensor whose loudest class is four times its median votes for the engine's level; one whose
    loudest is twice its median does not."""

    def sensor(height: float) -> tuple[HighFrequencyPower, HighFrequencyPower]:
        base = np.ones(BINS)
        base[:20] = height
        now = base.copy()
        now[:20] = 1.5 * height
        return (
            HighFrequencyPower(base, base.copy(), CYCLES, 25600.0, (1000.0, 10000.0), 1000.0),
            HighFrequencyPower(now, now.copy(), CYCLES, 25600.0, (1000.0, 10000.0), 1000.0),
        )

    assert engine_level([sensor(4.0)]) == pytest.approx(1.5)
    assert math.isnan(engine_level([sensor(2.0)]))


def test_a_reference_raised_by_a_tenth_is_noted() -> None:
    quiet = _ringing(1000.0)
    raised = MatchedProfiles(quiet, quiet, 1.1)
    assert raised.notes("mb1") and "1.10 x" in raised.notes("mb1")[0]
    assert MatchedProfiles(quiet, quiet, 1.09).notes("mb1") == []
