"""A seeded random sample of the validation population (docs/diagnosis-validation.md), in the suite.

Each case is an engine the product was not built with, from the validation simulator
(:mod:`validation.simulator`: its own gas model, structure, sensors and noise, and an engine file
that differs from the simulated engine as real ones do), diagnosed the way ``make bench-diagnosis``
does (:func:`benchmarks.diagnosis_validation.run_case`): calibrated on a healthy recording of the
same engine, told a load up to 10 % off. The whole population's rates are in
docs/diagnosis-validation.md; the sample is held to its acceptance table, with the tolerance its
size needs. A few cases that each once exposed a bug are kept by name below it.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import binom

from benchmarks.diagnosis_validation import Outcome, case_length, run_case

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
