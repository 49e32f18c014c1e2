"""The cylinder balance's weights: a cylinder that fires unlike the model adds its own uncertainty, and
cylinders that fire together add theirs as one.

The orders fix only the sum of a group's strengths (two cylinders 0.5 deg apart have the same columns to
the resolution of the orders used): the least-squares fit may split a healthy pair as 5.8 and -3.8. The
weights must not read that split as two cylinders far from the model, which once made a healthy V16's
pair uncertain by 29 % (reduced chi-square 0.08) and its 10 s run inconclusive.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from monitor.diagnosis.balance import _Spread

ORDERS = 6


def _spread(groups: list[tuple[int, ...]]) -> _Spread:
    """Four cylinders whose combustion reaches six orders; cylinders 0 and 2 have the same columns (as a
    pair 0.5 deg apart has, to the orders' resolution). Only the unlike share is non-zero."""
    rng = np.random.default_rng(7)
    combustion = rng.normal(size=(4, ORDERS)) + 1j * rng.normal(size=(4, ORDERS))
    combustion[2] = combustion[0]
    nothing = np.zeros(ORDERS)
    return _Spread(
        se=nothing,
        model=nothing,
        calibration=nothing,
        inertia=nothing,
        unlike_share=np.full(ORDERS, 0.1),
        timed=nothing,
        uneven=nothing,
        wheel=nothing,
        factor=np.ones(ORDERS, dtype=np.complex128),
        transfer=np.ones((4, ORDERS), dtype=np.complex128),
        combustion=combustion,
        groups=groups,
    )


@given(st.floats(-10.0, 10.0), st.floats(-1.0, 1.0))
def test_a_pair_s_weight_depends_only_on_what_the_orders_fix(split: float, departure: float) -> None:
    """Any split of the pair's total departure gives the same weights: the orders see only the sum."""
    spread = _spread([(0, 2)])
    even = spread.at(np.array([1.0 + departure / 2, 1.0, 1.0 + departure / 2, 1.0]))
    uneven = spread.at(np.array([1.0 + split, 1.0, 1.0 + departure - split, 1.0]))
    # the same sum of the same columns: equal to the arithmetic's rounding of terms up to 10 times larger
    np.testing.assert_allclose(uneven, even, rtol=1e-9, atol=1e-12)


def test_a_healthy_pair_split_apart_adds_nothing() -> None:
    """A pair read as 5.8 and -3.8 (its sum as the model's) is as certain as a pair read at 1 and 1; read
    as two cylinders alone, the same split would add 0.1 x 4.8 of each column."""
    grouped, apart = _spread([(0, 2)]), _spread([])
    split = np.array([5.8, 1.0, -3.8, 1.0])
    np.testing.assert_allclose(grouped.at(split), 0.0, atol=1e-12)
    column = np.abs(grouped.combustion[0])
    np.testing.assert_allclose(apart.at(split), 0.1 * 4.8 * np.sqrt(2.0) * column, rtol=1e-12)


@pytest.mark.parametrize("groups", [[], [(0, 2)]])
def test_one_weak_member_adds_its_own_departure(groups: list[tuple[int, ...]]) -> None:
    """One member at 70 %, the others as the model: 10 % of 0.3 of its column, grouped or not."""
    spread = _spread(groups)
    weak = spread.at(np.array([0.7, 1.0, 1.0, 1.0]))
    np.testing.assert_allclose(weak, 0.1 * 0.3 * np.abs(spread.combustion[0]), rtol=1e-12)
