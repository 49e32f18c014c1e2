"""Multi-cylinder model: cancellation, phases, load sharing, momentum balance, free forces."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from monitor.errors import ModelError
from monitor.fourier import cycle_grid, order_coefficients
from monitor.model.crankshaft import EngineModel
from monitor.model.crankshaft import EngineModel as Model
from monitor.model.engine import load_engine, parse_engine
from monitor.model.forces import CrankTrain, crank_kinematics, crank_train_forces
from monitor.model.gas import ParametricCycle, gas_force
from monitor.model.predicted import predict_orders
from tests.conftest import ENGINES


@pytest.fixture(scope="module")
def k98() -> EngineModel:
    return EngineModel(load_engine("man-b-w-7k98mc"))


@pytest.fixture(scope="module")
def l32() -> EngineModel:
    return EngineModel(load_engine("medium-speed-6l32"))


def test_even_firing_two_stroke_torque_keeps_only_multiples_of_cylinder_count(k98: EngineModel) -> None:
    """Seven cylinders firing every 360/7 deg: torque orders not a multiple of 7 cancel to round-off."""
    result = predict_orders(k98, crank_speed=k98.engine.rated_speed, load=1.0, max_order=24)
    per_cylinder = np.abs(result.cylinder_torque[0])
    for i, order in enumerate(result.orders):
        if order == 0:
            continue
        if order % 7 == 0:
            assert abs(result.engine_torque[i]) == pytest.approx(7 * per_cylinder[i], rel=1e-12)
        else:
            assert abs(result.engine_torque[i]) <= 1e-13 * 7 * per_cylinder.max()


def test_even_firing_four_stroke_torque_keeps_only_multiples_of_half_cylinder_count(l32: EngineModel) -> None:
    """Six cylinders firing every 120 deg: only orders 3, 6, 9, ... survive (half orders cancel too)."""
    result = predict_orders(l32, crank_speed=l32.engine.rated_speed, load=1.0, max_order=12)
    scale = 6 * np.abs(result.cylinder_torque[0]).max()
    for i, order in enumerate(result.orders[1:], start=1):
        if math.isclose(order % 3, 0.0, abs_tol=1e-12):
            assert abs(result.engine_torque[i]) > 1e-6 * scale
        else:
            assert abs(result.engine_torque[i]) <= 1e-13 * scale, order


def test_a_cylinder_carries_the_phase_of_its_crank(k98: EngineModel) -> None:
    """Cylinder 4's torque computed directly at its own crank angle alpha - phi_4 (no phase-shift
    formula) has the orders the model reports for cylinder 4."""
    e = k98.engine
    phi = float(e.firing_angles[3])
    alpha = cycle_grid(2048)
    local = alpha - phi
    kin = crank_kinematics(local, e.crank_radius, e.rod_ratio)
    cycle = ParametricCycle.of(e)
    f_gas = gas_force(cycle.pressure(local, 0.7), e.piston_area, e.combustion.ambient_pressure_bar * 1e5)  # type: ignore[union-attr]
    direct = crank_train_forces(kin, CrankTrain.of(e), crank_speed=e.rated_speed, gas_force=f_gas).torque
    expected = order_coefficients(direct, max_order=24).coefficients
    result = predict_orders(k98, crank_speed=e.rated_speed, load=0.7, max_order=24)
    # the model runs on 1024 points: the difference must lie within the grid error it reports
    error = np.abs(result.cylinder_torque[3] - expected)
    assert error.max() <= result.aliasing_error["torque"]
    assert error.max() <= 1e-7 * np.abs(expected).max()
    # and the phase of order k is cylinder 1's minus k phi_4
    k = 7
    assert np.angle(result.cylinder_torque[3, k] / result.cylinder_torque[0, k]) == pytest.approx(
        math.remainder(-k * phi, 2 * math.pi), abs=1e-9
    )


def test_bearings_carry_exactly_the_throw_forces(k98: EngineModel) -> None:
    """Load sharing conserves force: the sum over bearings equals the sum over throws."""
    e = k98.engine
    result = predict_orders(k98, crank_speed=e.rated_speed, load=1.0)
    forces = k98.cylinder_forces(e.rated_speed, 1.0)
    ux, uy = k98.unbalance_force(e.rated_speed)
    throw = order_coefficients(np.stack([forces.pin_force_x + ux, forces.pin_force_y + uy]), max_order=24)
    shifted = (
        throw.coefficients[None] * np.exp(-1j * np.multiply.outer(e.firing_angles, throw.orders))[:, None, :]
    )
    np.testing.assert_allclose(
        result.bearing_force.sum(axis=0), shifted.sum(axis=0), atol=1e-9 * np.abs(shifted).max()
    )


def test_momentum_balance_of_one_crank_train() -> None:
    """Without gravity: bearing force - guide force (x) + gas force on the head (y) = inertia force.

    The frame receives the crank-pin force plus the throw's centrifugal force at
    the bearings, -N at the guide and the gas force at the cylinder head; their
    sum is the inertia force of the moving parts (Newton's second law for the
    moving parts as a whole).
    """
    model = EngineModel(load_engine("kluczyk-1cyl-4stroke"), gravity=0.0)
    e = model.engine
    forces = model.cylinder_forces(e.rated_speed, 1.0)
    ux, uy = model.unbalance_force(e.rated_speed)
    total_x = forces.pin_force_x + ux - forces.guide_force
    total_y = forces.pin_force_y + uy + forces.gas_force
    scale = np.abs(forces.gas_force).max()
    np.testing.assert_allclose(total_x, forces.inertia_force_x + ux, atol=1e-12 * scale)
    np.testing.assert_allclose(total_y, forces.inertia_force_y + uy, atol=1e-12 * scale)


def test_inline_six_has_no_first_or_second_order_free_forces_or_moments(l32: EngineModel) -> None:
    """Textbook balance of the in-line six (throws 1-6, 2-5, 3-4 at 120 deg, mirror symmetric):
    free forces and moments of orders 1 and 2 vanish."""
    result = predict_orders(l32, crank_speed=l32.engine.rated_speed, load=1.0, max_order=6)
    one = np.abs(result.cylinder_inertia_force[0]).max()
    for order in (1.0, 2.0):
        i = int(np.flatnonzero(result.orders == order)[0])
        assert np.abs(result.free_force[:, i]).max() <= 1e-12 * one
        assert np.abs(result.free_moment[:, i]).max() <= 1e-12 * one * 3
    i = int(np.flatnonzero(result.orders == 6.0)[0])  # order 6 adds up in all six
    assert abs(result.free_force[1, i]) == pytest.approx(
        6 * abs(result.cylinder_inertia_force[0, 1, i]), rel=1e-9
    )


def test_seven_cylinder_free_forces_vanish_but_moments_do_not(k98: EngineModel) -> None:
    """An evenly spaced 7-throw star has no free force below order 7; the moments remain."""
    result = predict_orders(k98, crank_speed=k98.engine.rated_speed, load=1.0)
    one = np.abs(result.cylinder_inertia_force[0]).max()
    for i in (1, 2, 4, 6):
        assert np.abs(result.free_force[:, i]).max() <= 1e-12 * one
    assert abs(result.free_moment[0, 1]) > 1e3 and abs(result.free_moment[0, 2]) > 1e3


def test_single_cylinder_first_order_vertical_force() -> None:
    """Two-mass model: the order-1 vertical inertia force is (m_rec + m_rot) R w^2 + U w^2 exactly,
    because the exact piston acceleration's order 1 is R w^2 (the rod terms are even in 2 alpha)."""
    e = load_engine("zubaydi-1cyl-2stroke")
    model = EngineModel(e, rod_model="two-mass", gas="none", gravity=0.0)
    w = e.rated_speed
    result = predict_orders(model, crank_speed=w, load=0.0, max_order=8)
    expected = (
        e.reciprocating_mass + e.rotating_rod_mass
    ) * e.crank_radius * w**2 + e.net_crank_unbalance * w**2
    assert result.cylinder_inertia_force[0, 1, 1] == pytest.approx(expected, rel=1e-12)


def test_bad_operating_points_are_refused(k98: EngineModel) -> None:
    for speed in (0.0, -1.0, float("nan")):
        with pytest.raises(ModelError, match="crank_speed"):
            predict_orders(k98, crank_speed=speed, load=1.0)
    with pytest.raises(ModelError, match="load"):
        predict_orders(k98, crank_speed=10.0, load=2.0)
    with pytest.raises(ModelError, match="resolves orders up to"):
        predict_orders(EngineModel(k98.engine, grid_size=32), crank_speed=10.0, load=1.0, max_order=24)


def test_measured_trace_route() -> None:
    """An engine described by a measured trace (the parametric cycle sampled at 2 deg) predicts the
    same torque orders as the parametric model, within the interpolation error."""

    with (ENGINES / "medium-speed-6l32.toml").open("rb") as handle:
        data = tomllib.load(handle)
    e = load_engine("medium-speed-6l32")
    angles = np.arange(-360.0, 360.0, 2.0)
    pressure = ParametricCycle.of(e).pressure(np.radians(angles), 1.0) / 1e5
    data["pressure_trace"] = {
        "crank_angle_deg": angles.tolist(),
        "pressure_bar": pressure.tolist(),
        "load": 1.0,
    }
    measured_engine = parse_engine(data)
    measured = predict_orders(
        Model(measured_engine, gas="measured"), crank_speed=e.rated_speed, load=1.0, max_order=12
    )
    parametric = predict_orders(Model(e, gas="parametric"), crank_speed=e.rated_speed, load=1.0, max_order=12)
    scale = np.abs(parametric.engine_torque[1:]).max()
    assert np.abs(measured.engine_torque[1:] - parametric.engine_torque[1:]).max() < 5e-3 * scale
