"""Short recordings across a load step whose speed never settles are judged, not left inconclusive.

The case is the validation simulator's (written apart from the product): a healthy nine-cylinder
four-stroke on a propeller curve, 10 s (ten cycles) across a load step from 66 % to 45 % load, its speed
falling from 272 to 220 rpm the whole time: no steady span to cut a segment from. Its baseline is three
healthy points across the engine's law, as a fleet calibrates it. Before the crank speed's drift was
taken out of each cycle (:mod:`monitor.signal.crank_speed`), the cylinders' differences read +-22 % (a
sawtooth in every order) and the spread of its speed made it inconclusive. A weak cylinder across such
a step is named.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from monitor.diagnosis import Diagnosis, calibrate
from monitor.diagnosis.at_point import diagnose_at_point
from monitor.diagnosis.operating_points import LOAD_UNCERTAINTY, OperatingPoints
from monitor.diagnosis.segments import diagnose_segments, segmentation_of
from monitor.model.engine import Engine, load_engine
from validation.simulator import Case, healthy_twin, law_loads, random_case

SEED = 200_014  # of the benchmark's off-point population: its class and loads are its own draw
LENGTH_S = 10.0
Judged = tuple[Case, Engine, OperatingPoints, Diagnosis]


def _against_three_points(seed: int, folder: Path) -> tuple[Case, Engine, OperatingPoints]:
    """A case of the off-point population, its engine, and its baseline of three healthy points across the
    engine's law (its healthy twin, and healthy twins at the law's lowest and highest load)."""
    case = random_case(seed, duration_s=LENGTH_S, operating="random")
    path = folder / "engine.toml"
    path.write_text(case.engine_toml)
    engine = load_engine(path)
    twins = [healthy_twin(case, seed=seed + 1_000_000)]
    twins += [
        healthy_twin(case, seed=seed + k * 1_000_000, load=load) for k, load in enumerate(law_loads(case), 2)
    ]
    return (
        case,
        engine,
        OperatingPoints.of([calibrate(t.recording, engine, load=t.load_given) for t in twins]),
    )


@pytest.fixture(scope="module")
def judged(tmp_path_factory: pytest.TempPathFactory) -> Judged:
    case, engine, points = _against_three_points(SEED, tmp_path_factory.mktemp("unsteady"))
    return case, engine, points, diagnose_at_point(case.recording, engine, points=points)


def test_the_case_is_a_healthy_load_step_whose_speed_never_settles(judged: Judged) -> None:
    case, engine, _, diagnosis = judged
    truth = case.truth
    assert truth["class"] == "healthy" and truth["operating_class"] == "load step"
    found = segmentation_of(diagnosis, engine)
    assert found.cycles < 20 and not found.segments
    angle_map = diagnosis.spectra.reference.angle_map
    turns = (
        2
        * math.pi
        * np.arange(math.ceil(angle_map.angles[0] / (2 * math.pi)), angle_map.angles[-1] / (2 * math.pi))
    )
    per_revolution = 2 * math.pi / np.diff(angle_map.time_at(turns))
    assert per_revolution.max() / per_revolution.min() > 1.2


def test_its_cylinders_are_resolved_and_it_is_healthy(judged: Judged) -> None:
    _, _, _, diagnosis = judged
    assert diagnosis.status == "healthy" and diagnosis.findings == []
    assert diagnosis.balance is not None
    # the balance's own errors: 5 % here (docs/diagnosis.md quotes it); with each cycle's drift left in,
    # 22 %. The limit leaves room for a per cent of change in the simulation and none for the old reading
    assert float(np.max(diagnosis.balance.contrast_error)) < 0.07


def test_its_impacts_are_judged_over_the_load_its_speed_reads_not_every_calibrated_load(
    judged: Judged,
) -> None:
    """Not told its load, a propeller engine's load is read off its speed on the points' speeds, as
    closely as an operator reads the log: the impact reference is the loudest over that load +- the
    stated load's uncertainty, not over every calibrated load (which hid worn bearings at low load)."""
    _, _, points, diagnosis = judged
    point = diagnosis.operating_point
    assert point["load_used_from"] == "speed"
    low, high = point["load_used"] - LOAD_UNCERTAINTY, point["load_used"] + LOAD_UNCERTAINTY
    (said,) = [n for n in diagnosis.notes if "at its loudest over the loads" in n]
    assert f"over the loads {low:.2f} to {high:.2f}" in said
    assert points.loads[0] < low and high < points.loads[-1]


def test_a_speed_spread_beyond_the_steady_limit_is_inconclusive_and_says_by_how_much(
    judged: Judged, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Its speed spreads by 9 % rms; with the limit at 5 % the same recording is no steady run."""
    case, engine, points, _ = judged
    monkeypatch.setattr(sys.modules["monitor.diagnosis.diagnose"], "STEADY", 0.05)
    diagnosis = diagnose_at_point(case.recording, engine, points=points)
    assert diagnosis.status == "inconclusive"
    (said,) = [n for n in diagnosis.notes if n.startswith("inconclusive: the speed was not steady")]
    assert "9 % rms" in said and "miss theirs by 1 %" in said


def test_a_weak_cylinder_across_a_load_step_too_short_to_cut_is_named(
    tmp_path_factory: pytest.TempPathFactory,
) -> None:
    """Case 200010: a nine-cylinder four-stroke on a propeller curve, 10 s across a step from 84 % to 42 %
    load, cylinder 9 releasing 54 % of a healthy one's heat. Diagnosed as ``compare`` does (at its point,
    then per segment): no two segments, the change told with three cycles a side, and cylinder 9 named
    alone, with a note where the point changed. Before the drift was taken out, strengths read across a
    change were left out (healthy cylinders read 40 % to 151 %), and this case was inconclusive."""
    case, engine, points = _against_three_points(200_010, tmp_path_factory.mktemp("weak"))
    assert case.truth["class"] == "weak" and case.truth["cylinder"] == 9
    assert case.truth["operating_class"] == "load step"
    whole = diagnose_at_point(case.recording, engine, points=points)
    found = diagnose_segments(case.recording, engine, whole, baseline=points)
    assert found.segments == ()
    said = found.as_one()
    assert [f.subject for f in said.findings] == ["cylinder 9"] and said.status == "warning"
    assert said.notes[0].startswith("the operating point changes inside the recording")
