"""Cylinder shares: a V engine's cylinder against its own bank, cylinders firing together as one.

The crank speed tells one bank's level from the other's only at the orders where each bank's
cylinders add up, where the inertia torque dominates; the differences inside a bank are known far
better (on a V16 of the validation population, seed 300047: 0.36 against 0.02 to 0.04, one
standard error). These tests build that covariance by hand and check the shares and their contrast
errors against the linear algebra written out for one cylinder.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from monitor.diagnosis.findings import Finding, cylinder_findings
from monitor.diagnosis.shares import ALIKE, TOGETHER, fire_together, one_of, relative_shares
from monitor.model.banks import Vee, cylinder_banks
from tests.diagnosis.test_rule_limits import MISFIRING, STRONGER, WEAK, _balance, _only

HALF = 8  # cylinders on each bank of a V16
INSIDE = 0.03  # each strength's own standard error [-]
BANKS_APART = 0.36  # the standard error of one bank's level against the other's [-]


def _covariance() -> np.ndarray:
    """Each strength known to INSIDE on its own, and the banks' difference to BANKS_APART."""
    apart = np.concatenate([-np.ones(HALF), np.ones(HALF)]) / math.sqrt(2 * HALF)
    return np.diag(np.full(2 * HALF, INSIDE**2)) + BANKS_APART**2 * np.outer(apart, apart)


def test_bank_names_in_line_and_v() -> None:
    assert cylinder_banks(6, None) == [""] * 6
    vee = Vee(bank_angle_deg=60.0, rods="fork-and-blade")
    assert cylinder_banks(12, vee) == ["A"] * 6 + ["B"] * 6


def test_a_weak_cylinder_against_its_own_bank_carries_none_of_the_banks_level() -> None:
    strength = np.ones(2 * HALF)
    strength[0] = 0.7
    relative, _, contrast = relative_shares(strength, _covariance(), ["A"] * HALF + ["B"] * HALF)
    assert relative[0] == pytest.approx(0.7, rel=1e-12)
    # (s_0 - mean of A2..A8) / 1: the bank direction is the same on A1 and its mates, so only the
    # strengths' own errors remain, INSIDE^2 (1 + 1 / 7); to the arithmetic's rounding
    assert contrast[0] == pytest.approx(INSIDE * math.sqrt(1 + 1 / (HALF - 1)), rel=1e-9)
    # a B cylinder's share is of B's, untouched by the weak A1
    assert relative[HALF:] == pytest.approx(np.ones(HALF), rel=1e-12)


def test_against_both_banks_the_same_cylinder_carries_the_banks_level() -> None:
    strength = np.ones(2 * HALF)
    strength[0] = 0.7
    _, _, contrast = relative_shares(strength, _covariance(), None)
    # d = e_0 - (1/15) sum of the others; its part along the banks' direction is
    # -(1/4) (1 + 1/15) with the direction's entries 1/4: var = INSIDE^2 (1 + 1/15) + (0.36 * that)^2
    along = (1 + 1 / (2 * HALF - 1)) / math.sqrt(2 * HALF)
    expected = math.sqrt(INSIDE**2 * (1 + 1 / (2 * HALF - 1)) + (BANKS_APART * along) ** 2)
    assert contrast[0] == pytest.approx(expected, rel=1e-9)
    assert contrast[0] > 3 * INSIDE  # the reason a 70 % cylinder went unnamed at 4 contrast errors


def test_banks_at_different_levels_each_read_one() -> None:
    # bank B reads 40 % above bank A, beyond ALIKE of the engine's median: each bank is its own reference
    strength = np.concatenate([np.ones(HALF), np.full(HALF, 1.4)])
    assert 0.4 / 1.2 > ALIKE
    relative, _, _ = relative_shares(strength, _covariance(), ["A"] * HALF + ["B"] * HALF)
    assert relative == pytest.approx(np.ones(2 * HALF), rel=1e-12)


def test_one_bank_is_the_in_line_reference() -> None:
    rng = np.random.default_rng(7)
    strength = 1 + 0.05 * rng.standard_normal(6)
    strength[2] = 0.5
    a = rng.standard_normal((6, 6))
    covariance = 1e-3 * (a @ a.T + np.eye(6))
    one_bank = relative_shares(strength, covariance, [""] * 6)
    assert np.array_equal(np.asarray(one_bank), np.asarray(relative_shares(strength, covariance, None)))


def test_a_v_finding_names_its_bank_as_the_reference() -> None:
    balance = _balance([1.0] * 3 + [0.7] + [1.0] * 4, [1.0] * 3 + [0.7] + [1.0] * 4, 0.03, 0.03)
    names = ["A1", "A2", "A3", "A4", "B1", "B2", "B3", "B4"]
    balance = dataclasses.replace(balance, names=names, banks=["A"] * 4 + ["B"] * 4)
    found = [f for f in cylinder_findings(balance) if f.kind == "cylinder"]
    assert [f.subject for f in found] == ["cylinder A4"]
    assert "of bank A's cylinders that fire alike" in found[0].summary


def test_cylinders_firing_within_together_at_the_top_order_are_grouped() -> None:
    # two banks of four, B firing 0.5 deg after A's partner (a 90.5 deg V8 of 90 deg banks' intervals)
    a = np.radians([0.0, 180.0, 360.0, 540.0])
    angles = np.concatenate([a, a + np.radians(90.5)])
    assert fire_together(angles, 2, 4.0) == []  # 90.5 deg apart: at order 4, 362 deg, no pair
    angles[5] = angles[1] + np.radians(0.5)  # B2 fires 0.5 deg after A2
    assert fire_together(angles, 2, 4.0) == [(1, 5)]
    # at the boundary: k d against TOGETHER
    d = TOGETHER / 4.0
    assert fire_together(np.array([0.0, 0.999 * d, math.pi]), 2, 4.0) == [(0, 1)]
    assert fire_together(np.array([0.0, 1.001 * d, math.pi]), 2, 4.0) == []
    # a chain joins into one group; the cycle wraps (719.9 deg is 0.1 deg before 0)
    chain = np.radians([0.0, 3.0, 6.0, 719.9, 300.0])
    assert fire_together(chain, 2, 4.0) == [(0, 1, 2, 3)]


def test_a_pair_is_judged_as_one_and_spares_the_others() -> None:
    n = 2 * HALF
    pair = (0, HALF)  # A1 and B1 fire together: their difference is unknown
    apart = np.zeros(n)
    apart[list(pair)] = [1 / math.sqrt(2), -1 / math.sqrt(2)]
    covariance = np.diag(np.full(n, INSIDE**2)) + 10.0**2 * np.outer(apart, apart)
    strength = np.ones(n)
    strength[list(pair)] = [0.95, 1.05]  # the fit's split of a healthy pair, the difference unknown
    banks = ["A"] * HALF + ["B"] * HALF
    relative, _, contrast = relative_shares(strength, covariance, banks, [pair])
    assert relative[0] == relative[HALF] == pytest.approx(1.0, rel=1e-12)
    # the pair's mean against the fourteen others: INSIDE^2 (1/2 + 1/14), the difference's 10 cancels
    assert contrast[0] == contrast[HALF] == pytest.approx(INSIDE * math.sqrt(0.5 + 1 / 14), rel=1e-9)
    # an A cylinder against A2..A8 but A1: INSIDE^2 (1 + 1/6)
    assert contrast[1] == pytest.approx(INSIDE * math.sqrt(1 + 1 / (HALF - 2)), rel=1e-9)
    ungrouped = relative_shares(strength, covariance, banks, None)[2]
    # judged alone, A1 carries the 10 and, in its reference, A1's 10 / 7 reaches every cylinder of bank A
    assert ungrouped[0] > 5.0 and ungrouped[1] > 1.0


def test_a_pair_finding_names_both_cylinders() -> None:
    strength = [0.7, 1.0, 1.0, 1.0, 0.7, 1.0, 1.0, 1.0]
    names = ["A1", "A2", "A3", "A4", "B1", "B2", "B3", "B4"]
    balance = dataclasses.replace(
        _balance(strength, strength, 0.03, 0.03), names=names, banks=["A"] * 4 + ["B"] * 4, together=[(0, 4)]
    )
    found = [f for f in cylinder_findings(balance) if f.kind == "cylinder"]
    assert [f.subject for f in found] == ["cylinder A1 or cylinder B1"]
    assert "of the cylinders that fire alike" in found[0].summary
    assert "fire too nearly together" in found[0].summary


def test_where_every_cylinder_is_paired_each_pair_is_judged_against_the_other_pairs() -> None:
    n = 2 * HALF
    pairs = [(k, HALF + k) for k in range(HALF)]  # Ak with Bk: an 89.5 deg V16 of 90 deg intervals
    covariance = np.diag(np.full(n, INSIDE**2))
    for a, b in pairs:
        apart = np.zeros(n)
        apart[[a, b]] = [1 / math.sqrt(2), -1 / math.sqrt(2)]
        covariance += 10.0**2 * np.outer(apart, apart)
    strength = np.ones(n)
    strength[[2, HALF + 2]] = [0.4, 1.0]  # A3 at 40 %: its pair's mean 70 %
    strength[[5, HALF + 5]] = [1.3, 0.7]  # a healthy pair, split at random by the fit
    relative, _, contrast = relative_shares(strength, covariance, ["A"] * HALF + ["B"] * HALF, pairs)
    # the pair of A3 (mean 0.7) is outside ALIKE of the pairs' median (1.0): the reference is the six
    # others at 1.0, the healthy split pair among them
    assert relative[2] == relative[HALF + 2] == pytest.approx(0.7, rel=1e-12)
    assert relative[5] == pytest.approx(1.0, rel=1e-12)
    # a pair's mean against the six other whole pairs: INSIDE^2 (1/2 + 1/12) / 1^2, no 10 in it
    assert contrast[0] == pytest.approx(INSIDE * math.sqrt(0.5 + 1 / 12), rel=1e-9)


def test_one_group_of_every_cylinder_has_nothing_to_be_told_from() -> None:
    relative, error, contrast = relative_shares(np.array([0.9, 1.1]), 1e-4 * np.eye(2), None, [(0, 1)])
    assert relative == pytest.approx([1.0, 1.0]) and np.all(np.isinf(error)) and np.all(np.isinf(contrast))


@pytest.mark.parametrize("picked", [0, 4])  # A1 or B1
def test_a_pair_misfire_found_by_its_pattern_on_either_member_is_one_finding(
    picked: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The missing-impulse test may pick either member of a pair (their columns are nearly alike):
    its alarm stands in for the balance's finding on the pair (a warning: one member at 60 %),
    whichever member it picked."""
    from monitor.diagnosis import findings

    strength = [0.8, 1.0, 1.0, 1.0, 0.8, 1.0, 1.0, 1.0]
    names = ["A1", "A2", "A3", "A4", "B1", "B2", "B3", "B4"]
    balance = dataclasses.replace(
        _balance(strength, strength, 0.03, 0.03), names=names, banks=["A"] * 4 + ["B"] * 4, together=[(0, 4)]
    )
    missing = findings.Finding(
        kind="cylinder",
        subject="",
        severity="alarm",
        summary="",
        confidence=1.0,
        evidence=[{"cylinder": picked + 1, "measured": 0.05}],
    )
    monkeypatch.setattr(findings, "missing_firing_findings", lambda *_: [missing])
    found = [f for f in findings.cylinder_findings(balance) if f.kind == "cylinder"]
    assert found == [missing], [f.subject for f in found]


def test_a_pair_with_an_unknown_cycle_phase_names_every_candidate() -> None:
    strength = [0.6, 1.0, 1.0, 1.0, 0.6, 1.0, 1.0, 1.0]
    names = ["A1", "A2", "A3", "A4", "B1", "B2", "B3", "B4"]
    balance = dataclasses.replace(
        _balance(strength, strength, 0.03, 0.03), names=names, banks=["A"] * 4 + ["B"] * 4, together=[(0, 4)]
    )
    partners: list[int | None] = [3, None, None, 0, 7, None, None, 4]  # A1-A4 and B1-B4 a revolution apart
    (found,) = [f for f in cylinder_findings(balance, partners) if f.kind == "cylinder"]
    assert found.subject == "cylinder A1 or cylinder B1 or cylinder A4 or cylinder B4"
    assert "judged as one" in found.summary and "cycle phase is unknown" in found.summary


def _pair_at(together: float, error: float, contrast: float, model: float = 0.1) -> list[Finding]:
    """The findings on a V8 whose A1 and B1 fire together at ``together`` of the others, the model known
    to ``model`` (relative)."""
    relative = [together, 1.0, 1.0, 1.0, together, 1.0, 1.0, 1.0]
    balance = dataclasses.replace(
        _balance([1.0] * 8, relative, error, contrast),
        names=["A1", "A2", "A3", "A4", "B1", "B2", "B3", "B4"],
        banks=["A"] * 4 + ["B"] * 4,
        together=[(0, 4)],
        model_uncertainty=model,
    )
    return cylinder_findings(balance)


# (id, a pair's share together, its contrast error, expected severity, label and threshold): the pair's
# deficit read as one member's, 1 - 2 (1 - share), and judged by a cylinder's limits; its significance is
# the pair's own (the member's departure and errors are both twice the pair's)
PAIR: list[tuple[str, float, float, tuple[str, str, float] | None]] = [
    ("one member at 86 % is healthy", 0.93, 0.005, None),
    ("one member at 84 % is a warning", 0.92, 0.005, ("warning", WEAK, 0.85)),
    ("one member at 68 % (the pair at 84 %) is a warning", 0.84, 0.005, ("warning", WEAK, 0.85)),
    ("one member at 52 % is a warning", 0.76, 0.005, ("warning", WEAK, 0.85)),
    ("one member at 48 % is an alarm", 0.74, 0.005, ("alarm", WEAK, 0.5)),
    ("one member at 28 % is misfiring", 0.64, 0.005, ("alarm", MISFIRING, 0.5)),
    ("one member at 114 % is healthy", 1.07, 0.005, None),
    ("one member at 116 % is stronger", 1.08, 0.005, ("warning", STRONGER, 1.15)),
    # one member at 84 %: 16 % from the others, against 4 contrast errors of the member (2 x the pair's)
    ("a member's departure just beyond 4 of its errors", 0.92, 0.16 / 8 / 1.01, ("warning", WEAK, 0.85)),
    ("a member's departure just within 4 of its errors", 0.92, 0.16 / 8 / 0.99, None),
]


@pytest.mark.parametrize(
    ("together", "contrast", "expected"), [row[1:] for row in PAIR], ids=[row[0] for row in PAIR]
)
def test_a_pair_is_judged_as_one_member_at_the_pair_s_deficit(
    together: float, contrast: float, expected: tuple[str, str, float] | None
) -> None:
    """A pair that fires too nearly together reads one weak member at ``s`` as ``(s + 1) / 2``: a member
    at 68 %, weaker than a cylinder alone's warning limit, reads 84 % as a pair. The finding reads it
    back as one member's, so the pair's members are held to a cylinder's limits."""
    found = _pair_at(together, contrast, contrast)
    assert _only(found) == expected
    if found:
        (finding,) = found
        member = 1.0 - 2.0 * (1.0 - together)
        assert finding.subject == "cylinder A1 or cylinder B1"
        assert finding.evidence[0]["measured"] == pytest.approx(member, abs=1e-12)
        assert finding.evidence[0]["group_relative"] == together and finding.evidence[0]["group_size"] == 2
        assert f"together at {round(100 * together)} % of the others: one of them at " in finding.summary
        assert f"{round(100 * member)} % if the others fire as the reference" in finding.summary


@given(st.floats(-1.0, 2.0), st.integers(2, 4))
def test_a_member_read_back_makes_the_group_s_share(together: float, size: int) -> None:
    """Round trip: one member at ``one_of(s, n)`` among ``n - 1`` at the reference's level averages to
    ``s``; a cylinder alone is its own share, exactly."""
    assert (one_of(together, size) + size - 1) / size == pytest.approx(together, abs=1e-12)
    assert one_of(together, 1) == together


def test_a_cylinder_alone_beside_a_pair_is_read_as_itself() -> None:
    """On a V with one pair that fires together, a cylinder outside it is judged at its own share, and
    its finding says nothing of firing together."""
    relative = [1.0, 0.8, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]
    balance = dataclasses.replace(
        _balance([1.0] * 8, relative, 0.005, 0.005),
        names=["A1", "A2", "A3", "A4", "B1", "B2", "B3", "B4"],
        banks=["A"] * 4 + ["B"] * 4,
        together=[(0, 4)],
    )
    (found,) = cylinder_findings(balance)
    assert found.subject == "cylinder A2" and found.evidence[0]["measured"] == 0.8
    assert found.evidence[0]["group_size"] == 1
    assert "together" not in found.summary and "judged as one" not in found.summary


SEVERAL = "more than one of them weak, leaking or misfiring: together they lack more than a cylinder's firing"

# (id, a pair's share together, expected severity, label and threshold): below half the others the pair
# lacks more than one member's firing, which no single member can; beyond 4 of its errors (the member's
# contrast error, 2 x 1 %, beside the model's 10 %: 4 x 10.2 % = 40.8 %) more than one of them is weak
BEYOND_ONE: list[tuple[str, float, tuple[str, str, float]]] = [
    ("the pair at 51 %: one member at 2 %, misfiring", 0.51, ("alarm", MISFIRING, 0.5)),
    ("the pair at 50 %: one member at nothing, misfiring", 0.5, ("alarm", MISFIRING, 0.5)),
    ("the pair at 40 %: one member at -20 %, within its errors of nothing", 0.4, ("alarm", MISFIRING, 0.5)),
    ("the pair at 29.7 %: one member at -40.6 %, within its errors", 0.297, ("alarm", MISFIRING, 0.5)),
    ("the pair at 29.5 %: one member at -41 %, more than one member weak", 0.295, ("alarm", SEVERAL, 0.5)),
    ("the pair at 20 %: more than one member weak", 0.2, ("alarm", SEVERAL, 0.5)),
    ("the pair at nothing: both misfiring, more than one", 0.0, ("alarm", SEVERAL, 0.5)),
]


@pytest.mark.parametrize(
    ("together", "expected"), [row[1:] for row in BEYOND_ONE], ids=[row[0] for row in BEYOND_ONE]
)
def test_a_pair_lacking_more_than_one_member_s_firing_names_more_than_one(
    together: float, expected: tuple[str, str, float]
) -> None:
    """Read as one member's, a pair at 20 % would be a cylinder at -60 %: no cylinder fires less than
    nothing, so beyond 4 of its errors from a member missing whole the finding gives the pair's own
    share and says more than one of them is weak; within them it is one member misfiring."""
    found = _pair_at(together, 0.01, 0.01)
    assert _only(found) == expected
    (finding,) = found
    member = 1.0 - 2.0 * (1.0 - together)
    assert finding.evidence[0]["group_relative"] == together
    assert "judged as one" in finding.summary
    if expected[1] == SEVERAL:
        assert finding.evidence[0]["measured"] == 0.0
        # the pair's own share and error (1 %, 196 % of it rounds to 2 %), not a member's
        assert finding.summary.startswith(
            f"cylinder A1 or cylinder B1 together at {round(100 * together)} % +- 2 % of the cylinders that"
        )
        assert "one of them at" not in finding.summary
    else:
        assert finding.evidence[0]["measured"] == pytest.approx(member, abs=1e-12)
        assert finding.summary.startswith(f"cylinder A1 or cylinder B1 at {round(100 * member)} % +- 4 %")


def test_a_cylinder_alone_below_nothing_is_misfiring_not_several() -> None:
    """A cylinder alone whose share reads below nothing (noise about a misfire, or a model that carries
    its combustion short), even beyond what would make a pair "more than one", is one cylinder
    misfiring: only a group can lack more than one cylinder's firing."""
    relative = [1.0, -0.6, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]
    balance = dataclasses.replace(
        _balance([1.0] * 8, relative, 0.01, 0.01),
        names=["A1", "A2", "A3", "A4", "B1", "B2", "B3", "B4"],
        banks=["A"] * 4 + ["B"] * 4,
        together=[(0, 4)],
    )
    found = cylinder_findings(balance)
    assert _only(found) == ("alarm", MISFIRING, 0.5)
    assert found[0].subject == "cylinder A2" and found[0].evidence[0]["measured"] == -0.6


@pytest.mark.parametrize(
    ("together", "contrast", "model", "label"),
    [
        # the member at -31.25 %; its contrast error 2 x 3/128 beside the model's 1/16 makes 5/64: exactly 4
        # errors below nothing (every number here exact in binary), which is more than one member's deficit
        (0.34375, 3 / 128, 1 / 16, SEVERAL),
        (0.34375, 3 / 128 * 1.001, 1 / 16, MISFIRING),
        (0.34375, 3 / 128, 1 / 16 * 1.001, MISFIRING),
        # the member at -25 %, known exactly but for the model's 1/16: 4 of them
        (0.375, 0.0, 1 / 16, SEVERAL),
        # a member at nothing, known exactly: one member missing whole, not more
        (0.5, 0.0, 0.0, MISFIRING),
    ],
)
def test_more_than_one_is_named_from_4_errors_below_nothing(
    together: float, contrast: float, model: float, label: str
) -> None:
    """One member missing whole departs by one cylinder's combustion as the model carries it, known to
    the model's uncertainty: "more than one" needs 4 of the contrast's and the model's errors together."""
    assert _only(_pair_at(together, 0.01, contrast, model)) == ("alarm", label, 0.5)


@pytest.mark.parametrize(
    ("error", "headline"),
    [
        # 1.96 x 1.27 % = 2.49 %, 1.96 x 1.278 % = 2.505 %: the pair's own 95 % interval, rounded
        (0.0127, "cylinder A1 or cylinder B1 together at 20 % +- 2 % of the cylinders that fire alike ("),
        (0.01278, "cylinder A1 or cylinder B1 together at 20 % +- 3 % of the cylinders that fire alike ("),
    ],
)
def test_more_than_one_gives_the_pair_s_share_and_interval(error: float, headline: str) -> None:
    (found,) = _pair_at(0.204, error, 0.01)  # 20.4 %, rounded down
    assert found.summary.startswith(headline), found.summary
