"""The validation simulator's V engines: their draw, firing and physics, by routes of their own.

Nothing here uses the product's V models (``monitor.model.banks`` and its neighbours): the firing
angles are checked against the rule stated in words, the forces against the crank torque, a
V-twin's classical balance and finite differences of positions computed here.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from validation.simulator.engine import random_engine
from validation.simulator.vee_engine import random_vee_engine

VEE_SEEDS = (300000, 300001, 300002, 300003, 300004, 300005, 300011, 300017)


@pytest.mark.parametrize("seed", VEE_SEEDS)
def test_vee_engine_is_drawn_as_asked(seed: int) -> None:
    engine = random_vee_engine(seed)
    n, m = engine.cylinders, engine.throws
    assert n in (12, 14, 16, 18, 20) and m == n // 2
    rpm = engine.rated_speed * 30 / math.pi
    g = math.degrees(engine.bank_angle)
    if engine.engine_class.startswith("medium"):
        assert 45 <= g <= 60 and 500 <= rpm <= 1000
    else:
        assert 60 <= g <= 90 and 1200 <= rpm <= 1900
    assert engine.cycle_revolutions == 2
    assert engine.bearing_count == m + 1 == len(engine.bearing_positions)
    assert engine.rigid_inertia == pytest.approx(
        m * engine.throw_inertia + engine.flywheel_inertia + engine.driven_inertia
    )
    assert sorted(engine.firing_order) == list(range(1, n + 1)) and engine.firing_order[0] == 1
    # each cylinder between its throw's bearings, B the bank offset further along than A
    z = engine.cylinder_positions
    for c, (b1, b2) in enumerate(engine.throw_bearings):
        assert (b1, b2) == (c % m + 1, c % m + 2)
        assert engine.bearing_positions[b1 - 1] < z[c] < engine.bearing_positions[b2 - 1]
    assert np.allclose(z[m:] - z[:m], engine.bank_offset)
    assert (engine.rods == "fork-and-blade") == (engine.bank_offset == 0.0)


@pytest.mark.parametrize("seed", VEE_SEEDS)
def test_vee_firing_follows_the_bank_rule(seed: int) -> None:
    """Each bank fires evenly over 720 deg; each trailing cylinder the bank angle after its partner."""
    engine = random_vee_engine(seed)
    m, cycle = engine.throws, engine.cycle_angle
    angles = engine.firing_angles
    assert angles[0] == 0.0
    trailing = slice(m, 2 * m) if engine.leading_bank == "A" else slice(0, m)
    leading = slice(0, m) if engine.leading_bank == "A" else slice(m, 2 * m)
    gap = np.mod(angles[trailing] - angles[leading], cycle)
    assert np.allclose(gap, engine.bank_angle)
    for bank in (leading, trailing):
        spaced = np.sort(np.mod(angles[bank] - angles[bank][0], cycle))
        assert np.allclose(np.diff(np.r_[spaced, cycle]), cycle / m)
    # the firing order is the order of the angles
    assert np.all(np.diff(angles[np.asarray(engine.firing_order) - 1]) > 0)
    names = engine.cylinder_names
    assert names[:m] == [f"A{k}" for k in range(1, m + 1)] and names[m:] == [f"B{k}" for k in range(1, m + 1)]
    # the leading bank leans -g/2 (towards -x), the trailing +g/2
    assert np.allclose(engine.cylinder_leans[leading], -engine.bank_angle / 2)
    assert np.allclose(engine.cylinder_leans[trailing], engine.bank_angle / 2)


def test_in_line_engines_are_unchanged_by_the_vee() -> None:
    for seed in range(12):
        engine = random_engine(seed)
        assert not engine.is_vee and engine.throws == engine.cylinders
        assert engine.bearing_count == engine.cylinders + 1
        assert np.array_equal(engine.cylinder_leans, np.zeros(engine.cylinders))
