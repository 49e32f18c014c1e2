"""V engines described: bank-named cylinders, firing angles from the order and the bank angle, throws and
bearings shared by two cylinders, and the predicted free forces of a V through the whole model.

The firing angles are checked against angles worked out by hand from the bank geometry (each throw's
trailing cylinder a bank angle after its partner); the free forces against the classical balance of a
90 deg cross-plane V8 (a turning primary moment of ``sqrt(10) m r w^2 a`` and nothing else at orders 1
and 2) and of a 90 deg V-twin, computed by :func:`monitor.model.predicted.predict_orders` from the
description, not from one cylinder's forces as tests/model/test_vee.py does.
"""

from __future__ import annotations

import copy
import math
import re
from typing import Any

import numpy as np
import pytest

from monitor.errors import EngineDescriptionError
from monitor.model.banks import ANGLE_TOLERANCE_DEG, to_engine_frame
from monitor.model.crankshaft import EngineModel
from monitor.model.engine import Engine, parse_engine
from monitor.model.predicted import predict_orders

PISTON_KG, RADIUS, SPEED_RPM = 50.0, 0.1, 1000.0  # [kg], [m], [rpm]
SPACING = 0.5  # throw spacing along the shaft [m]
TWELVE = ["A1", "B1", "A5", "B5", "A3", "B3", "A6", "B6", "A2", "B2", "A4", "B4"]


def _vee(cylinders: int, bank_deg: float, order: list[str], **vee: Any) -> dict[str, Any]:
    """A V four-stroke whose moving mass is the pistons' alone (a rod of a milligram, no unbalance)."""
    return {
        "id": "test-vee",
        "name": "test V engine",
        "cycle": "four-stroke",
        "cylinders": cylinders,
        "geometry": {
            "bore_m": 0.1,
            "stroke_m": 2 * RADIUS,
            "rod_ratio": 0.25,
            "cylinder_pitch_m": SPACING,
        },
        "masses": {
            "piston_assembly_kg": PISTON_KG,
            "conrod_kg": 1e-6,
            "conrod_cg_from_piston_pin_m": 0.2,
            "conrod_inertia_kgm2": 1e-9,
        },
        "firing": {"order": order},
        "operation": {"rated_speed_rpm": SPEED_RPM},
        "combustion": {
            "rated_imep_bar": 20.0,
            "compression_ratio": 15.0,
            "intake_pressure_bar": 3.0,
            "inlet_closing_deg": -200.0,
            "exhaust_opening_deg": 120.0,
        },
        "vee": {"bank_angle_deg": bank_deg, "rods": "fork-and-blade", **vee},
    }


def _angles(engine: Engine) -> dict[str, float]:
    return dict(zip(engine.cylinder_names, np.degrees(engine.firing_angles).round(9), strict=True))


def test_a_v12_names_its_cylinders_by_bank_and_shares_its_throws_and_bearings() -> None:
    engine = parse_engine(_vee(12, 60.0, TWELVE, rods="side-by-side", bank_offset_m=0.07))
    assert engine.cylinder_names == [f"A{k}" for k in range(1, 7)] + [f"B{k}" for k in range(1, 7)]
    assert engine.throws == 6 and engine.bearing_count == 7
    assert engine.throw_bearings[0] == engine.throw_bearings[6] == (1, 2)
    assert engine.throw_bearings[5] == engine.throw_bearings[11] == (6, 7)
    np.testing.assert_allclose(engine.cylinder_positions[:6], SPACING * np.arange(6), atol=1e-15)
    np.testing.assert_allclose(engine.cylinder_positions[6:], SPACING * np.arange(6) + 0.07, atol=1e-15)
    np.testing.assert_allclose(np.degrees(engine.cylinder_axes), [-30.0] * 6 + [30.0] * 6, atol=1e-12)
    # each bearing carries the two cylinders of each throw beside it: one rod's worth from each throw's
    # pair, 1 at the ends (the shares of a pair add to round-off)
    np.testing.assert_allclose(
        engine.bearing_share.sum(axis=1), [1.0, 2.0, 2.0, 2.0, 2.0, 2.0, 1.0], atol=1e-12
    )


@pytest.mark.parametrize("offset", [0.07, -0.05, 0.0])
def test_each_rod_of_a_side_by_side_throw_is_shared_by_its_own_place_on_the_pin(offset: float) -> None:
    """The statics of one throw solved on its own: bearings a pitch apart, the throw's middle midway,
    its rods half the bank offset either side; for a unit force on one rod, the two reactions from
    force and moment balance (np.linalg.solve) are that rod's shares. A rod's force differs from its
    partner's in direction and time, so splitting their sum at the middle (half each) is wrong by
    offset / (2 pitch) of each rod's force; fork-and-blade (offset 0) is half each."""
    engine = parse_engine(_vee(12, 60.0, TWELVE, rods="side-by-side", bank_offset_m=offset))
    for c in range(engine.cylinders):
        throw = engine.cylinder_throw[c]
        b1, b2 = engine.throw_bearings[c]
        z1, z2 = throw * SPACING, (throw + 1) * SPACING  # the bearings around throw k, its middle midway
        z = 0.5 * (z1 + z2) + (offset / 2 if engine.cylinder_names[c][0] == "B" else -offset / 2)
        # R1 + R2 = 1 (forces), R2 (z2 - z1) = 1 (z - z1) (moments about bearing b1)
        reactions = np.linalg.solve([[1.0, 1.0], [0.0, z2 - z1]], [1.0, z - z1])
        np.testing.assert_allclose(engine.bearing_share[[b1 - 1, b2 - 1], c], reactions, rtol=0, atol=1e-12)
        others = np.delete(engine.bearing_share[:, c], [b1 - 1, b2 - 1])
        assert not others.any()


def test_a_v12_of_60_deg_fires_evenly_every_60_deg() -> None:
    """A 60 deg V12 whose B cylinders fire right after their A partners: even firing, 720 / 12."""
    angles = _angles(parse_engine(_vee(12, 60.0, TWELVE)))
    for position, name in enumerate(TWELVE):
        assert angles[name] == pytest.approx(60.0 * position)


def test_a_v12_of_55_deg_fires_each_bank_evenly_at_uneven_intervals() -> None:
    """55 deg: even firing would put each pair 60 deg apart, so each bank fires as an in-line six (every
    120 deg, A1-A5-A3-A6-A2-A4) and each B cylinder 55 deg after its partner: intervals 55, 65, 55, ..."""
    angles = _angles(parse_engine(_vee(12, 55.0, TWELVE)))
    for position, name in enumerate(TWELVE):
        expected = 120.0 * (position // 2) + (55.0 if name.startswith("B") else 0.0)
        assert angles[name] == pytest.approx(expected)


def test_the_leading_bank_decides_which_cylinder_of_a_throw_fires_first() -> None:
    """A cross-plane 90 deg V8 (throws 0, 90, 270, 180 deg), as makers number it with the B bank ahead:
    B4 fires 90 deg after A1, B2 90 deg after that..., every 90 deg; A leading, the order is refused."""
    order = ["A1", "B4", "B2", "A2", "B3", "A3", "A4", "B1"]
    angles = _angles(parse_engine(_vee(8, 90.0, order, leading_bank="B")))
    for position, name in enumerate(order):
        assert angles[name] == pytest.approx(90.0 * position)
    with pytest.raises(EngineDescriptionError, match=r"throw 1 carries A1 and B1|neither even firing"):
        parse_engine(_vee(8, 90.0, order))


def test_an_order_the_banks_cannot_fire_is_refused_naming_what_to_give() -> None:
    order = ["A1", "A2", "B1", "B2"]  # B1 between A2 and B2 cannot sit 90 deg after A1 in either bank's way
    with pytest.raises(EngineDescriptionError, match=r"neither even firing.*give firing.angles_deg"):
        parse_engine(_vee(4, 90.0, order))


def test_a_v_twin_order_that_does_not_say_the_revolution_is_refused() -> None:
    """90 deg V-twin: B1 may fire 90 deg after A1 or 450; the order A1, B1 says neither."""
    with pytest.raises(EngineDescriptionError, match=r"2 ways of firing each bank evenly"):
        parse_engine(_vee(2, 90.0, ["A1", "B1"]))
    data = _vee(2, 90.0, ["A1", "B1"])
    data["firing"]["angles_deg"] = [0.0, 450.0]
    assert _angles(parse_engine(data)) == {"A1": 0.0, "B1": 450.0}


def test_given_angles_must_put_each_throw_a_bank_angle_apart() -> None:
    data = _vee(2, 90.0, ["A1", "B1"])
    data["firing"]["angles_deg"] = [0.0, 450.0 + 10 * ANGLE_TOLERANCE_DEG]
    with pytest.raises(
        EngineDescriptionError, match=r"throw 1 carries A1 and B1.*expected the bank angle 90"
    ):
        parse_engine(data)


@pytest.mark.parametrize(
    ("change", "fragment"),
    [
        (lambda d: d.update(cylinders=7), "expected an even number"),
        (lambda d: d["firing"].update(order=[1, 2, 3, 4]), "permutation of the cylinders A1..A2 and B1..B2"),
        (
            lambda d: d["vee"].update(rods="articulated"),
            "rods = 'articulated' needs knuckle_radius_m, knuckle_angle",
        ),
        (lambda d: d["vee"].update(knuckle_radius_m=0.05), "knuckle_radius_m: for rods = 'articulated' only"),
        (
            lambda d: d["vee"].update(
                {**_SLAVE, "slave_rod_length_m": 0.11, "slave_rod_cg_from_piston_pin_m": 0.05}
            ),
            "cannot reach its piston at every crank angle",
        ),
        (
            lambda d: d["vee"].update({**_SLAVE, "slave_rod_cg_from_piston_pin_m": 0.5}),
            "expected less than the slave rod's length",
        ),
        (lambda d: d["vee"].update(bank_offset_m=0.05), "fork-and-blade rods: both rods run in one plane"),
        (lambda d: d["vee"].update(bank_angle_deg=0.0), "expected 1 <= value <= 180 deg"),
        (lambda d: d["bearings"].update(throws=[[1, 2]] * 4), "expected 2, one a throw"),
    ],
)
def test_bad_vee_descriptions_are_refused_with_the_rule(change: Any, fragment: str) -> None:
    data = copy.deepcopy(_vee(4, 90.0, ["A1", "B1", "A2", "B2"]))
    data["bearings"] = {}
    change(data)
    with pytest.raises(EngineDescriptionError, match=re.escape(fragment)):
        parse_engine(data)


# a master-and-slave rod for _vee's crank (radius 0.05 m, rod 0.2 m): the knuckle pin a quarter of the
# rod from the crank pin, the slave rod three quarters of the master's
_SLAVE = {
    "rods": "articulated",
    "knuckle_radius_m": 0.05,
    "knuckle_angle_deg": 45.0,
    "slave_rod_length_m": 0.15,
    "slave_rod_kg": 1e-6,
    "slave_rod_cg_from_piston_pin_m": 0.1,
}


def test_an_articulated_v_is_described_its_trailing_bank_the_slaves() -> None:
    """With its slave rod and knuckle pin given, an articulated V is accepted: its trailing bank hangs on
    the leading bank's master rods, and their own TDCs lie off their firing angles by the slave's
    offset."""
    from monitor.model.banks import slave_cylinders, tdc_offsets

    engine = parse_engine(_vee(4, 90.0, ["A1", "B1", "A2", "B2"], **_SLAVE))
    assert engine.articulated is not None
    assert engine.articulated.bank_angle == pytest.approx(math.pi / 2)
    assert slave_cylinders(engine.cylinders, engine.vee).tolist() == [False, False, True, True]
    offset = engine.articulated.stroke().tdc_offset
    assert abs(offset) > math.radians(0.5)  # the articulation moves the slave's TDC
    assert tdc_offsets(engine.cylinders, engine.vee, engine.articulated).tolist() == [
        0.0,
        0.0,
        offset,
        offset,
    ]
    led_by_b = parse_engine(_vee(4, 90.0, ["B1", "A1", "B2", "A2"], leading_bank="B", **_SLAVE))
    assert slave_cylinders(4, led_by_b.vee).tolist() == [True, True, False, False]


def _free(engine: Engine) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    predicted = predict_orders(EngineModel(engine), crank_speed=SPEED_RPM * math.pi / 30, load=0.0)
    return predicted.orders, predicted.free_force, predicted.free_moment


def test_a_cross_plane_v8_through_the_model_has_only_the_root_10_primary_moment() -> None:
    """The classical balance of a 90 deg cross-plane V8 (tests/model/test_vee.py derives it): no free
    force at orders 1 and 2, no second-order moment, a primary moment ``sqrt(10) m r w^2 a`` turning
    with the crank. Tolerance 1e-6 of the primary: the milligram rod's share (2e-8 of the piston's)
    and the grid's aliasing are far below it."""
    order = ["A1", "B4", "B2", "A2", "B3", "A3", "A4", "B1"]
    orders, force, moment = _free(parse_engine(_vee(8, 90.0, order, leading_bank="B")))
    primary = PISTON_KG * RADIUS * (SPEED_RPM * math.pi / 30) ** 2
    for k in (1.0, 2.0):
        at = int(np.argmin(np.abs(orders - k)))
        assert np.all(np.abs(force[:, at]) < 1e-6 * primary)
    second = int(np.argmin(np.abs(orders - 2.0)))
    assert np.all(np.abs(moment[:, second]) < 1e-6 * primary * SPACING)
    first = int(np.argmin(np.abs(orders - 1.0)))
    np.testing.assert_allclose(np.abs(moment[:, first]), math.sqrt(10) * primary * SPACING, rtol=1e-6)


def test_a_90_deg_v_twin_through_the_model_has_a_turning_primary_and_a_horizontal_secondary() -> None:
    """One throw, cylinders at -45 and +45 deg: primary force of constant size ``m r w^2``, turning; the
    secondary horizontal only, ``sqrt(2)`` times one cylinder's (test_vee.py derives both)."""
    data = _vee(2, 90.0, ["A1", "B1"])
    data["firing"]["angles_deg"] = [0.0, 450.0]
    orders, force, _ = _free(parse_engine(data))
    primary = PISTON_KG * RADIUS * (SPEED_RPM * math.pi / 30) ** 2
    first = int(np.argmin(np.abs(orders - 1.0)))
    np.testing.assert_allclose(np.abs(force[:, first]), primary, rtol=1e-6)
    second = int(np.argmin(np.abs(orders - 2.0)))
    assert abs(force[1, second]) < 1e-6 * primary
    assert abs(force[0, second]) == pytest.approx(math.sqrt(2) * 0.25 * primary, rel=0.02)


def test_an_in_line_cylinder_is_not_turned() -> None:
    forces = np.array([[[1.0 + 2.0j], [3.0 - 1.0j]]])
    np.testing.assert_array_equal(to_engine_frame(forces, [0.0]), forces)


def test_a_throws_unbalance_counts_once_though_two_cylinders_share_it() -> None:
    """Adding 10 kg m to the unbalance of each throw of a V8 adds 10 w^2 to each throw's turning force:
    half of it to bearing 1 (throw 1 alone beside it, midway between bearings 1 and 2), not the
    whole, as each of the throw's two cylinders carrying the throw's whole unbalance would make it."""
    order = ["A1", "B4", "B2", "A2", "B3", "A3", "A4", "B1"]
    omega = SPEED_RPM * math.pi / 30
    forces = []
    for extra in (0.0, 10.0):
        data = _vee(8, 90.0, order, leading_bank="B")
        data["masses"]["crank_unbalance_kgm"] = 5.0 + extra
        predicted = predict_orders(EngineModel(parse_engine(data)), crank_speed=omega, load=0.0)
        first = int(np.argmin(np.abs(predicted.orders - 1.0)))
        forces.append(predicted.bearing_force[0, :, first])
    np.testing.assert_allclose(np.abs(forces[1] - forces[0]), 0.5 * 10.0 * omega**2, rtol=1e-9)
