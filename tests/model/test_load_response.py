"""The load response on a real engine: the crank speed's half orders predicted from the measured pressure.

The TU/e 4GB10 single-cylinder rig at no, half and full load (../shared/external/tue-4gb10, skipped
where that folder is absent), through :mod:`benchmarks.rig_4gb10`: a route apart from the product's
model (the measured pressure, pegged by the compression polytrope, times the exact slider-crank lever
through a rigid crank), with the product's measured side giving the crank speed.
"""

from __future__ import annotations

import pytest

from benchmarks.rig_4gb10 import RUNS, OrderRatio, RigRun, order_ratios, rig_runs
from tests.conftest import shared_path


@pytest.fixture(scope="module")
def runs() -> list[RigRun]:
    return rig_runs(shared_path("external", "tue-4gb10"))


@pytest.fixture(scope="module")
def ratios(runs: list[RigRun]) -> list[OrderRatio]:
    return order_ratios(runs, (0.5, 1.5, 2.5))


def test_half_orders_follow_the_load_as_the_pressure_predicts(ratios: list[OrderRatio]) -> None:
    """Each run's speed orders 0.5, 1.5 and 2.5 over the full-load runs' mean: predicted from the
    pressure and measured agree within three standard errors of the measured ratio (from the
    cycle-to-cycle scatter of both runs' 11 to 13 cycles; the largest seen is 2.3 at order 0.5, half
    load). Order 3.5 is left out: the rigid crank under-predicts it at half load by 3.3 standard errors
    (docs/load-response.md)."""
    assert len(ratios) == 3 * len(RUNS)
    for ratio in ratios:
        assert abs(ratio.predicted - ratio.measured) <= 3 * ratio.error, ratio


def test_the_loads_are_told_apart(ratios: list[OrderRatio]) -> None:
    """The comparison can fail: the orders at no load are about a third of full load's, at half load
    about two thirds, far outside the errors; a prediction blind to the pressure (ratio 1) would miss."""
    for ratio in ratios:
        if ratio.name.startswith("E10NOLOAD"):
            assert ratio.measured < 0.4 and ratio.predicted < 0.4
            assert 1 - ratio.measured > 10 * ratio.error
        elif ratio.name.startswith("E10HALFLOAD"):
            assert 0.55 < ratio.measured < 0.75 and 0.55 < ratio.predicted < 0.75


def test_the_pegged_pressure_is_a_throttled_engines(runs: list[RigRun]) -> None:
    """The polytrope's peg puts the pressure at BDC of intake (in volts above zero pressure, so for any
    positive gain) lower as the throttle closes: no load below half, half below full. That is what a
    throttled spark-ignition engine's manifold does, and nothing in the peg forces it."""
    bdc = {run.name: run.bdc for run in runs}
    assert bdc["E10NOLOAD1"] < min(bdc["E10HALFLOAD1"], bdc["E10HALFLOAD2"])
    assert max(bdc["E10HALFLOAD1"], bdc["E10HALFLOAD2"]) < min(bdc["E10FULLLOAD1"], bdc["E10FULLLOAD2"])
