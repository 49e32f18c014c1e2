"""A seeded sample of the validation population (docs/diagnosis-validation.md), pinned in the suite.

Each case is an engine the product was not built with, from the validation simulator
(:mod:`validation.simulator`: its own gas model, structure, sensors and noise, and an engine file
that differs from the simulated engine as real ones do), diagnosed the way ``make bench-diagnosis``
does: calibrated on a healthy recording of the same engine, told a load up to 10 % off. The whole
population's rates are in docs/diagnosis-validation.md; these cases hold the rules to what they
name today.
"""

from __future__ import annotations

import pytest

from benchmarks.diagnosis_validation import run_case

CASES = [
    # seed, length [s], what the simulator put in, the exit code compare gives
    (4, 30.0, "healthy", 0),  # 4-cylinder two-stroke
    (19, 30.0, "healthy", 0),  # 6-cylinder four-stroke
    (37, 30.0, "healthy", 0),  # single-cylinder four-stroke: judged against its baseline
    (6, 10.0, "misfire", 2),  # 6-cylinder four-stroke
    (30, 10.0, "misfire", 2),  # 7-cylinder slow two-stroke
    (46, 30.0, "misfire", 2),  # 3-cylinder two-stroke
    (21, 10.0, "weak", 1),  # 8-cylinder four-stroke
    (9, 10.0, "sensor_fault", 1),  # 6-cylinder four-stroke
    (
        246,
        10.0,
        "misfire",
        2,
    ),  # 12-cylinder two-stroke at 59 rpm: its firing order leaked from the wheel's gap
    (123, 10.0, "misfire", 2),  # 2-cylinder four-stroke: only the weaker of the two named
    (409, 30.0, "weak", 1),  # 4-cylinder four-stroke 5 % slower than its baseline (a propeller)
    (3, 10.0, "worn_bearing", 1),  # 5-cylinder two-stroke at 56 rpm, 10.24 kHz: knocks in time, not angle
    (51, 10.0, "worn_bearing", 1),  # 2-cylinder two-stroke, a 3.3 kHz ring at 25.6 kHz: the 1-10 kHz band
]


@pytest.mark.parametrize(
    ("seed", "length", "truth", "exit_code"), CASES, ids=[f"{c[2]}-seed{c[0]}" for c in CASES]
)
def test_a_population_case_is_named_on_the_right_subject(
    seed: int, length: float, truth: str, exit_code: int
) -> None:
    outcome = run_case(seed, length)
    assert outcome.truth == truth and not outcome.error, outcome
    assert outcome.named, outcome
    assert outcome.exit_code == exit_code, outcome
