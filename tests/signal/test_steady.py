"""Steady segments: the per-cycle series from an angle map, and the segment finder on seeded series.

The finder's claims (monitor/signal/steady.py): a step well above the series' noise and above the
step the diagnosis tells apart is found within a few cycles of where it is; a steady noisy series is
split at most at the rate ``ALPHA`` the threshold is set for; a ramp is no steady segment; a glitch
does not cut a steady run in two.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from monitor.signal.anglemap import AngleMap
from monitor.signal.steady import (
    ALPHA,
    GUARD,
    LOAD_STEP,
    MIN_CYCLES,
    SPEED_STEP,
    CycleSeries,
    cycle_series,
    noise_of,
    steady_segments,
)

OMEGA = 78.54  # rad/s, 750 rpm
LEVEL = 0.2  # rad/s, a load indicator's level


def _series(speed: np.ndarray, load: np.ndarray | None) -> CycleSeries:
    period = 4 * math.pi / OMEGA
    start = np.arange(speed.size) * period
    return CycleSeries(start, start + period, speed, load)


def _steady(
    rng: np.random.Generator, n: int, speed_noise: float, load_noise: float
) -> tuple[np.ndarray, np.ndarray]:
    speed = OMEGA * (1 + speed_noise * rng.standard_normal(n))
    load = LEVEL * (1 + load_noise * rng.standard_normal(n))
    return speed, load


@pytest.mark.parametrize(
    ("what", "size", "noise"),
    [
        # (the series stepped, the step relative to its level, its noise relative to its level)
        ("load", -0.5, 0.10),  # a load step from full to half, the indicator's noise as simulated
        ("load", -0.3, 0.10),
        ("load", 0.2, 0.03),
        ("load", 2.0, 0.30),  # a large step against a noisy indicator
        ("speed", 0.05, 0.001),  # a manoeuvre: 5 % in speed
        ("speed", -0.03, 0.0005),
    ],
)
def test_a_step_is_found_within_a_few_cycles_of_where_it_is(what: str, size: float, noise: float) -> None:
    """Twenty seeded cases each: two segments, the step inside the transition between them or within
    two cycles of it (the guard cycle and one cycle of a boundary moved by the noise)."""
    for seed in range(20):
        rng = np.random.default_rng([seed, 7])
        n = 100
        at = int(rng.integers(35, 65))
        speed, load = _steady(rng, n, noise if what == "speed" else 1e-4, noise if what == "load" else 0.1)
        (load if what == "load" else speed)[at:] *= 1 + size
        found = steady_segments(_series(speed, load))
        assert len(found.segments) == 2, (seed, found.segments)
        (transition,) = found.transitions
        assert transition.before.stop - GUARD - 2 <= at <= transition.after.first + GUARD + 2
        assert found.segments[0].first == 0 and found.segments[1].stop == n


@pytest.mark.parametrize(("what", "size"), [("load", 0.5 * LOAD_STEP), ("speed", 0.5 * SPEED_STEP)])
def test_a_step_smaller_than_the_diagnosis_tells_apart_does_not_split(what: str, size: float) -> None:
    """Half the step that matters, against almost no noise (highly significant): one segment."""
    rng = np.random.default_rng(3)
    speed, load = _steady(rng, 100, 1e-5, 1e-4)
    (load if what == "load" else speed)[50:] *= 1 + size
    assert len(steady_segments(_series(speed, load)).segments) == 1


def test_a_steady_noisy_series_is_split_at_most_at_the_rate_the_threshold_is_set_for() -> None:
    """400 seeded steady series of 100 cycles, the load indicator's noise at 30 % of its level (the
    step floor of 10 % then never guards against a split: two halves' means differ by more than it
    by chance): the false splits measured stay within the binomial 99.9 % bound of ``ALPHA``."""
    cases = 400
    splits = 0
    for seed in range(cases):
        rng = np.random.default_rng([seed, 11])
        speed, load = _steady(rng, 100, 1e-3, 0.30)
        splits += len(steady_segments(_series(speed, load)).segments) != 1
    bound = cases * ALPHA + 3.1 * math.sqrt(cases * ALPHA * (1 - ALPHA))
    assert splits <= bound, f"{splits} false splits in {cases} steady series (bound {bound:.1f})"


def test_the_threshold_is_what_keeps_steady_series_whole() -> None:
    """The same series with the test's threshold replaced by a fixed 2 (no correction for the many
    places) splits often: the correction, not the floor, is what the previous test measures."""
    import monitor.signal.steady as steady

    original = steady._threshold
    try:
        steady._threshold = lambda n, series: 2.0  # type: ignore[assignment]
        splits = 0
        for seed in range(100):
            rng = np.random.default_rng([seed, 11])
            speed, load = _steady(rng, 100, 1e-3, 0.30)
            splits += len(steady_segments(_series(speed, load)).segments) != 1
    finally:
        steady._threshold = original  # type: ignore[assignment]
    assert splits > 10


def test_a_ramp_has_no_steady_segment_and_a_glitch_does_not_cut_a_run() -> None:
    rng = np.random.default_rng(5)
    n = 200
    ramp = OMEGA * np.linspace(1.0, 1.5, n) * (1 + 1e-3 * rng.standard_normal(n))  # a run-up: 50 %
    assert steady_segments(_series(ramp, None)).segments == ()
    speed, load = _steady(rng, n, 1e-3, 0.05)
    load[90] *= 3.0  # one odd cycle
    found = steady_segments(_series(speed, load))
    assert len(found.segments) == 1 and found.segments[0].cycles >= n - 2


@pytest.mark.parametrize(
    ("rise", "segments"),
    [(1.4 * SPEED_STEP, 0), (0.5 * SPEED_STEP, 1)],  # over MIN_CYCLES: a ramp; a drift within a step
    ids=["ramp", "drift"],
)
def test_a_short_span_of_a_ramp_is_no_segment_though_it_rises_by_less_than_a_step(
    rise: float, segments: int
) -> None:
    """The last 14 cycles of a run-up (rising by ``rise`` every MIN_CYCLES cycles) with segments of 12
    asked for, their drift judged over MIN_CYCLES: the ramp's span rises by ``0.65 rise``, less than a
    step, yet it is a ramp. Judged over its own cycles (the default) either is a segment."""
    rng = np.random.default_rng(11)
    n = 14
    speed = OMEGA * (1 + rise * np.arange(n) / MIN_CYCLES) * (1 + 1e-4 * rng.standard_normal(n))
    assert (speed[-1] - speed[0]) / speed[0] < SPEED_STEP
    series = _series(speed, None)
    assert len(steady_segments(series, min_cycles=12, drift_over=MIN_CYCLES).segments) == segments
    assert len(steady_segments(series, min_cycles=12).segments) == 1


def test_segments_need_their_minimum_of_cycles() -> None:
    rng = np.random.default_rng(9)
    speed, load = _steady(rng, 2 * MIN_CYCLES, 1e-4, 0.02)
    load[MIN_CYCLES - 5 :] *= 0.5  # the first part shorter than a segment
    found = steady_segments(_series(speed, load))
    assert len(found.segments) == 1 and found.segments[0].first > MIN_CYCLES - 5


def test_the_noise_of_a_stepped_series_is_the_noise_alone() -> None:
    rng = np.random.default_rng(2)
    x = 0.01 * rng.standard_normal(2000)
    x[1000:] += 5.0
    assert noise_of(x) == pytest.approx(0.01, rel=0.08)  # 2000 differences: a few per cent of spread


def test_the_cycle_series_reads_an_analytic_angle_map() -> None:
    """A crank at a mean speed that steps by 2 % at cycle 30, with a fluctuation at the firing harmonic
    whose size steps too: ``t(theta) = theta / Omega + d sin(h theta / R)`` (zero over each cycle), so
    each cycle lasts exactly ``2 pi R / Omega`` and the speed's harmonic ``h`` is ``Omega^2 d h / R``
    to first order in ``Omega d h / R`` (0.5 % here): within 3 % with the angle steps' sinc (1.5 %)."""
    R, h, pulses = 2, 6, 60
    omegas, ds = (OMEGA, 1.02 * OMEGA), (1e-4, 0.5e-4)
    angles, times, t0 = [], [], 0.0
    per_cycle = pulses * R
    for cycle in range(60):
        part = 0 if cycle < 30 else 1
        theta = (cycle * per_cycle + np.arange(per_cycle)) * (2 * math.pi / pulses)
        local = theta - theta[0]
        times.append(t0 + local / omegas[part] + ds[part] * np.sin(h * theta / R))
        angles.append(theta)
        t0 += 2 * math.pi * R / omegas[part]
    series = cycle_series(
        AngleMap(np.concatenate(times), np.concatenate(angles)),
        cycle_revolutions=R,
        firing_harmonic=h,
        pulses_per_revolution=pulses,
    )
    assert series.cycles == 59
    np.testing.assert_allclose(series.speed[:29], OMEGA, rtol=1e-9)
    np.testing.assert_allclose(series.speed[30:], 1.02 * OMEGA, rtol=1e-9)
    assert series.load is not None
    for part, cycles in ((0, slice(0, 29)), (1, slice(30, 59))):
        expected = omegas[part] ** 2 * ds[part] * h / R
        np.testing.assert_allclose(series.load[cycles], expected, rtol=0.03)
    found = steady_segments(series)
    assert [len(found.segments), len(found.transitions)] == [2, 1]
    assert found.transitions[0].start_s < 30 * 4 * math.pi / OMEGA < found.transitions[0].stop_s


def test_a_keyphasor_alone_gives_the_speed_and_no_load_indicator() -> None:
    times = np.arange(40) * (2 * math.pi / OMEGA)
    series = cycle_series(
        AngleMap.from_keyphasor(times), cycle_revolutions=1, firing_harmonic=6, pulses_per_revolution=1
    )
    assert series.load is None
    np.testing.assert_allclose(series.speed, OMEGA, rtol=1e-9)


# (id, relative speed step, relative load-indicator step, cycles before and after, segments expected)
LIMITS: list[tuple[str, float, float, int, int]] = [
    ("speed 1.9 %: not split (the whole run drifts: diagnosed whole)", 0.019, 0.0, 40, 0),
    ("speed 2.1 %: two points", 0.021, 0.0, 40, 2),
    ("load indicator 9 %: not split (diagnosed whole)", 0.0, 0.09, 40, 0),
    ("load indicator 11 %: two points", 0.0, 0.11, 40, 2),
    ("20 cycles on each side of a step (and its guard): two segments", 0.05, 0.0, 21, 2),
    ("19 cycles on each side of a step: no segment long enough", 0.05, 0.0, 20, 0),
]


@pytest.mark.parametrize(
    ("speed_step", "load_step", "each", "expected"),
    [row[1:] for row in LIMITS],
    ids=[row[0] for row in LIMITS],
)
def test_the_finder_on_its_limits(speed_step: float, load_step: float, each: int, expected: int) -> None:
    """Noise-free series (the noise floor is round-off): a speed step of 2 % and a load-indicator step of
    10 % are the least that make two points (a smaller one is no split, and the run, not steady either,
    is diagnosed whole), and a segment needs 20 cycles besides the one-cycle guard either side."""
    up = np.r_[np.zeros(each), np.ones(each)]
    found = steady_segments(_series(OMEGA * (1 + speed_step * up), LEVEL * (1 + load_step * up)))
    assert len(found.segments) == expected


def test_the_limits_are_those_documented() -> None:
    """docs/diagnosis.md, "Recordings that cross operating points": a false split at most 1 % of the
    time, one guard cycle each side of a change, steps of 2 % in speed and 10 % in load, 20 cycles."""
    assert (ALPHA, GUARD, SPEED_STEP, LOAD_STEP, MIN_CYCLES) == (0.01, 1, 0.02, 0.10, 20)


def test_a_short_recording_with_a_step_near_its_end_is_not_at_one_point(rng: np.random.Generator) -> None:
    """Fourteen cycles (a slow two-stroke's 10 s), the load indicator up by half and the speed
    falling over the last three: too short for segments of MIN_CYCLES, but with three cycles a side
    the steady span does not reach the end, so the recording is not at one point; the same fourteen
    cycles held steady are one segment from the first cycle to the last."""
    speed, load = _steady(rng, 14, 0.001, 0.03)
    assert steady_segments(_series(speed, load), min_cycles=3).at_one_point
    speed[11:] *= np.array([0.985, 0.95, 0.92])
    load[11:] *= 1.5
    short = steady_segments(_series(speed, load), min_cycles=3)
    assert not short.at_one_point and short.cycles == 14
    assert len(short.segments) >= 1 and short.segments[0].stop < 14
    assert steady_segments(_series(speed, load)).segments == ()


@pytest.mark.parametrize("seed", range(10))
def test_a_held_speeds_dip_and_recovery_is_a_transition_between_two_segments(seed: int) -> None:
    """A generator's governor after a load step: the speed falls 11 %, overshoots 6 % and settles within
    16 cycles, back at the speed it held, the load indicator unchanged (on many cylinders the inertia
    torque dominates the firing harmonic): the same mean either side, which the split test cannot
    tell, so the cycles 2 % or more off the median are cut out and the two sides are two segments,
    the dip between them; a dip of 1.5 % leaves the run whole."""
    rng = np.random.default_rng(seed)
    speed, load = _steady(rng, 150, 0.002, 0.03)
    dip = np.array([0.97, 0.91, 0.89, 0.905, 0.94, 0.98, 1.015, 1.04, 1.055, 1.06, 1.055, 1.045, 1.035,
                    1.025, 1.0, 0.99])  # fmt: skip
    stepped = speed.copy()
    stepped[70 : 70 + dip.size] *= dip
    found = steady_segments(_series(stepped, load))
    assert len(found.segments) == 2, found.segments
    first, second = found.segments
    assert 60 <= first.stop <= 70 and 70 + dip.size - 6 <= second.first <= 70 + dip.size + 4
    (transition,) = found.transitions
    assert transition.before == first and transition.after == second
    shallow = speed.copy()
    shallow[70:75] *= 0.985
    assert steady_segments(_series(shallow, load)).at_one_point
