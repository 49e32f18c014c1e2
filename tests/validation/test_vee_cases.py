"""V engines' validation cases: the truth names cylinders by bank, as the product's findings do."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from benchmarks.diagnosis_validation import Outcome, at_point
from benchmarks.diagnosis_vee import vee_section
from benchmarks.judging import classify, named
from validation.simulator import Case, description_engine, healthy_twin, law_loads, random_case
from validation.simulator.vee_engine import random_vee_engine


@pytest.fixture(scope="module")
def misfire() -> Case:
    return random_case(300007, duration_s=1.5, fault="misfire", vee=True)


def test_vee_misfire_case_names_its_cylinder_by_bank(misfire: Case) -> None:
    truth = misfire.truth
    engine = random_vee_engine(300007)
    assert truth["vee"] is True and truth["cylinders"] == engine.cylinders
    index = truth["cylinder_index"]
    assert truth["cylinder"] == engine.cylinder_names[index - 1]
    assert truth["cylinder"][0] in "AB" and truth["cylinder_names"] == engine.cylinder_names
    imep = np.asarray(truth["imep_bar"])
    others = np.delete(imep, index - 1)
    assert imep[index - 1] < 0.2 * others.mean()  # the motored cylinder, by its index
    assert description_engine(misfire.engine_toml).cylinder_names[index - 1] == truth["cylinder"]
    assert misfire.recording.engine_id == engine.ident
    assert all(
        c.name.endswith("-vertical") and 1 <= int(c.name[2:].split("-")[0]) <= engine.throws + 1
        for c in misfire.recording.channels
        if c.name.startswith("mb")
    )


def test_vee_twin_is_the_same_v_engine(misfire: Case) -> None:
    twin = healthy_twin(misfire, seed=1_300_007)
    assert twin.truth["vee"] is True and twin.truth["class"] == "healthy"
    assert twin.engine_toml == misfire.engine_toml
    low, high = law_loads(misfire)
    assert 0 < low < high <= 1.0 + 1e-9


def test_findings_on_a_vee_cylinder_match_the_truth() -> None:
    finding = SimpleNamespace(kind="cylinder", subject="cylinder B3", summary="low torque (misfiring)")
    assert classify(finding) == ("misfire", "B3")
    truth = {"class": "misfire", "cylinder": "B3"}
    assert named(truth, [("misfire", "B3", "alarm")])
    assert not named(truth, [("misfire", "A3", "alarm")])


def test_a_finding_on_cylinders_that_fire_together_names_each_of_them() -> None:
    """Case 310032 (V20, B4 misfiring): the product names "cylinder A9 or cylinder B4", which fire too
    nearly together for the crank speed to tell apart; the benchmark read only the first name and
    counted an alarm on the wrong cylinder."""
    finding = SimpleNamespace(
        kind="cylinder",
        subject="cylinder A9 or cylinder B4",
        summary="cylinder A9 or cylinder B4 at -23 % +- 16 % of the others' firing impulse (misfiring; ...",
    )
    assert classify(finding) == ("misfire", "A9 or B4")
    assert named({"class": "misfire", "cylinder": "B4"}, [("misfire", "A9 or B4", "alarm")])
    assert named({"class": "misfire", "cylinder": "A9"}, [("misfire", "A9 or B4", "alarm")])
    assert not named({"class": "misfire", "cylinder": "B9"}, [("misfire", "A9 or B4", "alarm")])


def _outcome(truth: str, named: bool, vee: bool, exit_code: int, rods: str = "side-by-side") -> Outcome:
    return Outcome(
        300000, 10.0, 12, "four-stroke", 750.0, truth, "B3", math.nan, "alarm", exit_code, truth, named,
        exit_code == 2, "", 1.0, vee=vee, rods=rods if vee else "",
    )  # fmt: skip


def test_vee_outcomes_have_their_own_rows() -> None:
    outcomes = [_outcome("misfire", True, True, 2), _outcome("healthy", True, True, 0)]
    outcomes += [_outcome("misfire", False, False, 2)]
    assert at_point(outcomes) == outcomes[2:]
    lines = vee_section(outcomes)
    assert lines[0] == "## V engines"
    assert any(line.startswith("| misfire | 10 | 1 | 1/1 (100 %) |") for line in lines)
    assert vee_section(outcomes[2:]) == []
    # by rods: a column per arrangement the run had, each over its own cases
    outcomes += [_outcome("misfire", False, True, 1, rods="articulated")]
    lines = vee_section(outcomes)
    head = next(line for line in lines if line.startswith("| what | required | side-by-side"))
    assert head == "| what | required | side-by-side (2 cases) | articulated (1 cases) |"
    misfire = next(line for line in lines[lines.index(head) :] if line.startswith("| misfire named"))
    assert misfire.endswith("| 1/1 (100.0 %): meets | 0/1 (0.0 %): **fails** |")


def test_vee_worn_bearing_knocks_where_its_planar_load_is_least() -> None:
    case = random_case(300003, duration_s=2.0, fault="worn_bearing", vee=True)
    truth = case.truth
    assert truth["class"] == "worn_bearing" and truth["reversal"] in ("plane", "minimum")
    assert truth["burst_count"] > 0 and truth["channel"] == f"mb{truth['bearing']}-vertical"


def test_a_weak_cylinder_of_a_v20_is_named_against_its_own_bank() -> None:
    """Seed 300040: a V20 at 765 rpm, 10 s, one cylinder at 73 % of its heat release. Against both
    banks its share carried the banks' poorly known levels and it went unnamed (exit 0); against its
    own bank it is a warning on the right cylinder."""
    from benchmarks.diagnosis_validation import run_ways

    (outcome,) = run_ways(300040, 10.0, "baseline point", (True,), vee=True)
    assert outcome.truth == "weak" and outcome.strength == pytest.approx(0.73, abs=0.01)
    assert outcome.named and outcome.exit_code == 1, outcome.findings
    assert abs(outcome.share - outcome.strength) < 0.1  # the share read, against the heat release put in
