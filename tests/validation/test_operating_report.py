"""The off-point report: the healthy runs it left inconclusive with the product's reason, the rows that
count a single cylinder not told its load, and the worn bearings by the knocks their recordings hold."""

from __future__ import annotations

import math
from dataclasses import replace

from benchmarks.diagnosis_operating import (
    ROWS,
    cell,
    impact_limit_table,
    knock_table,
    missed_table,
    unjudged_table,
)
from benchmarks.diagnosis_validation import Outcome


def _healthy(
    seed: int, status: str, *, why: str = "", operating: str = "load step", points: int = 3
) -> Outcome:
    exit_code = {"healthy": 0, "warning": 1, "inconclusive": 3}[status]
    findings = "worn_bearing 2 (warning)" if status == "warning" else ""
    return Outcome(
        seed, 10.0, 1, "four-stroke", 1500.0, "healthy", "", math.nan, status, exit_code, status,
        status != "warning", False, findings, 1.0,
        inconclusive=why, operating=operating, load_told=False, points=points,
    )  # fmt: skip


def test_only_healthy_runs_off_the_point_left_inconclusive_are_listed_with_their_reason() -> None:
    outcomes = [
        _healthy(200059, "inconclusive", why="a single cylinder's weaker firing and a lower load read alike"),
        _healthy(200001, "healthy"),
        _healthy(200002, "warning"),  # a false finding: the list of cases not named holds it
        _healthy(3, "inconclusive", why="too few cycles", operating="baseline point"),
    ]
    lines = unjudged_table(outcomes)
    assert lines[0] == "### Healthy runs off the baseline's point left inconclusive (1 diagnoses)"
    rows = lines[lines.index("|---|---|---|---|---|---|---|") + 1 :]
    assert rows == [
        "| 200059 | 10 | load step | 1 | no | 3 | "
        "a single cylinder's weaker firing and a lower load read alike |"
    ]


def test_a_single_cylinder_left_inconclusive_without_its_load_misses_only_the_row_that_counts_it() -> None:
    # two healthy runs not told their load: a single cylinder left inconclusive, a six-cylinder healthy
    alone = _healthy(
        200059, "inconclusive", why="a single cylinder's weaker firing and a lower load read alike"
    )
    six = replace(_healthy(200001, "healthy"), cylinders=6)
    by_row = {row.what: row for row in ROWS}
    assert cell(by_row["healthy runs exit 0"], [alone, six]) == "1/2 (50.0 %): **fails**"
    assert cell(by_row["healthy runs exit 0, 2 or more cylinders"], [alone, six]) == "1/1 (100.0 %): meets"
    findings = by_row["healthy single-cylinder runs with a finding (exit 1 or 2)"]
    assert cell(findings, [alone, six]) == "0 of 1: meets"
    assert cell(findings, [_healthy(200002, "warning")]) == "1 of 1: **fails**"
    alarmed = replace(_healthy(200003, "warning"), status="alarm", exit_code=2, alarm=True)
    assert cell(findings, [alarmed]) == "1 of 1: **fails**"


def _worn(seed: int, knocks: int, size: float, named: bool) -> Outcome:
    return Outcome(
        seed, 10.0, 6, "two-stroke", 80.0, "worn_bearing", "5", math.nan,
        "warning" if named else "healthy", 1 if named else 0, "worn_bearing" if named else "healthy",
        named, False, "worn_bearing 5 (warning)" if named else "", 1.0,
        operating="load step", knocks=knocks, knock_size=size,
    )  # fmt: skip


def test_worn_bearings_are_counted_by_the_knocks_their_recordings_hold() -> None:
    outcomes = [_worn(1, 4, 4.46, False), _worn(2, 13, 3.4, False), _worn(3, 19, 5.0, True)]
    outcomes += [_worn(4, 20, 3.0, True), _worn(5, 49, 6.0, True), _worn(6, 50, 4.0, True)]
    outcomes.append(_healthy(7, "healthy"))  # not a worn bearing: not counted
    rows = knock_table(outcomes)[-3:]
    assert rows == [
        "| 0 to 19 | 3 | 1/3 (33.3 %) | 3.4 to 5.0 |",
        "| 20 to 49 | 2 | 2/2 (100.0 %) | 3.0 to 6.0 |",
        "| 50 or more | 1 | 1/1 (100.0 %) | 4.0 to 4.0 |",
    ]


def test_a_worn_bearing_not_named_is_listed_with_its_knocks() -> None:
    lines = missed_table([_worn(200132, 13, 3.398, False), _worn(200133, 60, 5.0, True)])
    rows = lines[lines.index("|---|---|---|---|---|---|---|---|---|") + 1 :]
    assert rows == [
        "| 200132 | 10 | load step | worn_bearing (13 knocks, 3.4 x noise) | 5 | yes | 1 | healthy | - |"
    ]


def test_the_impact_limit_is_set_against_spans_heard_but_for_it() -> None:
    """A healthy run's span counts where it is significant (at least 4 and the family's) and localised,
    whatever its size; a worn bearing's at its true bearing alike. 1.4 x on a healthy run lies below
    the 1.5 x limit, a worn bearing's 1.3 x below it too (a miss), its 2.5 x above."""
    healthy = [
        replace(
            _healthy(1, "healthy", operating="baseline point", points=1), impact_other=(1.4, 5.0, 4.6, 1.0)
        ),
        # not significant, not localised, none at all: not counted
        replace(
            _healthy(2, "healthy", operating="baseline point", points=1), impact_other=(9.0, 4.5, 4.6, 1.0)
        ),
        replace(
            _healthy(3, "healthy", operating="baseline point", points=1), impact_other=(9.0, 9.0, 4.6, 6.0)
        ),
        _healthy(4, "healthy", operating="baseline point", points=1),
        replace(_healthy(5, "healthy", points=1), impact_other=(1.6, 12.0, 4.6, math.nan)),
    ]
    worn = [
        replace(_worn(6, 30, 4.0, False), operating="baseline point", impact_true=(1.3, 20.0, 4.6, 1.0)),
        replace(_worn(7, 30, 4.0, True), operating="baseline point", impact_true=(2.5, 20.0, 4.6, 1.2)),
    ]
    rows = impact_limit_table(healthy + worn)[-2:]
    assert rows == [
        "| at the baseline's point | 4 | 1 | 1.40 | 0 | 2 | 2 | 1.30 | 1 |",
        "| off it, one point | 1 | 1 | 1.60 | 1 | 0 | 0 | - | 0 |",
    ]
