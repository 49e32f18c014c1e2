"""The drift rule's false findings and delays, with its baseline estimated as the product estimates it.

``python -m benchmarks.trends`` simulates nightly values of one quantity:
independent Gaussian values, the engine's first ten recordings its baseline
period (their mean and spread estimated from them, as :func:`monitor.trends.drift`
does), then nights in control, or shifted by 1, 2 or 3 sigmas from the first
night after the baseline. It writes the table between its markers in
docs/trends.md: how often the rule finds drift where there is none within a
month, a quarter and a year of nights, for one quantity and for an engine
following 13 (a seven-cylinder engine with two bearing sensors: 7 strengths and
3 quantities per sensor, taken as independent), and after how many nights a
shift is found (median and 90th percentile).
"""

from __future__ import annotations

import argparse
import platform
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np

from benchmarks.sections import replace_section
from monitor.trends import BASELINE_RECORDINGS, DECISION, REFERENCE, drift

DOC = Path(__file__).resolve().parents[1] / "docs" / "trends.md"
START, END = "<!-- trend-rule: start -->", "<!-- trend-rule: end -->"
QUANTITIES = 13  # judged quantities of a seven-cylinder engine with two bearing sensors
HORIZONS = (30, 90, 365)  # nights after the baseline period


def _first_finding(rng: np.random.Generator, nights: int, shift: float) -> int | None:
    """The night (1 = the first after the baseline) a simulated series is found drifting, or None."""
    times = [
        datetime(2026, 1, 1, tzinfo=UTC) + timedelta(days=n) for n in range(BASELINE_RECORDINGS + nights)
    ]
    values = np.r_[rng.standard_normal(BASELINE_RECORDINGS), shift + rng.standard_normal(nights)]
    found = drift(times, 10.0 + values)  # a mean of 10: the spread's floor (1 % of it) stays below sigma
    return None if found is None else (found.found_at - times[BASELINE_RECORDINGS]).days + 1


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--series", type=int, default=2000, help="simulated series per case")
    args = parser.parse_args()
    rng = np.random.default_rng(2026)
    nights = [_first_finding(rng, max(HORIZONS), 0.0) for _ in range(args.series)]
    found = np.array([n if n is not None else np.inf for n in nights], dtype=float)
    rows = []
    for horizon in HORIZONS:
        one = float(np.mean(found <= horizon))
        error = (one * (1 - one) / args.series) ** 0.5
        engine = 1.0 - (1.0 - one) ** QUANTITIES
        rows.append(f"| {horizon} | {100 * one:.1f} % +- {100 * error:.1f} | {100 * engine:.0f} % |")
    delays = []
    for shift in (1.0, 2.0, 3.0):
        late = [_first_finding(rng, 120, shift) for _ in range(args.series // 4)]
        seen = np.array([n for n in late if n is not None], dtype=float)
        missed = len(late) - seen.size
        delays.append(
            f"| {shift:g} | {np.median(seen):.0f} | {np.percentile(seen, 90):.0f} | {missed} of {len(late)} |"
        )
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    section = "\n".join(
        [
            START,
            "## The rule's false findings and delays, measured",
            "",
            f"Written by `python -m benchmarks.trends --series {args.series}` on {stamp}, Python "
            f"{platform.python_version()}. Do not edit by hand. Simulated nightly values of one quantity, "
            f"independent and Gaussian; the baseline period's {BASELINE_RECORDINGS} recordings give the "
            f"mean and spread as the product estimates them (K = {REFERENCE:g}, H = {DECISION:g} sigmas). "
            f"{args.series} series in control; an engine is taken to follow {QUANTITIES} independent "
            "quantities (7 cylinder strengths, and the order deviation, impact score and rms velocity of 2 "
            "bearing sensors).",
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
            END,
        ]
    )
    replace_section(DOC, START, END, section)
    print(f"wrote {DOC.name}")


if __name__ == "__main__":
    main()
