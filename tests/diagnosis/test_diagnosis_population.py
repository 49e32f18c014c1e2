"""A seeded random sample of the validation population (docs/diagnosis-validation.md), in the suite.

Each case is an engine the product was not built with, from the validation simulator
(:mod:`validation.simulator`: its own gas model, structure, sensors and noise, and an engine file
that differs from the simulated engine as real ones do), diagnosed the way ``make bench-diagnosis``
does (:func:`benchmarks.diagnosis_validation.run_case`): calibrated on a healthy recording of the
same engine, told a load up to 10 % off. The whole population's rates are in
docs/diagnosis-validation.md; the sample is held to its acceptance table, with the tolerance its
size needs. A few cases that each once exposed a bug are kept by name below it. A second sample
runs off the baseline's operating point (another load or speed, a load step, crank speed alone),
each case diagnosed told its load and not, held to what the product meets there.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import binom

from benchmarks.diagnosis_operating import judged
from benchmarks.diagnosis_validation import (
    OFF_POINT_FIRST_SEED,
    Outcome,
    case_length,
    off_point_length,
    run_case,
    run_ways,
)
from benchmarks.judging import named, vibrating

# The draw: SAMPLE_SIZE distinct seeds, uniform over [FIRST_SEED, END_SEED), from
# numpy.random.default_rng(DRAW_SEED); each case as long as the benchmark makes it (case_length:
# 10, 30 or 60 s by the seed modulo 3, as `--first-seed 0 --cases N` would run it), so the classes,
# engines and lengths come out in the benchmark's proportions.
# - Disjoint from the benchmark's seeds (0 to 539 for `--cases 540`): those are the cases the rules
#   and their thresholds were measured and adjusted on, and make bench-diagnosis runs each of them;
#   fresh seeds from the same generator are the same population, so the documented rates hold for
#   them, without being cases anyone has looked at.
# - Below 100,000: the simulator dates a case's recording its seed (modulo 500,000) minutes after
#   2026-01-01, and the product refuses a recording dated more than a day past the machine's clock
#   (seed 485979 is dated 2026-12-04 and cannot be read on 2026-11-27). Seeds below 100,000 are
#   dated by 2026-03-11; their healthy twins (seed + 1,000,000) are none of the cases.
# - 36 cases cost about 65 s of CPU (1 to 6 s each, the 60 s ones the most).
# The draw holds 2 healthy cases, 8 misfires, 8 weak cylinders (5 in the acceptance table's weak row:
# 30 s or longer, at or below 70 %, 2 or more cylinders), 8 worn bearings and 10 sensor faults.
DRAW_SEED = 20261127
FIRST_SEED, END_SEED = 540, 100_000
SAMPLE_SIZE = 36

# A named rate is held to a one-sided binomial bound at the rate docs/diagnosis-validation.md
# requires: the least count of hits a population meeting it gives all but ALPHA of its samples of
# that size, binom.ppf(ALPHA, n, rate). Three rates at 1 % each: a population that meets all of them
# fails this test with a probability under 3 %. Too few cases to see a drift of a few per cent: that
# is the whole benchmark's to measure; this catches a rule that breaks.
ALPHA = 0.01


def draw() -> list[tuple[int, float]]:
    """The sample's cases: (seed, length [s]), by seed."""
    rng = np.random.default_rng(DRAW_SEED)
    seeds = FIRST_SEED + rng.choice(END_SEED - FIRST_SEED, size=SAMPLE_SIZE, replace=False)
    return [(int(seed), case_length(int(seed))) for seed in sorted(seeds)]


@pytest.fixture(scope="module")
def sample() -> list[Outcome]:
    """Every case of the draw, diagnosed (one process: about 60 s of CPU)."""
    return [run_case(seed, length) for seed, length in draw()]


def least_hits(cases: int, rate: float) -> int:
    """The fewest hits of ``cases`` that a population with ``rate`` gives with probability 1 - ALPHA."""
    return int(binom.ppf(ALPHA, cases, rate))


def test_every_case_is_diagnosed(sample: list[Outcome]) -> None:
    failed = [o for o in sample if o.error or o.status == "error"]
    assert not failed, failed


def test_a_worn_bearing_s_impact_scores_are_kept_for_the_record(sample: list[Outcome]) -> None:
    """The true bearing's most significant impact score is recorded (for studying the rule), and a
    named worn bearing's is at least the 4 standard errors its finding needed."""
    worn = [o for o in sample if o.truth == "worn_bearing"]
    assert worn
    for o in worn:
        score, significance, needed, _ = o.impact_true
        assert math.isfinite(score) and math.isfinite(needed), o
        assert not o.named or significance >= 4.0, o


def test_a_healthy_case_raises_no_alarm(sample: list[Outcome]) -> None:
    healthy = [o for o in sample if o.truth == "healthy"]
    assert healthy  # the draw holds 2
    assert not [o for o in healthy if o.alarm], healthy  # required: none


def test_a_misfire_is_named_and_never_called_healthy(sample: list[Outcome]) -> None:
    misfires = [o for o in sample if o.truth == "misfire"]
    assert misfires  # the draw holds 8
    # required 100 % (measured 112/112): every one named on its cylinder, none exits 0
    assert not [o for o in misfires if o.exit_code == 0], misfires
    assert all(o.named for o in misfires), [o for o in misfires if not o.named]


def test_the_named_rates_hold_to_the_acceptance_table(sample: list[Outcome]) -> None:
    # the acceptance table's rows, each with its cases in the draw and the rate it requires
    healthy = [o for o in sample if o.truth == "healthy"]
    weak = [
        o
        for o in sample
        if o.truth == "weak" and o.duration_s >= 30.0 and o.strength <= 0.70 and o.cylinders > 1
    ]
    worn = [o for o in sample if o.truth == "worn_bearing"]
    rows = {
        # name: (hits, cases, required rate); this draw's cases and least hits in the comment
        # 2 cases, at least 1 (seed 79353, 12 cylinders at 923 rpm, 10 s, is inconclusive today: its
        # crank-speed orders do not resolve the cylinders; the benchmark measured 0 of 107)
        "healthy runs exit 0": (sum(o.exit_code == 0 for o in healthy), len(healthy), 0.98),
        # 5 cases, at least 3
        "weak cylinder named": (sum(o.named for o in weak), len(weak), 0.95),
        # 8 cases, at least 6
        "worn bearing named": (sum(o.named for o in worn), len(worn), 0.95),
    }
    short = {
        name: (hits, cases, least_hits(cases, rate))
        for name, (hits, cases, rate) in rows.items()
        if hits < least_hits(cases, rate)
    }
    assert not short, (short, [o for o in sample if not o.named])


# Cases that each once exposed a bug, kept by name: seed, length [s], what the simulator put in, the
# exit code compare gives.
REGRESSIONS = [
    # 12-cylinder two-stroke at 59 rpm: its firing order leaked from the wheel's gap
    (246, 10.0, "misfire", 2),
    # 2-cylinder four-stroke: only the weaker of the two named
    (123, 10.0, "misfire", 2),
    # 4-cylinder four-stroke 5 % slower than its baseline (a propeller)
    (409, 30.0, "weak", 1),
    # 5-cylinder two-stroke at 56 rpm, 10.24 kHz: knocks in time, not angle
    (3, 10.0, "worn_bearing", 1),
    # 2-cylinder two-stroke, a 3.3 kHz ring at 25.6 kHz: the 1-10 kHz band
    (51, 10.0, "worn_bearing", 1),
]


@pytest.mark.parametrize(
    ("seed", "length", "truth", "exit_code"), REGRESSIONS, ids=[f"{c[2]}-seed{c[0]}" for c in REGRESSIONS]
)
def test_a_case_that_exposed_a_bug_is_named_on_the_right_subject(
    seed: int, length: float, truth: str, exit_code: int
) -> None:
    outcome = run_case(seed, length)
    assert outcome.truth == truth and not outcome.error, outcome
    assert outcome.named, outcome
    assert outcome.exit_code == exit_code, outcome


def test_a_healthy_two_stroke_on_its_propeller_curve_has_no_knock_between_its_points() -> None:
    """Case 200472: a healthy 9-cylinder two-stroke at 146 rpm on its propeller curve, its baseline
    calibrated at 154 rpm (and with three points, at the ends of its curve too, the reference's power
    taken from 100 to 166 rpm). A cylinder's exhaust opening and the next one's firing, 7 deg apart,
    ring an 860 Hz mode of main bearing 4's frame; at 146 rpm their rings add in phase, at 153 they
    cancel, and no reference between the points follows that: main bearing 4 was named, a warning
    told its load or not, against one point or three. Judged also on the part of the power that
    varies from cycle to cycle, it is healthy (told its load; each way takes about 20 s)."""
    outcomes = run_ways(200472, 10.0, "random", (True,), across_law=True)
    assert [(o.points, o.truth, o.exit_code) for o in outcomes] == [(1, "healthy", 0), (3, "healthy", 0)], (
        outcomes
    )


def test_a_worn_bearing_through_a_load_step_is_named_on_the_varying_part_too() -> None:
    """Case 200042: main bearing 4 of an engine at 120 rpm knocks through a load step, 10 s. Away from
    the reference's speed its knock span must stand out in the part of the power that varies from
    cycle to cycle as well: read with a linear interpolation between samples, which damps the band's
    top, its significance fell from 5.6 to 3.1 (4.7 needed) and it went unnamed; read at the nearest
    samples it is named, against one point and three (told its load)."""
    outcomes = run_ways(200042, 10.0, "random", (True,), across_law=True)
    assert [(o.points, o.truth, o.named) for o in outcomes] == [
        (1, "worn_bearing", True),
        (3, "worn_bearing", True),
    ]


# Off the baseline's point: OFF_POINT_SIZE distinct seeds, uniform over [OFF_POINT_FIRST, END_SEED),
# from numpy.random.default_rng(DRAW_SEED), each of the operating-point class the simulator draws
# for it ("random": the engine's own law, a load step or crank speed alone) and as long as the
# benchmark makes it (off_point_length: 10 or 30 s by the seed's parity), each diagnosed told its
# load and not. Past the benchmark's off-point seeds (200,000 to 200,539), below 300,000 (dated,
# like the first draw's, by the seed modulo 100,000 minutes after 2026-01-01). About 50 s of CPU.
# The draw holds 5 propeller-curve cases, 1 constant-speed, 10 load steps and 8 of crank speed
# alone; 9 misfires, 5 weak cylinders, 5 worn bearings, 2 sensor faults, 3 healthy runs.
# Only what the product met off its baseline's point when this was written is held here (a
# reduced benchmark, 360 cases off the point: healthy runs at a steady point without an alarm, 0 of
# 27 each way); the rest it did not meet (a misfire at a steady point called healthy, 1 of 24 told
# the load; false bearing findings on healthy engines at another speed; load steps inconclusive
# or misread) is measured by make bench-diagnosis, per class, and not held by the suite.
STEADY = ("propeller curve", "constant speed")
OFF_POINT_FIRST = OFF_POINT_FIRST_SEED + 540
OFF_POINT_END = OFF_POINT_FIRST_SEED + 100_000
OFF_POINT_SIZE = 24


def draw_off_point() -> list[tuple[int, float]]:
    """The off-point sample's cases: (seed, length [s]), by seed."""
    rng = np.random.default_rng(DRAW_SEED)
    seeds = OFF_POINT_FIRST + rng.choice(OFF_POINT_END - OFF_POINT_FIRST, size=OFF_POINT_SIZE, replace=False)
    return [(int(seed), off_point_length(int(seed))) for seed in sorted(seeds)]


@pytest.fixture(scope="module")
def off_point() -> list[Outcome]:
    """Every case of the off-point draw, diagnosed told its load and not (one process)."""
    return [o for seed, length in draw_off_point() for o in run_ways(seed, length, "random", (True, False))]


def test_every_off_point_case_is_simulated_and_diagnosed_or_refused_for_want_of_a_bearing_sensor(
    off_point: list[Outcome],
) -> None:
    assert {o.operating for o in off_point} == {*STEADY, "load step", "crank speed only"}
    assert not [o for o in off_point if o.failed_at == "simulator"]
    assert not [o for o in off_point if o.failed_at == "diagnosis"]
    # a calibration needs a bearing channel today: only an engine without one may be refused
    assert not [o for o in off_point if o.failed_at == "calibration" and o.operating != "crank speed only"]


def test_a_healthy_run_at_a_steady_point_off_the_baseline_raises_no_alarm(off_point: list[Outcome]) -> None:
    healthy = [o for o in judged(off_point) if o.truth == "healthy" and o.operating in STEADY]
    assert {o.load_told for o in healthy} == {True, False}  # the draw holds 1, diagnosed both ways
    assert not [o for o in healthy if o.alarm], healthy  # required: none


def test_a_healthy_case_whose_structure_vibrates_in_zone_c_or_d_is_judged_as_a_zone() -> None:
    """The benchmark's truth of a healthy case: its own vibration at 23 mm/s on one channel is zone D of
    the default limits (7.1/11/18 mm/s), so the case is of class vibration_zone on that channel, and a
    zone finding there names it; at 10.9 mm/s (zone B) the case stays healthy, as does a worn bearing
    whatever its vibration."""
    truth = {"class": "healthy", "channel": None, "velocity_mm_s": {"mb1": 4.1, "mb2": 23.4, "mb4": 12.0}}
    zoned = vibrating(truth)
    assert (zoned["class"], zoned["channel"]) == ("vibration_zone", "mb2")
    assert named(zoned, [("vibration_zone", "mb2", "alarm")])
    assert not named(zoned, [("vibration_zone", "mb4", "warning")])
    assert not named(zoned, [])
    quiet = {**truth, "velocity_mm_s": {"mb1": 4.1, "mb2": 10.9}}
    assert vibrating(quiet) is quiet
    # zone C alone (11 mm/s and above, below 18) is a zone too
    assert vibrating({**truth, "velocity_mm_s": {"mb1": 4.1, "mb2": 11.0}})["class"] == "vibration_zone"
    worn = {**truth, "class": "worn_bearing", "bearing": 2}
    assert vibrating(worn) is worn
