"""The off-point report lists the healthy runs it left inconclusive, each with the product's reason."""

from __future__ import annotations

import math

from benchmarks.diagnosis_operating import unjudged_table
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
