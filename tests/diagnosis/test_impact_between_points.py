"""The impact reference between two calibrated points: the engine's own events as loud as the load makes them.

An engine calibrated at several loads (:class:`monitor.diagnosis.operating_points.OperatingPoints`)
has a high-frequency profile at each. An event of the engine's own (a valve closing, piston slap)
that grows with the load, barely there at the lower point, is louder in a recording between the
points than at the lower one: judged against the nearer point alone it reads as a knock. Between two
points each bin's power is interpolated linearly in load
(:func:`monitor.diagnosis.impact_reference.between`); these tests build such profiles by hand and
check that the event is expected where it is and a knock elsewhere still heard.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from monitor.diagnosis import Baseline
from monitor.diagnosis.at_point import load_from_speed
from monitor.diagnosis.bearings import impact_score
from monitor.diagnosis.findings import IMPACT_WARNING, SIGNIFICANCE
from monitor.diagnosis.impact_reference import between, loudest, reference_profile
from monitor.diagnosis.operating_points import OperatingPoints
from monitor.signal.impact import HighFrequencyPower
from tests.diagnosis.hand_built import one_sensor_point

BINS = 1024  # over a four-stroke's cycle: 0.7 deg a bin
CYCLES = 300
SAMPLE_RATE = 25600.0
BAND = (1000.0, 10000.0)
EVENT_DEG = 390.0  # an engine event at a load reversal's knock window (20 deg before, 30 after)
QUIET_DEG = 600.0  # a reversal far from any event
LOADS = (0.5, 1.0)
BETWEEN = 0.75


def _event(load: float) -> float:
    """The event's power over the floor's: barely there at half load (0.5), 8 at full, linear between:
    at the lower point it is in the floor's class, which the load does not raise."""
    return 0.5 + 15.0 * (load - 0.5)


def _profile(load: float, *, knock_at_deg: float | None = None, bins: int = BINS) -> HighFrequencyPower:
    """A floor of 1 with the event over 8 deg (each bin's power spread 100 % over the cycles); a knock
    trebles the floor over 3 bins where given."""
    centre = (np.arange(bins) + 0.5) * 720.0 / bins
    mean = np.ones(bins)
    mean[np.abs(centre - EVENT_DEG) < 4.0] += _event(load)
    if knock_at_deg is not None:
        at = int(knock_at_deg / 720.0 * bins)
        mean[at - 1 : at + 2] += 2.0
    return HighFrequencyPower(mean, mean.copy(), CYCLES, SAMPLE_RATE, BAND, 750.0)


def _point(load: float) -> Baseline:
    """A point of one sensor whose only content is its high-frequency profile at that load."""
    return one_sensor_point(load, high_frequency=_profile(load), sample_rate=SAMPLE_RATE)


def _heard(recording: HighFrequencyPower, reference: HighFrequencyPower | None, at_deg: float) -> bool:
    """Whether a reversal's window would be reported (beyond the warning limit, significantly)."""
    matched = reference_profile(reference, recording, 2)
    s = impact_score(matched.profile, np.radians([at_deg]), 1, 2, matched.reference)
    return bool(s.score >= IMPACT_WARNING and s.significance >= max(SIGNIFICANCE, s.significance_needed))


def test_an_event_grown_with_the_load_is_expected_between_the_points_and_a_knock_is_still_heard() -> None:
    """At 0.75 the event is 5.25 x the floor, 1.5 x at the point of 0.5: against that point alone it is
    a knock; against the points interpolated it is the engine's own; a knock at a quiet reversal of the
    same recording is heard against either."""
    points = OperatingPoints.of([_point(load) for load in LOADS])
    reference = points.reference_at(BETWEEN).baseline.sensors["mb1"].high_frequency
    recording = _profile(BETWEEN)
    assert _heard(recording, _profile(LOADS[0]), EVENT_DEG)  # the nearer point alone
    assert not _heard(recording, reference, EVENT_DEG)
    knocked = _profile(BETWEEN, knock_at_deg=QUIET_DEG + 15.0)
    assert _heard(knocked, reference, QUIET_DEG)
    assert _heard(knocked, _profile(LOADS[0]), QUIET_DEG)


def test_between_is_each_point_at_its_own_load_and_the_line_between() -> None:
    """Weight 0 and 1 give the two profiles; 0.5 the mean of each bin's power and spread; the speed too."""
    low, high = _profile(0.5), _profile(1.0)
    high = HighFrequencyPower(high.mean, high.std, CYCLES - 100, SAMPLE_RATE, BAND, 790.0)
    np.testing.assert_allclose(between(low, high, 0.0).mean, low.mean)  # type: ignore[union-attr]
    np.testing.assert_allclose(between(low, high, 1.0).mean, high.mean)  # type: ignore[union-attr]
    half = between(low, high, 0.5)
    assert half is not None
    np.testing.assert_allclose(half.mean, 0.5 * (low.mean + high.mean))
    np.testing.assert_allclose(half.std, 0.5 * (low.std + high.std))
    assert half.speed_rpm == pytest.approx(770.0) and half.cycles == CYCLES - 100


def test_profiles_binned_apart_meet_on_the_coarser_bins_and_incomparable_ones_give_the_nearer() -> None:
    """A point binned at 1024 and one at 512 interpolate on 512 bins; another sampling rate or band, or
    a missing profile, leaves the nearer point's profile as it is."""
    fine, coarse = _profile(0.5), _profile(1.0, bins=512)
    half = between(fine, coarse, 0.5)
    assert half is not None and half.mean.size == 512
    np.testing.assert_allclose(half.mean, 0.5 * (fine.coarsened(512).mean + coarse.mean))
    other_rate = HighFrequencyPower(coarse.mean, coarse.std, CYCLES, 12800.0, BAND, 750.0)
    assert between(fine, other_rate, 0.3) is fine
    assert between(fine, other_rate, 0.7) is other_rate
    assert between(None, coarse, 0.3) is None
    assert between(None, coarse, 0.7) is coarse


def test_beyond_the_points_the_nearest_profile_is_kept() -> None:
    """Outside the calibrated loads nothing is extrapolated: the nearest point's profile, unchanged."""
    points = OperatingPoints.of([_point(load) for load in LOADS])
    below = points.reference_at(0.3).baseline.sensors["mb1"].high_frequency
    assert below is not None
    np.testing.assert_array_equal(below.mean, _profile(0.5).mean)


def test_a_load_known_within_a_span_is_judged_against_the_loudest_over_it() -> None:
    """Told 0.75 +- 0.1, the event is expected as loud as at 0.85 (the line's value there); told
    nothing, as loud as at the loudest calibrated point; a knock at a quiet reversal is heard either
    way, the loudest being the engine's own events only."""
    points = OperatingPoints.of([_point(load) for load in LOADS])
    at_event = int(EVENT_DEG / 720.0 * BINS)
    told = points.reference_at(BETWEEN, within=(0.65, 0.85)).baseline.sensors["mb1"].high_frequency
    assert told is not None
    assert told.mean[at_event] == pytest.approx(1.0 + _event(0.85))
    anywhere = points.reference_at(BETWEEN, within=LOADS).baseline.sensors["mb1"].high_frequency
    assert anywhere is not None
    assert anywhere.mean[at_event] == pytest.approx(1.0 + _event(1.0))
    assert points.reference_at(BETWEEN).baseline.sensors["mb1"].high_frequency.mean[at_event] == (  # type: ignore[union-attr]
        pytest.approx(1.0 + _event(BETWEEN))
    )
    knocked = _profile(BETWEEN, knock_at_deg=QUIET_DEG + 15.0)
    assert _heard(knocked, anywhere, QUIET_DEG)
    assert not _heard(_profile(1.0), anywhere, EVENT_DEG)


def test_the_loudest_keeps_the_first_profiles_bins_and_leaves_out_what_cannot_be_compared() -> None:
    """Bin by bin the largest, with that bin's spread; a finer profile is coarsened to the first's, a
    coarser one or one of another sampling rate is left out; no first profile, none."""
    quiet, loud = _profile(0.5), _profile(1.0)
    both = loudest([quiet, loud])
    assert both is not None
    np.testing.assert_array_equal(both.mean, np.maximum(quiet.mean, loud.mean))
    np.testing.assert_array_equal(both.std, np.where(loud.mean >= quiet.mean, loud.std, quiet.std))
    coarse_first = loudest([_profile(0.5, bins=512), loud])
    assert coarse_first is not None and coarse_first.mean.size == 512
    np.testing.assert_allclose(
        coarse_first.mean, np.maximum(_profile(0.5, bins=512).mean, loud.coarsened(512).mean)
    )
    assert loudest([quiet, _profile(1.0, bins=512)]) is quiet
    other_rate = HighFrequencyPower(loud.mean, loud.std, CYCLES, 12800.0, BAND, 750.0)
    assert loudest([quiet, other_rate, None]) is quiet
    assert loudest([None, loud]) is None


def test_points_on_a_propeller_curve_give_the_load_at_the_recordings_speed() -> None:
    """Points whose speeds rise with the load (100, 154, 166 rpm at 0.41, 0.91, 1.05) read 0.82 at
    145.8 rpm, linearly between the two around it, and the end point's load beyond them; points at
    one speed, or one point, tell nothing."""
    propeller = OperatingPoints.of(
        [replace(_point(load), speed_rpm=rpm) for load, rpm in ((0.41, 100.0), (0.91, 154.0), (1.05, 166.0))]
    )
    assert load_from_speed(145.8, propeller) == pytest.approx(0.41 + 0.5 * 45.8 / 54.0)
    assert load_from_speed(170.0, propeller) == pytest.approx(1.05)
    assert load_from_speed(90.0, propeller) == pytest.approx(0.41)
    generator = OperatingPoints.of([_point(load) for load in LOADS])  # both at 750 rpm
    assert load_from_speed(700.0, generator) is None
    assert load_from_speed(145.8, OperatingPoints.of([_point(0.5)])) is None
    # speeds within the bearings' 5 % of each other are one speed, whatever the load
    near = OperatingPoints.of([replace(_point(0.5), speed_rpm=750.0), replace(_point(1.0), speed_rpm=780.0)])
    assert load_from_speed(770.0, near) is None
