"""Each finding rule just inside and just outside each of its limits: the exact severity and label.

The limits are those of docs/diagnosis.md, "Findings", written here as literal numbers (the inputs
are built from them, not from :mod:`monitor.diagnosis.findings`' constants), so that a changed
constant fails a test instead of moving the test with it.  The rules are called directly on
constructed estimates (:class:`CylinderBalance`, :class:`ImpactScore`, :class:`OrderDeviation`,
:class:`SensorFault`, :class:`VelocityRms`).

Mutations of findings.py each of which fails this module (and which the acceptance set in
test_diagnosis.py does not all notice), with a test that catches it:

- ``MISFIRE_BELOW`` 0.3 -> -1: test_a_cylinder_against_the_others[misfiring below 30 %],
  test_a_single_cylinder[no baseline: misfiring below 30 %], ...[a baseline reference at or below
  30 % is no reference];
- ``CYLINDER_ALARM`` low 0.5 -> 0.3: test_a_cylinder_against_the_others[alarm below 50 %];
- ``CYLINDER_WARNING`` low 0.85 -> 0.75: test_a_cylinder_against_the_others[warning below 85 %];
- ``SIGNIFICANCE`` 4 -> 3: test_a_cylinder_against_the_others[beyond the band, 3.9 contrast errors
  from 100 %], test_impacts[significance below 4], test_bearing_orders[3.99 errors];
- ``IMPACT_WITHOUT_BASELINE`` 10 -> 8: test_impacts[no baseline: below 10 x];
- the labels "misfiring" and "weak, leaking or misfiring" swapped: every misfiring and weak row of
  test_a_cylinder_against_the_others and test_a_single_cylinder;
- and each constant against its documented value: test_the_limits_are_those_documented;
- every number of findings.py and every comparison moved across its limit, by ``make mutation``
  (docs/mutation-testing.md, which lists the equivalent mutants left): the tests from
  test_confidence_is_the_normal_probability_beyond_the_threshold on, each limit exactly among them.
"""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest

from monitor.diagnosis import findings
from monitor.diagnosis.balance import CylinderBalance
from monitor.diagnosis.bearings import AWAY_SHARE, AWAY_SIGNIFICANCE, ImpactScore, OrderDeviation
from monitor.diagnosis.diagnose import _zones
from monitor.diagnosis.findings import (
    BearingResult,
    Finding,
    bearing_findings,
    cylinder_findings,
    sensor_finding,
    single_cylinder_findings,
)
from monitor.diagnosis.misfire import MissingFiring
from monitor.diagnosis.sensors import SensorFault
from monitor.diagnosis.zones import DEFAULT_BOUNDARIES_MM_S, VelocityRms
from monitor.io.recording import Channel, Recording

MISFIRING = "misfiring"
WEAK = "weak, leaking or misfiring"
NEARLY = "misfiring, or nearly: no firing is within its 95 % interval"
STRONGER = "stronger than the others"
STRONGER_THAN_MODEL = "stronger than the model"
NEARLY_PATTERN = "misfiring, or nearly: it lacks most of its firing impulse"


def test_the_limits_are_those_documented() -> None:
    """docs/diagnosis.md, "Findings": 4 standard errors; a cylinder against the others a warning below
    85 % or above 115 %, an alarm below 50 % or above 130 %, misfiring below 30 %; a single cylinder's
    error at least 15 % against the model (10 % against its baseline), a limit crossed 2 errors beyond it;
    bearing orders 50 % and 100 %;
    impacts 1.5 x, 2 x with a cylinder finding, 10 x without a baseline (a warning) and 10 x for an
    alarm, localised by a factor of 2 against other sensors and against 5 % of its own spans away from
    its windows (each counted beyond 4 standard errors); zones C and D from 11 and 18 mm/s; a missing
    impulse's pattern explaining at least 50 % of the orders where the cylinders cancel, its share given
    while its 95 % interval reaches no further than 100 % either side."""
    assert findings.SIGNIFICANCE == 4.0
    assert findings.CYLINDER_WARNING == (0.85, 1.15)
    assert findings.CYLINDER_ALARM == (0.5, 1.3)
    assert findings.MISFIRE_BELOW == 0.3
    assert findings.ABSOLUTE_UNCERTAINTY == 0.15
    assert findings.BASELINE_UNCERTAINTY == 0.10
    assert findings.SINGLE_BEYOND == 2.0
    assert (findings.BEARING_WARNING, findings.BEARING_ALARM) == (0.5, 1.0)
    assert (findings.IMPACT_WARNING, findings.IMPACT_ALARM) == (1.5, 10.0)
    assert findings.IMPACT_WITH_CYLINDER_FINDING == 2.0
    assert findings.IMPACT_WITHOUT_BASELINE == 10.0
    assert findings.LOCALISED == 2.0
    assert (AWAY_SHARE, AWAY_SIGNIFICANCE) == (0.05, 4.0)
    assert findings.PATTERN_EXPLAINED == 0.5
    assert findings.SHARE_READABLE == 1.0
    assert DEFAULT_BOUNDARIES_MM_S == (7.1, 11.0, 18.0)


def _label(summary: str) -> str:
    """What a cylinder finding calls the cylinder: the text between its summary's "(" and ";"."""
    match = re.search(r"\(([^;(]*);", summary)
    assert match is not None, summary
    return match.group(1)


def _balance(strength: list[float], relative: list[float], error: float, contrast: float) -> CylinderBalance:
    """A balance with the given strengths and shares, every cylinder with the same errors."""
    n = len(strength)
    empty = np.zeros(0)
    none = np.zeros(0, dtype=np.complex128)
    return CylinderBalance(
        strength=np.asarray(strength, dtype=np.float64),
        strength_covariance=np.diag(np.full(n, error**2)),
        relative=np.asarray(relative, dtype=np.float64),
        relative_error=np.full(n, error),
        contrast_error=np.full(n, contrast),
        model_uncertainty=0.1,
        orders=empty,
        measured=none,
        predicted=none,
        standard_error=empty,
        unit="N m",
        condition=1.0,
        chi2_reduced=1.0,
        separable=True,
        strength_meaning="heat release",
        transfer="rigid",
        inertia=1.0,
    )


def _only(found: list[Finding]) -> tuple[str, str, float] | None:
    """The one finding's severity, label and threshold, or None without a finding."""
    assert len(found) <= 1, [f.summary for f in found]
    if not found:
        return None
    finding = found[0]
    assert finding.kind == "cylinder"
    return finding.severity, _label(finding.summary), finding.evidence[0]["threshold"]


# (id, share of the others, its standard error, its contrast error, expected severity, label, threshold)
AGAINST_THE_OTHERS: list[tuple[str, float, float, float, tuple[str, str, float] | None]] = [
    ("healthy above 85 %", 0.86, 0.01, 0.01, None),
    ("warning below 85 %", 0.84, 0.01, 0.01, ("warning", WEAK, 0.85)),
    ("warning above 50 %", 0.51, 0.01, 0.01, ("warning", WEAK, 0.85)),
    ("alarm below 50 %", 0.49, 0.01, 0.01, ("alarm", WEAK, 0.5)),
    ("weak above 30 %", 0.31, 0.01, 0.01, ("alarm", WEAK, 0.5)),
    ("misfiring below 30 %", 0.29, 0.01, 0.01, ("alarm", MISFIRING, 0.5)),
    ("healthy below 115 %", 1.14, 0.01, 0.01, None),
    ("warning above 115 %", 1.16, 0.01, 0.01, ("warning", STRONGER, 1.15)),
    ("warning below 130 %", 1.29, 0.01, 0.01, ("warning", STRONGER, 1.15)),
    ("alarm above 130 %", 1.31, 0.01, 0.01, ("alarm", STRONGER, 1.3)),
    # 0.80 is beyond the warning limit: a finding only 4 contrast errors (0.05) from 100 %
    ("beyond the band, 3.9 contrast errors from 100 %", 0.80, 0.01, 0.2 / 3.9, None),
    ("beyond the band, 4.1 contrast errors from 100 %", 0.80, 0.01, 0.2 / 4.1, ("warning", WEAK, 0.85)),
    ("beyond the band, 4.1 errors but 3.9 contrast errors", 0.80, 0.2 / 4.1, 0.2 / 3.9, None),
    # an alarm whose 95 % interval (1.96 errors) reaches no firing is called misfiring, or nearly
    ("alarm, no firing outside 1.96 errors", 0.40, 0.40 / 1.97, 0.01, ("alarm", WEAK, 0.5)),
    ("alarm, no firing within 1.96 errors", 0.40, 0.40 / 1.95, 0.01, ("alarm", NEARLY, 0.5)),
]


@pytest.mark.parametrize(
    ("share", "error", "contrast", "expected"),
    [row[1:] for row in AGAINST_THE_OTHERS],
    ids=[row[0] for row in AGAINST_THE_OTHERS],
)
def test_a_cylinder_against_the_others(
    share: float, error: float, contrast: float, expected: tuple[str, str, float] | None
) -> None:
    """Cylinder 2 of three at a share of the others; the two others at 100 % name nothing."""
    balance = _balance([1.0, share, 1.0], [1.0, share, 1.0], error, contrast)
    found = cylinder_findings(balance)
    assert _only(found) == expected
    if found:
        assert found[0].subject == "cylinder 2"
        assert f"({expected[1] if expected else ''}; heat release from the crank-speed orders)" in (
            found[0].summary
        )


# (id, share of the others' impulse, deficit, its error, explained, the model's share, expected)
PATTERN: list[tuple[str, float, float, float, float, float, tuple[str, str, float] | None]] = [
    ("lacks most: below 50 %", 0.49, 1.0, 0.01, 0.9, 1.0, ("alarm", NEARLY_PATTERN, 0.5)),
    ("lacks half or less: at 50 %", 0.50, 1.0, 0.01, 0.9, 1.0, None),
    ("misfiring below 30 %", 0.29, 1.0, 0.01, 0.9, 1.0, ("alarm", MISFIRING, 0.5)),
    ("lacks most above 30 %", 0.31, 1.0, 0.01, 0.9, 1.0, ("alarm", NEARLY_PATTERN, 0.5)),
    ("deficit 4.1 errors above nothing", 0.1, 1.0, 1.0 / 4.1, 0.9, 1.0, ("alarm", MISFIRING, 0.5)),
    ("deficit 3.9 errors above nothing", 0.1, 1.0, 1.0 / 3.9, 0.9, 1.0, None),
    ("the pattern explains 51 %", 0.1, 1.0, 0.01, 0.51, 1.0, ("alarm", MISFIRING, 0.5)),
    ("the pattern explains 49 %", 0.1, 1.0, 0.01, 0.49, 1.0, None),
    ("the pattern explains exactly 50 %", 0.1, 1.0, 0.01, 0.5, 1.0, ("alarm", MISFIRING, 0.5)),
    ("misfiring, or nearly, at exactly 30 %", 0.3, 1.0, 0.01, 0.9, 1.0, ("alarm", NEARLY_PATTERN, 0.5)),
    # the model's rule already calls it an alarm reading it lower, or misfiring: its finding stands
    ("the model's lower alarm stands", 0.45, 1.0, 0.01, 0.9, 0.44, ("alarm", WEAK, 0.5)),
    ("the model's misfiring stands", 0.05, 1.0, 0.01, 0.9, 0.29, ("alarm", MISFIRING, 0.5)),
    # the model's alarm reads it as high, or higher and not misfiring: the pattern stands in for it
    ("the model's alarm as high gives way", 0.45, 1.0, 0.01, 0.9, 0.45, ("alarm", NEARLY_PATTERN, 0.5)),
    ("the model's higher alarm gives way", 0.29, 1.0, 0.01, 0.9, 0.31, ("alarm", MISFIRING, 0.5)),
    # a model's warning gives way to the pattern's alarm
    ("the pattern's alarm replaces a warning", 0.1, 1.0, 0.01, 0.9, 0.7, ("alarm", MISFIRING, 0.5)),
]


@pytest.mark.parametrize(
    ("share", "deficit", "error", "explained", "model", "expected"),
    [row[1:] for row in PATTERN],
    ids=[row[0] for row in PATTERN],
)
def test_a_missing_firing_impulse(
    share: float,
    deficit: float,
    error: float,
    explained: float,
    model: float,
    expected: tuple[str, str, float] | None,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Cylinder 2 of three lacks ``deficit`` of its impulse by the pattern test (its result given
    here), the model-based share at ``model`` with small errors: an alarm below 50 % whose deficit
    stands 4 errors above nothing and whose pattern explains at least half the cancelling orders."""
    balance = _balance([1.0, model, 1.0], [1.0, model, 1.0], 0.01, 0.01)
    given = _missing(share, deficit, error, explained)
    monkeypatch.setattr(findings, "missing_firing", lambda _: given)
    found = cylinder_findings(balance)
    assert _only(found) == expected
    if found:
        assert found[0].subject == "cylinder 2"
        # the balance's finding stands where it is an alarm reading the cylinder lower, or misfiring
        by_pattern = "the pattern of a missing impulse" in found[0].summary
        assert by_pattern == (not (model < 0.5 and (model < share or model < 0.3))), found[0].summary


def _missing(share: float, deficit: float, error: float, explained: float) -> MissingFiring:
    """The pattern test's result with cylinder 2 of three its candidate."""
    return MissingFiring(
        deficit=np.array([-0.1, deficit, -0.1]),
        deficit_error=np.full(3, error),
        level=np.full(3, deficit / (1 - share)),
        level_error=np.full(3, 0.01),
        share=np.array([1.1, share, 1.1]),
        share_error=np.full(3, 0.05),
        compression=np.ones(3),
        explained=np.array([0.1, explained, 0.1]),
        orders=np.array([0.5, 1.0, 1.5]),
        cancelling=np.array([True, False, True]),
    )


# (id, share, deficit, its error, explained, whether the run is held back from healthy)
DOUBT: list[tuple[str, float, float, float, float, bool]] = [
    ("lacks most, its pattern explains 49 %", 0.1, 1.0, 0.01, 0.49, True),
    ("lacks most, its pattern explains 51 % (a finding instead)", 0.1, 1.0, 0.01, 0.51, False),
    ("at 50 %, unexplained", 0.5, 1.0, 0.01, 0.1, False),
    ("deficit 3.9 errors, unexplained", 0.1, 1.0, 1.0 / 3.9, 0.1, False),
    ("deficit exactly 4 errors, unexplained", 0.1, 1.0, 0.25, 0.1, True),
    ("its pattern explains exactly 50 % (a finding instead)", 0.1, 1.0, 0.01, 0.5, False),
]


@pytest.mark.parametrize(
    ("share", "deficit", "error", "explained", "doubt"),
    [row[1:] for row in DOUBT],
    ids=[row[0] for row in DOUBT],
)
def test_a_deficit_its_pattern_does_not_explain(
    share: float, deficit: float, error: float, explained: float, doubt: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A deficit that would be an alarm but whose pattern explains less than half the cancelling
    orders names nothing and keeps the run from being called healthy (the reason names it)."""
    balance = _balance([1.0, 1.0, 1.0], [1.0, 1.0, 1.0], 0.01, 0.01)
    monkeypatch.setattr(findings, "missing_firing", lambda _: _missing(share, deficit, error, explained))
    reason = findings.missing_firing_doubt(balance)
    assert (reason is not None) == doubt
    if reason is not None:
        assert reason.startswith("cylinder 2 reads 10 % of the others' firing impulse")
        assert cylinder_findings(balance) == []


@pytest.mark.parametrize(
    ("share", "explained", "reason"),
    [
        (
            0.445,
            0.445,
            "cylinder 2 reads 44 % of the others' firing impulse by its pattern, 100 standard "
            "errors, but the pattern explains only 44 % of the orders",
        ),
        (
            0.455,
            0.455,
            "cylinder 2 reads 46 % of the others' firing impulse by its pattern, 100 standard "
            "errors, but the pattern explains only 46 % of the orders",
        ),
    ],
    ids=["44.5 % rounds down", "45.5 % rounds up"],
)
def test_a_deficit_its_pattern_does_not_explain_states_both_shares(
    share: float, explained: float, reason: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    balance = _balance([1.0, 1.0, 1.0], [1.0, 1.0, 1.0], 0.01, 0.01)
    monkeypatch.setattr(findings, "missing_firing", lambda _: _missing(share, 1.0, 0.01, explained))
    assert (findings.missing_firing_doubt(balance) or "").startswith(reason)


@pytest.mark.parametrize(
    ("share", "share_error", "summary"),
    [
        (0.445, 0.13, "cylinder 2 at 44 % +- 25 % of the others' firing impulse (misfiring, or nearly: "),
        (0.455, 0.12525, "cylinder 2 at 46 % +- 25 % of the others' firing impulse (misfiring, or nearly: "),
        (0.1, 0.0, "cylinder 2 at 10 % +- 0 % of the others' firing impulse (misfiring; "),
    ],
    ids=["44.5 % and 1.96 x 13 % round down", "45.5 % and 1.96 x 12.525 % round up", "no error at all"],
)
def test_a_missing_firing_impulse_states_its_share_and_95_interval(
    share: float, share_error: float, summary: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The pattern's alarm: its share and 95 % interval in the summary, the evidence against 100 %, and
    its confidence that the share lies below the alarm limit (an error of 0 gives certainty, no error)."""
    balance = _balance([1.0, 1.0, 1.0], [1.0, 1.0, 1.0], 0.01, 0.01)
    given = dataclasses.replace(_missing(share, 1.0, 0.01, 0.9), share_error=np.full(3, share_error))
    monkeypatch.setattr(findings, "missing_firing", lambda _: given)
    (found,) = findings.missing_firing_findings(balance)
    assert found.summary.startswith(summary)
    assert (found.evidence[0]["predicted"], found.evidence[0]["threshold"]) == (1.0, 0.5)
    expected = findings.confidence_beyond((0.5 - share) / max(share_error, 1e-12))
    assert found.confidence == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize(
    ("share_error", "summary"),
    [
        (0.51, "cylinder 2 at -200 % +- 100 % of the others' firing impulse (misfiring; "),
        (1 / 1.96, "cylinder 2 at -200 % +- 100 % of the others' firing impulse (misfiring; "),
        (
            0.511,
            "cylinder 2 lacks 1.00 +- 0.02 of a cylinder's firing impulse in the model at the load used, the "
            "others firing 0.33 +- 0.02 of it: too uncertain a level to give a share (misfiring; ",
        ),
    ],
    ids=[
        "95 % interval 99.96 %: the share",
        "95 % interval exactly 100 %: the share",
        "95 % interval 100.16 %: the deficit and the level",
    ],
)
def test_a_missing_firing_impulse_whose_share_says_nothing_gives_its_deficit(
    share_error: float, summary: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A share whose 95 % interval reaches further than 100 % either side (``SHARE_READABLE``) is no size:
    the summary gives the deficit and the others' level, each with its 95 % interval, in the model's units;
    the evidence and the confidence stay the share's."""
    balance = _balance([1.0, 1.0, 1.0], [1.0, 1.0, 1.0], 0.01, 0.01)
    given = dataclasses.replace(_missing(-2.0, 1.0, 0.01, 0.9), share_error=np.full(3, share_error))
    monkeypatch.setattr(findings, "missing_firing", lambda _: given)
    (found,) = findings.missing_firing_findings(balance)
    assert found.summary.startswith(summary), found.summary
    assert found.evidence[0]["measured"] == -2.0
    assert found.confidence == pytest.approx(findings.confidence_beyond(2.5 / share_error), rel=1e-12)


def test_a_missing_firing_impulse_of_unknown_cycle_phase_names_its_partner(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Cylinder 2's partner 360 deg from it is cylinder 3 (index 2): both are named."""
    balance = _balance([1.0, 1.0, 1.0], [1.0, 1.0, 1.0], 0.01, 0.01)
    monkeypatch.setattr(findings, "missing_firing", lambda _: _missing(0.1, 1.0, 0.01, 0.9))
    (found,) = findings.missing_firing_findings(balance, [None, 2, None])
    assert found.subject == "cylinder 2 or cylinder 3"
    assert found.summary.endswith("; the cycle phase is unknown, so either may be it")


# (id, strength, its standard error, the baseline's strength (None: none), expected)
SINGLE: list[tuple[str, float, float, float | None, tuple[str, str, float] | None]] = [
    # against the model: an error of at least 15 %, each limit crossed 2 of them beyond it: a warning below
    # 85 - 30 = 55 %, an alarm below 50 - 30 = 20 %, a warning above 130 + 30 = 160 %
    ("no baseline: 15 % error, above 55 %", 0.551, 0.01, None, None),
    ("no baseline: 15 % error, below 55 %", 0.549, 0.01, None, ("warning", WEAK, 0.85)),
    ("no baseline: a warning above 20 %", 0.201, 0.01, None, ("warning", MISFIRING, 0.85)),
    ("no baseline: an alarm below 20 %", 0.199, 0.01, None, ("alarm", MISFIRING, 0.5)),
    ("no baseline: 15 % error, below 160 %", 1.599, 0.01, None, None),
    ("no baseline: 15 % error, above 160 %", 1.601, 0.01, None, ("warning", STRONGER_THAN_MODEL, 1.3)),
    ("no baseline: a 20 % error is more than the floor", 0.451, 0.2, None, None),
    ("no baseline: 2 errors of 20 % below 85 %", 0.449, 0.2, None, ("warning", WEAK, 0.85)),
    # against a baseline of 100 %: at least 10 %, so below 65 %, 30 % and above 150 %
    ("baseline: 10 % error, above 65 %", 0.651, 0.01, 1.0, None),
    ("baseline: 10 % error, below 65 %", 0.649, 0.01, 1.0, ("warning", WEAK, 0.85)),
    ("baseline: a warning above 30 %", 0.301, 0.01, 1.0, ("warning", WEAK, 0.85)),
    ("baseline: an alarm below 30 %, misfiring", 0.299, 0.01, 1.0, ("alarm", MISFIRING, 0.5)),
    ("baseline: 10 % error, below 150 %", 1.499, 0.01, 1.0, None),
    ("baseline: 10 % error, above 150 %", 1.501, 0.01, 1.0, ("warning", STRONGER_THAN_MODEL, 1.3)),
    # the baseline's own strength is the reference: 80 % of it below 65 % of 80 %
    ("baseline of 80 %: above 65 % of it", 0.8 * 0.651, 0.01, 0.8, None),
    ("baseline of 80 %: below 65 % of it", 0.8 * 0.649, 0.01, 0.8, ("warning", WEAK, 0.85)),
    # a baseline that misfired itself is no reference: the model's (with the baseline's error floor)
    ("a baseline reference above 30 % serves", 0.28, 0.01, 0.31, None),
    ("a baseline reference at or below 30 % is no reference", 0.28, 0.01, 0.29, ("alarm", MISFIRING, 0.5)),
]


@pytest.mark.parametrize(
    ("strength", "error", "calibrated", "expected"),
    [row[1:] for row in SINGLE],
    ids=[row[0] for row in SINGLE],
)
def test_a_single_cylinder(
    strength: float, error: float, calibrated: float | None, expected: tuple[str, str, float] | None
) -> None:
    """A single cylinder against its baseline's strength, or without one against the model's."""
    found = single_cylinder_findings(_balance([strength], [math.nan], error, error), 1.0, calibrated)
    assert _only(found) == expected
    if found:
        assert found[0].subject == "cylinder 1"
        judged = "its baseline" if calibrated is not None else "the model"
        assert found[0].summary.endswith(f"a single cylinder is judged against {judged}, not against others)")


def _impact(
    score: float,
    significance: float = 20.0,
    needed: float = 3.0,
    elsewhere: float = 1.0,
    bearing: int = 5,
    away: float = 1.0,
) -> ImpactScore:
    return ImpactScore(
        bearing=bearing,
        score=score,
        score_error=0.1,
        reference="baseline",
        reversal_angles_deg=[100.0],
        significance=significance,
        significance_needed=needed,
        angle_deg=100.0,
        elsewhere=elsewhere,
        away=away,
    )


# (id, impact, with a baseline, a cylinder finding, expected severity and threshold)
IMPACTS: list[tuple[str, ImpactScore, bool, bool, tuple[str, float] | None]] = [
    ("baseline: below 1.5 x", _impact(1.49), True, False, None),
    ("baseline: above 1.5 x", _impact(1.51), True, False, ("warning", 1.5)),
    ("baseline: below 10 x", _impact(9.99), True, False, ("warning", 1.5)),
    ("baseline: at 10 x", _impact(10.0), True, False, ("alarm", 10.0)),
    ("baseline: above 10 x", _impact(10.01), True, False, ("alarm", 10.0)),
    ("baseline, a cylinder finding: below 2 x", _impact(1.99), True, True, None),
    ("baseline, a cylinder finding: above 2 x", _impact(2.01), True, True, ("warning", 1.5)),
    ("no baseline: below 10 x", _impact(9.99), False, False, None),
    ("no baseline: above 10 x", _impact(10.01), False, False, ("warning", 10.0)),
    ("no baseline: a warning at most", _impact(50.0), False, False, ("warning", 10.0)),
    ("no baseline, a cylinder finding: below 10 x", _impact(9.99), False, True, None),
    ("no baseline, a cylinder finding: above 10 x", _impact(10.01), False, True, ("warning", 10.0)),
    ("no baseline, no other sensor", _impact(50.0, elsewhere=math.nan), False, False, None),
    ("significance below 4", _impact(3.0, significance=3.99, needed=1.0), True, False, None),
    ("significance above 4", _impact(3.0, significance=4.01, needed=1.0), True, False, ("warning", 1.5)),
    ("significance below the family's", _impact(3.0, significance=5.99, needed=6.0), True, False, None),
    ("significance above the family's", _impact(3.0, 6.01, 6.0), True, False, ("warning", 1.5)),
    # an excess of 2 on its own sensor: localised while another sensor's excess is at most half of it
    ("localised: excess elsewhere below half", _impact(3.0, elsewhere=1.99), True, False, ("warning", 1.5)),
    ("not localised: excess elsewhere above half", _impact(3.0, elsewhere=2.01), True, False, None),
    ("localised: quieter elsewhere", _impact(3.0, elsewhere=0.5), True, False, ("warning", 1.5)),
    # and away from its windows on its own sensor alike
    ("in its windows: excess away below half", _impact(3.0, away=1.99), True, False, ("warning", 1.5)),
    ("not in its windows: excess away above half", _impact(3.0, away=2.01), True, False, None),
    ("in its windows: nothing clear of them", _impact(3.0, away=math.nan), True, False, ("warning", 1.5)),
    ("no baseline: excess away above half", _impact(30.0, away=15.6), False, False, None),
]


@pytest.mark.parametrize(
    ("impact", "with_baseline", "cylinders_changed", "expected"),
    [row[1:] for row in IMPACTS],
    ids=[row[0] for row in IMPACTS],
)
def test_impacts(
    impact: ImpactScore, with_baseline: bool, cylinders_changed: bool, expected: tuple[str, float] | None
) -> None:
    """The sensor on main bearing 5 scores a knock span in bearing 5's load-reversal windows."""
    result = BearingResult("mb5-vertical", 5, None, [impact], elsewhere=impact.elsewhere)
    found = bearing_findings([result], with_baseline=with_baseline, cylinders_changed=cylinders_changed)
    assert [(f.severity, f.evidence[0]["threshold"]) for f in found] == ([expected] if expected else [])
    if found:
        assert (found[0].kind, found[0].subject) == ("main bearing", "main bearing 5")
        assert "impacts where its load reverses" in found[0].summary


@pytest.mark.parametrize(
    ("neighbour", "sensed", "expected"),
    [(1.87, False, None), (1.88, False, "main bearing 6"), (3.0, True, None)],
    ids=["below 1.5 x its own", "above 1.5 x its own", "a sensor sits on the neighbour"],
)
def test_a_neighbour_is_named_only_when_clearly_louder_and_unsensed(
    neighbour: float, sensed: bool, expected: str | None
) -> None:
    """Bearing 5's own windows at 1.25 x, below the warning: its neighbour 6, heard beyond the warning
    either way, is named from this sensor only if it hears it at least 1.5 times as loud (1.875 x) and
    no sensor sits on bearing 6."""
    results = [BearingResult("mb5-vertical", 5, None, [_impact(1.25), _impact(neighbour, bearing=6)])]
    if sensed:
        results.append(BearingResult("mb6-vertical", 6, None, []))
    found = bearing_findings(results, with_baseline=True)
    assert [f.subject for f in found] == ([expected] if expected else [])


# (id, deviation, its standard error, expected severity)
ORDERS: list[tuple[str, float, float, str | None]] = [
    ("below 50 %", 0.49, 0.01, None),
    ("above 50 %", 0.51, 0.01, "warning"),
    ("below 100 %", 0.99, 0.01, "warning"),
    ("at 100 %", 1.0, 0.01, "alarm"),
    ("3.99 errors", 0.8, 0.8 / 3.99, None),
    ("4.01 errors", 0.8, 0.8 / 4.01, "warning"),
]


@pytest.mark.parametrize(
    ("deviation", "error", "expected"), [row[1:] for row in ORDERS], ids=[row[0] for row in ORDERS]
)
def test_bearing_orders(deviation: float, error: float, expected: str | None) -> None:
    """One order's deviation from the calibrated prediction."""
    orders = OrderDeviation(
        orders=np.array([2.0]),
        measured=np.array([1.0 + deviation], dtype=np.complex128),
        predicted=np.array([1.0], dtype=np.complex128),
        deviation=np.array([deviation]),
        deviation_error=np.array([error]),
    )
    found = bearing_findings([BearingResult("mb5-vertical", 5, orders, [])], with_baseline=True)
    assert [f.severity for f in found] == ([expected] if expected else [])
    if found:
        assert (found[0].kind, found[0].subject) == ("main bearing", "main bearing 5")
        assert found[0].evidence[0]["threshold"] == 0.5


def _recording() -> Recording:
    channel = Channel(
        "mb5-vertical", "acceleration", "m/s^2", np.zeros(64), 1000.0, location="main bearing 5"
    )
    return Recording("man-b-w-7k98mc", "2026-11-27T00:00:00Z", (channel,))


@pytest.mark.parametrize("fault", ["unusable samples", "dead", "implausible level"])
def test_a_faulty_sensor_is_a_warning_never_an_alarm(fault: str) -> None:
    finding = sensor_finding(SensorFault("mb5-vertical", fault, "as measured"), _recording())
    assert (finding.kind, finding.subject, finding.severity) == ("sensor", "sensor mb5-vertical", "warning")
    assert finding.summary.startswith(f"sensor mb5-vertical (main bearing 5): {fault}: as measured;")


@pytest.mark.parametrize(
    ("velocity", "expected"),
    [(10.99, None), (11.0, ("warning", 11.0)), (17.99, ("warning", 11.0)), (18.0, ("alarm", 18.0))],
    ids=["zone B", "zone C from its boundary", "zone C", "zone D from its boundary"],
)
def test_vibration_zones(velocity: float, expected: tuple[str, float] | None) -> None:
    """The default zone boundaries: zone C a warning, zone D an alarm, a value on a boundary above it."""
    rms = {"mb5-vertical": VelocityRms(velocity, 0.1, (2.0, 450.0), 16)}
    _, found = _zones(_recording(), rms, DEFAULT_BOUNDARIES_MM_S, stated=False)
    assert [(f.severity, f.evidence[0]["threshold"]) for f in found] == ([expected] if expected else [])


# Rows added for the mutants of findings.py that `make mutation` (docs/mutation-testing.md) found alive.


def test_confidence_is_the_normal_probability_beyond_the_threshold() -> None:
    """50 % on the threshold, 97.5 % at 1.96 standard errors beyond it, 84.1 % at one."""
    assert findings.confidence_beyond(0.0) == 0.5
    assert findings.confidence_beyond(1.96) == pytest.approx(0.975, abs=1e-4)
    assert findings.confidence_beyond(1.0) == pytest.approx(0.8413, abs=1e-4)


@pytest.mark.parametrize(
    ("share", "error", "summary"),
    [
        (0.84, 0.0127, "cylinder 2 at 84 % +- 2 % of the cylinders that fire alike"),
        (0.84, 0.0128, "cylinder 2 at 84 % +- 3 % of the cylinders that fire alike"),
    ],
    ids=["1.96 x 1.27 % rounds to 2 %", "1.96 x 1.28 % rounds to 3 %"],
)
def test_a_cylinder_summary_states_its_share_and_95_interval(
    share: float, error: float, summary: str
) -> None:
    found = cylinder_findings(_balance([1.0, share, 1.0], [1.0, share, 1.0], error, 0.01))
    assert found[0].summary.startswith(summary)
    assert (found[0].evidence[0]["predicted"], found[0].evidence[0]["measured"]) == (1.0, share)


@pytest.mark.parametrize(
    ("strength", "error", "summary"),
    [
        (0.384, 0.1298, "cylinder 1 at 38 % +- 25 % of the baseline's at load 1.00"),
        (0.386, 0.1304, "cylinder 1 at 39 % +- 26 % of the baseline's at load 1.00"),
    ],
    ids=["38.4 % and 1.96 x 12.98 % round down", "38.6 % and 1.96 x 13.04 % round up"],
)
def test_a_single_cylinder_summary_states_its_strength_and_95_interval(
    strength: float, error: float, summary: str
) -> None:
    found = single_cylinder_findings(_balance([strength], [math.nan], error, error), 1.0, 1.0)
    assert found[0].summary.startswith(summary)
    assert found[0].evidence[0]["predicted"] == 1.0


def test_of_two_cylinders_only_the_weaker_is_named() -> None:
    """Cylinder 1 at 60 % (a warning) makes cylinder 2 read 140 % (an alarm): only cylinder 1 is named."""
    found = cylinder_findings(_balance([0.8, 1.2], [0.6, 1.4], 0.01, 0.01))
    assert [(f.subject, f.severity) for f in found] == [("cylinder 1", "warning")]


def test_a_cylinder_whose_cycle_phase_is_unknown_is_named_with_its_partner() -> None:
    """Cylinder 2 of four fires 360 deg from cylinder 4 (index 3)."""
    balance = _balance([1.0, 0.84, 1.0, 1.0], [1.0, 0.84, 1.0, 1.0], 0.01, 0.01)
    found = cylinder_findings(balance, partners=[None, 3, None, None])
    assert [f.subject for f in found] == ["cylinder 2 or cylinder 4"]


def _orders(deviation: float, error: float) -> OrderDeviation:
    return OrderDeviation(
        orders=np.array([2.0]),
        measured=np.array([1.0 + deviation], dtype=np.complex128),
        predicted=np.array([1.0], dtype=np.complex128),
        deviation=np.array([deviation]),
        deviation_error=np.array([error]),
    )


@pytest.mark.parametrize(
    ("deviation", "error", "expected"),
    [(0.8, 0.2, ("warning", 0.5)), (0.6, 0.0, ("warning", 0.5))],
    ids=["at exactly 4 errors", "no error stated: at least its floor"],
)
def test_bearing_orders_at_the_significance_limit(
    deviation: float, error: float, expected: tuple[str, float]
) -> None:
    found = bearing_findings(
        [BearingResult("mb5-vertical", 5, _orders(deviation, error), [])], with_baseline=True
    )
    assert [(f.severity, f.evidence[0]["threshold"]) for f in found] == [expected]


def test_a_bearing_found_twice_alike_keeps_its_first_summary_and_all_evidence() -> None:
    """An order deviation and an impact, both warnings: the orders' summary, both pieces of evidence."""
    result = BearingResult("mb5-vertical", 5, _orders(0.6, 0.01), [_impact(3.0)], elsewhere=1.0)
    found = bearing_findings([result], with_baseline=True)
    assert [f.severity for f in found] == ["warning"]
    assert found[0].summary == (
        "main bearing 5: orders 2 of mb5-vertical deviate from the calibrated model, up to 60 % (order 2)"
    )
    assert len(found[0].evidence) == 2


def test_an_impact_confidence_counts_score_errors_beyond_its_threshold() -> None:
    """1.6 x against 1.5 x with a score error of 0.1: one error beyond, 84.1 %."""
    result = BearingResult("mb5-vertical", 5, None, [_impact(1.6)], elsewhere=1.0)
    found = bearing_findings([result], with_baseline=True)
    assert found[0].confidence == pytest.approx(0.8413, abs=1e-4)
    assert (found[0].evidence[0]["predicted"], found[0].evidence[0]["threshold"]) == (1.0, 1.5)


def test_an_impact_quieter_elsewhere_is_localised_at_any_excess() -> None:
    """2.5 x on its own sensor, below the baseline's level on the others: localised."""
    result = BearingResult("mb5-vertical", 5, None, [_impact(2.5, elsewhere=0.5)], elsewhere=0.5)
    found = bearing_findings([result], with_baseline=True)
    assert [(f.severity, f.evidence[0]["threshold"]) for f in found] == [("warning", 1.5)]


def test_a_faulty_sensor_finding_is_certain() -> None:
    finding = sensor_finding(SensorFault("mb5-vertical", "dead", "as measured"), _recording())
    assert finding.confidence == 1.0


def test_a_cylinder_with_no_error_stated_is_judged_with_its_floor() -> None:
    """A zero standard error: the finding stands, certain."""
    found = cylinder_findings(_balance([1.0, 0.84, 1.0], [1.0, 0.84, 1.0], 0.0, 0.01))
    assert [(f.severity, f.confidence) for f in found] == [("warning", 1.0)]


def test_an_impact_with_no_error_stated_is_judged_with_its_floor() -> None:
    """A zero score error: the finding stands, certain."""
    impact = dataclasses.replace(_impact(3.0), score_error=0.0)
    found = bearing_findings(
        [BearingResult("mb5-vertical", 5, None, [impact], elsewhere=1.0)], with_baseline=True
    )
    assert [(f.severity, f.confidence) for f in found] == [("warning", 1.0)]


# Each limit exactly: "below" and "above" a limit leave the limit itself out; "at least" takes it in.
ON_THE_LIMITS: list[tuple[str, float, float, float, tuple[str, str, float] | None]] = [
    ("at 85 %: healthy", 0.85, 0.01, 0.01, None),
    ("at 50 %: a warning", 0.5, 0.01, 0.01, ("warning", WEAK, 0.85)),
    ("at 115 %: healthy", 1.15, 0.01, 0.01, None),
    ("at 130 %: a warning", 1.3, 0.01, 0.01, ("warning", STRONGER, 1.15)),
    ("at 30 %: weak", 0.3, 0.01, 0.01, ("alarm", WEAK, 0.5)),
    ("at exactly 4 contrast errors from 100 %", 0.75, 0.01, 0.0625, ("warning", WEAK, 0.85)),
    ("no firing at exactly 1.96 errors: weak", 0.49, 0.25, 0.01, ("alarm", WEAK, 0.5)),
]


@pytest.mark.parametrize(
    ("share", "error", "contrast", "expected"),
    [row[1:] for row in ON_THE_LIMITS],
    ids=[row[0] for row in ON_THE_LIMITS],
)
def test_a_cylinder_on_its_limits(
    share: float, error: float, contrast: float, expected: tuple[str, str, float] | None
) -> None:
    found = cylinder_findings(_balance([1.0, share, 1.0], [1.0, share, 1.0], error, contrast))
    assert _only(found) == expected


@pytest.mark.parametrize(
    ("strength", "error", "calibrated", "expected"),
    [
        (0.28, 0.01, 0.3, ("alarm", MISFIRING, 0.5)),
        (0.6, 0.125, 1.0, None),
        (0.25, 0.125, 1.0, ("warning", MISFIRING, 0.85)),
        (1.55, 0.125, 1.0, None),
        (0.3, 0.01, 1.0, ("warning", WEAK, 0.85)),
    ],
    ids=[
        "a baseline reference of 30 % is no reference",
        "exactly 2 errors of 12.5 % below 85 %: healthy",
        "exactly 2 errors of 12.5 % below 50 %: a warning",
        "exactly 2 errors of 12.5 % above 130 %: healthy",
        "at 30 %: weak, not misfiring",
    ],
)
def test_a_single_cylinder_on_its_limits(
    strength: float, error: float, calibrated: float | None, expected: tuple[str, str, float] | None
) -> None:
    found = single_cylinder_findings(_balance([strength], [math.nan], error, error), 1.0, calibrated)
    assert _only(found) == expected


@pytest.mark.parametrize(
    ("impact", "expected"),
    [
        (_impact(1.5), ("warning", 1.5)),
        (_impact(3.0, significance=4.0, needed=1.0), ("warning", 1.5)),
        (_impact(3.0, elsewhere=2.0), ("warning", 1.5)),
        (_impact(3.0, away=2.0), ("warning", 1.5)),
    ],
    ids=[
        "at 1.5 x",
        "at a significance of 4",
        "localised: excess elsewhere exactly half",
        "in its windows: excess away exactly half",
    ],
)
def test_an_impact_on_its_limits(impact: ImpactScore, expected: tuple[str, float]) -> None:
    result = BearingResult("mb5-vertical", 5, None, [impact], elsewhere=impact.elsewhere)
    found = bearing_findings([result], with_baseline=True)
    assert [(f.severity, f.evidence[0]["threshold"]) for f in found] == [expected]


def test_a_neighbour_exactly_1_5_times_as_loud_is_named() -> None:
    """1.875 x against its own 1.25 x: exactly 1.5 times, in binary too."""
    results = [BearingResult("mb5-vertical", 5, None, [_impact(1.25), _impact(1.875, bearing=6)])]
    assert [f.subject for f in bearing_findings(results, with_baseline=True)] == ["main bearing 6"]


def test_bearing_orders_at_50_percent() -> None:
    found = bearing_findings([BearingResult("mb5-vertical", 5, _orders(0.5, 0.01), [])], with_baseline=True)
    assert [f.severity for f in found] == ["warning"]
