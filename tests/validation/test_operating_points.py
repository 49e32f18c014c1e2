"""The validation simulator off the baseline's point: load steps, the propeller curve, crank speed alone.

Each case is checked by a route other than the one that set it up: a load step's loads are read
back from the IMEP of the cycles each side of it (the crank run's firings, not the draw), the
propeller curve from the crank speed the dynamics settled at against that IMEP, a crank-speed-only
installation from the channels the recording holds.
"""

from __future__ import annotations

import numpy as np
import pytest

from validation.simulator import healthy_twin, law_loads, random_case, random_engine
from validation.simulator.operating import OperatingPoint, propeller_load

# Engines of 300 rpm or more (not the slow two-strokes): a few seconds hold tens of cycles each side
# of a step. The first seeds from 0 with the load type asked, not chosen by hand.
LENGTH_S = 6.0


def first_seed(load_type: str, *, after: int = 0) -> int:
    """The first seed from ``after`` whose engine drives ``load_type`` and is not a slow two-stroke."""
    seed = after
    while True:
        engine = random_engine(seed)
        if engine.load_type == load_type and engine.engine_class != "slow two-stroke":
            return seed
        seed += 1


@pytest.mark.parametrize("load_type", ["propeller", "generator"])
def test_a_drawn_load_step_steps_inside_the_recording(load_type: str) -> None:
    case = random_case(first_seed(load_type), duration_s=LENGTH_S, fault=None, operating="load step")
    truth = case.truth
    assert truth["operating_class"] == "load step" and truth["load_type"] == load_type
    assert 0.3 * LENGTH_S <= truth["step_time_s"] <= 0.7 * LENGTH_S
    before, after = truth["segment_loads"]
    # before the step the engine runs at the first load drawn: the cycle-to-cycle scatter of the
    # heat release (<= 4 % per firing, averaged over tens of firings of every cylinder): 2 % of rated
    assert before == pytest.approx(truth["test_loads"][0], abs=0.02)
    # the mean load (the one told) lies between the two sides', weighted by the time at each
    assert min(before, after) - 0.01 <= truth["true_load"] <= max(before, after) + 0.01


STEP_LENGTH_S = 16.0
STEP_AT = 0.25  # of the recording: 4 s at the first load, then 12 s at the second
SETTLED_S = 10.0  # the last 6 s: a governor's PI has settled (about 15 cycles; 3 s at 300 rpm)


@pytest.mark.parametrize("load_type", ["propeller", "generator"])
@pytest.mark.parametrize("loads", [(0.85, 0.4), (0.4, 0.9)], ids=["down", "up"])
def test_a_load_step_runs_the_loads_asked_each_side_of_it(load_type: str, loads: tuple[float, float]) -> None:
    point = OperatingPoint("load step", loads, step_fraction=STEP_AT)
    case = random_case(first_seed(load_type), duration_s=STEP_LENGTH_S, fault=None, operating=point)
    start = np.array(case.truth["cycle_start_s"])
    load = np.array(case.truth["cycle_loads"])
    ends = start + np.diff(start, append=STEP_LENGTH_S)
    # read back from the IMEP of the crank run's firings each side: the cycle-to-cycle scatter of
    # the heat release averaged over tens of firings, and a governor's residual swing (1.5 % seen
    # on a 0.8 to 0.4 step): 2 % of rated
    assert load[ends <= STEP_AT * STEP_LENGTH_S].mean() == pytest.approx(loads[0], abs=0.02)
    assert load[start >= SETTLED_S].mean() == pytest.approx(loads[1], abs=0.02)


def test_a_propeller_runs_on_its_curve() -> None:
    seed = first_seed("propeller")
    case = random_case(seed, duration_s=LENGTH_S, fault=None, operating="propeller curve")
    truth = case.truth
    engine = random_engine(seed)
    speed_fraction = truth["mean_speed_rpm"] / truth["rated_speed_rpm"]
    assert 0.6 - 0.01 <= speed_fraction <= 1.0 + 0.01  # drawn 60-100 %
    # the speed the crank settled at, against the load its cylinders delivered: the propeller law
    # (net torque as speed squared); the crank's cyclic irregularity and the table's speed guess
    # leave the two within 1 %
    assert truth["true_load"] == pytest.approx(propeller_load(engine, speed_fraction), rel=0.01)
    # and off the baseline's point, which the twin keeps
    twin = healthy_twin(case, seed=seed + 1_000_000)
    assert twin.truth["operating_class"] == "baseline point"
    assert twin.truth["true_load"] == pytest.approx(truth["baseline_load"], abs=0.02)


@pytest.mark.parametrize("load_type", ["propeller", "generator"])
def test_twins_at_the_ends_of_the_law_run_there(load_type: str) -> None:
    """The lowest and highest loads of the engine's law, read back from the twins' own cycles (within
    the 2 % of the heat release's scatter), and on the propeller curve at 60 % and 100 % speed."""
    seed = first_seed(load_type)
    case = random_case(seed, duration_s=LENGTH_S, fault=None, operating="random")
    lowest, highest = law_loads(case)
    engine = random_engine(seed)
    if load_type == "propeller":
        assert (lowest, highest) == (propeller_load(engine, 0.6), propeller_load(engine, 1.0))
    else:
        assert (lowest, highest) == (0.25, 1.0)
    for k, load in enumerate((lowest, highest), start=2):
        twin = healthy_twin(case, seed=seed + k * 1_000_000, load=load)
        assert twin.truth["class"] == "healthy" and twin.truth["operating_class"] == "baseline point"
        assert twin.truth["true_load"] == pytest.approx(load, abs=0.02)
        assert twin.recording.engine_id == case.recording.engine_id
    if load_type == "propeller":  # the speed its curve gives: 60 % of rated at the lowest load
        low = healthy_twin(case, seed=seed + 2_000_000, load=lowest)
        assert low.truth["mean_speed_rpm"] / low.truth["rated_speed_rpm"] == pytest.approx(0.6, abs=0.01)


def test_a_generator_runs_at_rated_speed_at_any_load() -> None:
    case = random_case(first_seed("generator"), duration_s=LENGTH_S, fault=None, operating="constant speed")
    truth = case.truth
    assert 0.25 - 0.02 <= truth["true_load"] <= 1.0 + 0.02
    # the governor holds the set point within its droop-free PI's residual: 0.5 %
    assert truth["mean_speed_rpm"] == pytest.approx(truth["rated_speed_rpm"], rel=0.005)


def test_a_crank_speed_only_engine_has_no_bearing_channel() -> None:
    seed = first_seed("propeller")
    case = random_case(seed, duration_s=LENGTH_S, fault="random", operating="crank speed only")
    twin = healthy_twin(case, seed=seed + 1_000_000)
    for recording in (case.recording, twin.recording):
        assert recording.channels  # the angle sensors
        assert not [c for c in recording.channels if c.location.startswith("main bearing")]
    assert case.truth["class"] in ("healthy", "misfire", "weak")  # no bearing or sensor fault to see
    assert case.truth["sensor_bearings"] == []


def test_the_baseline_point_is_the_default_and_the_twins_point() -> None:
    case = random_case(5, duration_s=2.0, fault=None)
    assert case.truth["operating_class"] == "baseline point"
    assert case.truth["test_loads"] == [case.truth["baseline_load"]]
    assert case.truth["step_time_s"] is None
    assert case.truth["charge_law"] == "turbocharged"


def test_an_operating_class_that_does_not_fit_the_engine_is_refused() -> None:
    with pytest.raises(ValueError, match="operating"):
        random_case(first_seed("generator"), duration_s=2.0, operating="propeller curve")


def test_a_held_boost_fires_harder_than_a_turbocharger_at_part_load() -> None:
    seed = first_seed("generator")
    peaks = {}
    for law in ("turbocharged", "held"):
        point = OperatingPoint("constant speed", (0.3,), charge_law=law)
        case = random_case(seed, duration_s=2.0, fault=None, operating=point)
        assert case.truth["charge_law"] == law
        assert case.truth["true_load"] == pytest.approx(0.3, abs=0.02)  # the same load either way
        peaks[law] = max(case.truth["peak_pressure_bar"])
    # at 30 % load the turbocharger gives 30 % of the rated boost, the held charge all of it: the
    # compression starts from a denser charge, so the peak rises, by far more than the 1-2 % scatter
    assert peaks["held"] > 1.1 * peaks["turbocharged"]
