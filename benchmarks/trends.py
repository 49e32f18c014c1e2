"""The drift rule's false findings and delays, with its reference estimated as the product estimates it.

``python -m benchmarks.trends`` simulates nightly values of one quantity:
independent Gaussian values, the engine's first ten recordings its baseline
period, then nights in control, or shifted by 1, 2 or 3 sigmas from the first
night after the baseline. Each series goes through the product's
standardisation (:func:`monitor.diagnosis.trends.standardised`, the history's mean and
spread, values far from its median left out) and the CUSUM with the product's
K and H; a sample of series is checked against :func:`monitor.diagnosis.trends.drift`
itself. It writes between its markers in docs/trends.md: how often the rule
finds drift where there is none within a month, a quarter and a year of
nights, for one quantity and for an engine following 13 (a seven-cylinder
engine with two bearing sensors: 7 strengths and 3 quantities per sensor,
taken as independent), after how many nights a shift is found (median and 90th
percentile), and the same with faults among the baseline period's recordings
(one or two misfires, 30 sigmas low; one knock, 6 sigmas high) for the rule
and the other bands it could keep (none: the plain mean and spread).
"""

from __future__ import annotations

import argparse
import math
import platform
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np

from benchmarks.sections import replace_section
from monitor.diagnosis.trends import (
    BASELINE_RECORDINGS,
    DECISION,
    LAG,
    REFERENCE,
    ROBUST_SIGMAS,
    drift,
    standardised,
)
from monitor.types import FloatArray

DOC = Path(__file__).resolve().parents[1] / "docs" / "trends.md"
START, END = "<!-- trend-rule: start -->", "<!-- trend-rule: end -->"
QUANTITIES = 13  # judged quantities of a seven-cylinder engine with two bearing sensors
HORIZONS = (30, 90, 365)  # nights after the baseline period
MEAN = 10.0  # the simulated quantity's mean: its spread's floor (1 % of it) stays below its sigma of 1
BANDS = (math.inf, 8.0, 6.0, 5.0, 4.0)  # none (the rule before) and the candidates, in robust sigmas
FAULTS = (  # (label, sizes in sigmas) of the faults among the baseline period's recordings
    ("none", ()),
    ("one misfire", (-30.0,)),
    ("two misfires", (-30.0, -30.0)),
    ("one knock", (6.0,)),
)


def _nights(values: FloatArray, band: float) -> FloatArray:
    """The night (1 = the first after the baseline) each series (a row) is found drifting, inf if never."""
    u = standardised(values, robust_sigmas=band)[:, BASELINE_RECORDINGS:]
    high, low = np.zeros(u.shape[0]), np.zeros(u.shape[0])
    found = np.full(u.shape[0], np.inf)
    for night in range(u.shape[1]):
        high = np.maximum(0.0, high + u[:, night] - REFERENCE)
        low = np.maximum(0.0, low - u[:, night] - REFERENCE)
        found[((high > DECISION) | (low > DECISION)) & np.isinf(found)] = night + 1
    return found


def _checked(values: FloatArray, found: FloatArray, band: float, series: int = 20) -> None:
    """The nights of the first series as :func:`monitor.diagnosis.trends.drift` finds them, or an error."""
    times = [datetime(2026, 1, 1, tzinfo=UTC) + timedelta(days=n) for n in range(values.shape[1])]
    for row, night in zip(values[:series], found[:series], strict=True):
        finding = drift(times, row, robust_sigmas=band)
        expected = math.inf if finding is None else (finding.found_at - times[BASELINE_RECORDINGS]).days + 1
        if expected != night:
            raise AssertionError(f"band {band}: night {night} here, {expected} from drift()")


def _faulty(rng: np.random.Generator, clean: FloatArray, sizes: tuple[float, ...]) -> FloatArray:
    """The series with faults of ``sizes`` sigmas at distinct recordings of the baseline period."""
    values = clean.copy()
    for row in values:
        row[rng.choice(BASELINE_RECORDINGS, len(sizes), replace=False)] += sizes
    return values


def _band(band: float) -> str:
    if math.isinf(band):
        return "all (the plain mean and spread)"
    return f"within {band:g} robust sigmas" + (" (the rule)" if band == ROBUST_SIGMAS else "")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--series", type=int, default=2000, help="simulated series per case")
    args = parser.parse_args()
    rng = np.random.default_rng(2026)
    quiet = MEAN + rng.standard_normal((args.series, BASELINE_RECORDINGS + max(HORIZONS)))
    shifted = {
        shift: MEAN
        + rng.standard_normal((args.series // 4, BASELINE_RECORDINGS + 120))
        + shift * (np.arange(BASELINE_RECORDINGS + 120) >= BASELINE_RECORDINGS)
        for shift in (1.0, 2.0, 3.0)
    }
    found = _nights(quiet, ROBUST_SIGMAS)
    _checked(quiet, found, ROBUST_SIGMAS)
    rows = []
    for horizon in HORIZONS:
        one = float(np.mean(found <= horizon))
        error = (one * (1 - one) / args.series) ** 0.5
        engine = 1.0 - (1.0 - one) ** QUANTITIES
        rows.append(f"| {horizon} | {100 * one:.1f} % +- {100 * error:.1f} | {100 * engine:.0f} % |")
    delays = []
    for shift, values in shifted.items():
        late = _nights(values, ROBUST_SIGMAS)
        seen = late[np.isfinite(late)]
        delays.append(
            f"| {shift:g} | {np.median(seen):.0f} | {np.percentile(seen, 90):.0f} | "
            f"{late.size - seen.size} of {late.size} |"
        )
    faulty = [
        (label, _faulty(rng, quiet, sizes), _faulty(rng, shifted[2.0], sizes)) for label, sizes in FAULTS
    ]
    robust = []
    for band in BANDS:
        for label, quiet_values, shifted_values in faulty:
            false = float(np.mean(_nights(quiet_values, band) <= max(HORIZONS)))
            late = _nights(shifted_values, band)
            seen = late[np.isfinite(late)]
            median = f"{np.median(seen):.0f}" if seen.size else "-"
            robust.append(
                f"| {_band(band)} | {label} | {100 * false:.1f} % | {median} | {late.size - seen.size} of "
                f"{late.size} |"
            )
        _checked(faulty[1][1], _nights(faulty[1][1][:20], band), band)
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    section = "\n".join(
        [
            START,
            "## The rule's false findings and delays, measured",
            "",
            f"Written by `python -m benchmarks.trends --series {args.series}` on {stamp}, Python "
            f"{platform.python_version()}. Do not edit by hand. Simulated nightly values of one quantity, "
            f"independent and Gaussian, standardised as the product does it (the history up to {LAG} "
            f"recordings back, at least the baseline period's {BASELINE_RECORDINGS}; values beyond "
            f"{ROBUST_SIGMAS:g} robust sigmas of its median left out; K = {REFERENCE:g}, H = {DECISION:g} "
            f"sigmas). {args.series} series in control; an engine is taken to follow {QUANTITIES} "
            "independent quantities (7 cylinder strengths, and the order deviation, impact score and rms "
            "velocity of 2 bearing sensors).",
            "",
            "| nights after the baseline period | a false finding on one quantity | on an engine of 13 |",
            "|---|---|---|",
            *rows,
            "",
            f"A shift from the first night after the baseline period ({args.series // 4} series each, "
            "120 nights):",
            "",
            "| shift [sigma] | nights to the finding, median | 90th percentile | not found in 120 nights |",
            "|---|---|---|---|",
            *delays,
            "",
            "Faults among the baseline period's recordings: a misfire (a value 30 sigmas low: a misfiring "
            "cylinder's strength, 0 against 1.00 +- 0.01 to 0.03, is 30 to 100) or a knock (6 sigmas high) "
            "at a recording of the first 10 drawn at random, added to the same series as above. A false "
            f"finding within {max(HORIZONS)} nights in control ({args.series} series), and the nights to "
            f"the finding of a shift of 2 sigmas ({args.series // 4} series, 120 nights), for each band "
            "of the history the estimates keep:",
            "",
            f"| values kept | faults | a false finding in {max(HORIZONS)} nights | 2 sigmas found after, "
            "median nights | not found in 120 nights |",
            "|---|---|---|---|---|",
            *robust,
            END,
        ]
    )
    replace_section(DOC, START, END, section)
    print(f"wrote {DOC.name}")


if __name__ == "__main__":
    main()
