"""Crank-train forces: paper 004's equations, the two rod models, energy balance, published values."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from monitor.errors import ModelError
from monitor.fourier import cycle_grid
from monitor.model import kinematics as kin
from monitor.model.engine import load_engine
from monitor.model.forces import (
    STANDARD_GRAVITY,
    CrankTrain,
    crank_kinematics,
    crank_train_forces,
)

TRAIN = CrankTrain(
    crank_radius=1.33,
    rod_ratio=0.413,
    piston_mass=6000.0,
    rod_mass=8000.0,
    rod_cg_fraction=0.6,
    rod_inertia=10200.0,
)
COMPARED = (
    "guide_force",
    "tangential_force",
    "radial_force",
    "torque",
    "pin_force_x",
    "pin_force_y",
    "inertia_force_x",
    "inertia_force_y",
)


def _gas(alpha: np.ndarray) -> np.ndarray:
    return 1.1e7 * np.exp(-((np.mod(alpha + np.pi, 2 * np.pi) - np.pi - 0.3) ** 2) / 0.1)


@pytest.mark.parametrize("omega_dot", [0.0, 0.8, -3.0])
def test_rigid_rod_with_two_mass_inertia_equals_two_mass_model(omega_dot: float) -> None:
    """Newton-Euler with I_G = m k (1-k) L^2 must reproduce the two-mass split to round-off."""
    train = dataclasses.replace(TRAIN, rod_inertia=TRAIN.two_mass_inertia)
    alpha = cycle_grid(360)
    k = crank_kinematics(alpha, train.crank_radius, train.rod_ratio)
    common = dict(crank_speed=10.9, crank_acceleration=omega_dot, gas_force=_gas(alpha))
    rigid = crank_train_forces(k, train, rod_model="rigid", **common)
    split = crank_train_forces(k, train, rod_model="two-mass", **common)
    for name in COMPARED:
        a, b = getattr(rigid, name), getattr(split, name)
        assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(b)) + 1e-6, name


def test_two_mass_model_follows_paper_004_equations() -> None:
    """004 eq. 6-12 written out as printed (eq. 12 with its brackets restored)."""
    alpha = cycle_grid(720)
    omega = 1189 * math.pi / 30
    train = CrankTrain(0.0525, 0.252, 4.0, 2.0, 0.75, 0.01)
    k = crank_kinematics(alpha, train.crank_radius, train.rod_ratio)
    f_gas = _gas(alpha) * 1e-3
    out = crank_train_forces(k, train, crank_speed=omega, gas_force=f_gas, rod_model="two-mass", gravity=0.0)
    lam, r = train.rod_ratio, train.crank_radius
    beta = np.arcsin(lam * np.sin(alpha))  # 004 eq. 13
    f_bp = -train.reciprocating_mass * kin.piston_acceleration(alpha, omega, r, lam)  # eq. 6, exact a
    f_bo = -train.rotating_rod_mass * r * omega**2  # eq. 7
    f = f_gas + f_bp
    s = f / np.cos(beta)  # eq. 9
    np.testing.assert_allclose(out.piston_force, f, rtol=1e-12)
    np.testing.assert_allclose(out.guide_force, f * np.tan(beta), atol=1e-9 * np.abs(f).max())  # eq. 8
    np.testing.assert_allclose(out.rod_force, s, rtol=1e-12)
    np.testing.assert_allclose(
        out.tangential_force, s * np.sin(alpha + beta), atol=1e-9 * np.abs(s).max()
    )  # eq. 10
    np.testing.assert_allclose(
        out.radial_force, s * np.cos(alpha + beta) + f_bo, atol=1e-9 * np.abs(s).max()
    )  # eq. 12
    np.testing.assert_allclose(out.torque, out.tangential_force * r, rtol=1e-15)  # eq. 15


@pytest.mark.parametrize("rod_model", ["rigid", "two-mass"])
@pytest.mark.parametrize("omega_dot", [0.0, 2.5])
def test_power_balance(rod_model: str, omega_dot: float) -> None:
    """Torque x omega = gas power - d(kinetic + potential energy)/dt, at every angle.

    Kinetic energy of the moving parts is (omega^2 / 2) J(alpha) with
    J = m_p x'^2 + m_r |G'|^2 + I x beta'^2 built from the kinematics alone;
    its angle derivative is taken spectrally on a 4096-point grid (an
    independent route to the Newton-Euler forces).
    """
    train = TRAIN if rod_model == "rigid" else dataclasses.replace(TRAIN, rod_inertia=TRAIN.two_mass_inertia)
    n = 4096
    alpha = cycle_grid(n)
    k = crank_kinematics(alpha, train.crank_radius, train.rod_ratio)
    omega, g = 10.9, STANDARD_GRAVITY
    f_gas = _gas(alpha)
    out = crank_train_forces(
        k,
        train,
        crank_speed=omega,
        crank_acceleration=omega_dot,
        gas_force=f_gas,
        rod_model=rod_model,
        gravity=g,
    )  # type: ignore[arg-type]
    r, q = train.crank_radius, train.rod_cg_fraction
    # velocities per unit crank speed
    pin_x, pin_y = r * np.cos(alpha), -r * np.sin(alpha)
    gx, gy = q * pin_x, (1 - q) * (-k.dx) + q * pin_y
    inertia = train.rod_inertia if rod_model == "rigid" else train.two_mass_inertia
    j = train.piston_mass * k.dx**2 + train.rod_mass * (gx**2 + gy**2) + inertia * k.dbeta**2
    # potential energy per unit of height: piston pin at y = R cos a + L cos b, G between pins
    x = kin.piston_displacement(alpha, r, train.rod_ratio)
    y_pin = r + train.rod_length - x
    y_g = (1 - q) * y_pin + q * r * np.cos(alpha)
    potential = g * (train.piston_mass * y_pin + train.rod_mass * y_g)
    freq = np.fft.rfftfreq(n, d=1.0 / n)
    d_da = lambda v: np.fft.irfft(1j * freq * np.fft.rfft(v), n)  # noqa: E731
    dkinetic_dt = omega * omega_dot * j + 0.5 * omega**3 * d_da(j)
    dpotential_dt = omega * d_da(potential)
    expected = f_gas * k.dx * omega - dkinetic_dt - dpotential_dt
    np.testing.assert_allclose(out.torque * omega, expected, atol=1e-9 * np.abs(expected).max())


def test_paper_004_reciprocating_inertia_and_weight() -> None:
    """Paper 004 (section 'Dynamics'): at 1189 rpm the peak reciprocating inertia
    force is 4601 N and the reciprocating weight 44.28 N (both printed to 4
    digits: tolerance 0.05 %). The geometry behind them is inferred in the
    engine file (see docs/engines.md)."""
    e = load_engine("kluczyk-1cyl-4stroke")
    alpha = cycle_grid(7200)
    omega = 1189 * math.pi / 30
    f_bp = -e.reciprocating_mass * kin.piston_acceleration(alpha, omega, e.crank_radius, e.rod_ratio)
    assert np.max(np.abs(f_bp)) == pytest.approx(4601, rel=5e-4)
    assert e.reciprocating_mass * STANDARD_GRAVITY == pytest.approx(44.28, rel=5e-4)
    # the two-mass split is the paper's 25 % of the rod at the piston pin
    assert e.conrod_cg_fraction == pytest.approx(0.75)


def test_paper_000_inertia_force_difference_exceeds_50_kN() -> None:
    """Paper 000 conclusions: with the approximate kinematics the inertia force of one
    7K98MC cylinder is off by more than 50 kN (bundled masses, two-mass split)."""
    e = load_engine("man-b-w-7k98mc")
    alpha = cycle_grid(7200)
    exact = kin.piston_acceleration(alpha, e.rated_speed, e.crank_radius, e.rod_ratio)
    approx = kin.piston_acceleration_approx(alpha, e.rated_speed, e.crank_radius, e.rod_ratio)
    diff = e.reciprocating_mass * np.max(np.abs(exact - approx))
    assert diff > 50e3
    train = CrankTrain.of(e)
    forces = [
        crank_train_forces(
            crank_kinematics(alpha, e.crank_radius, e.rod_ratio, model=m),
            train,
            crank_speed=e.rated_speed,
            rod_model="two-mass",
            gravity=0.0,
        )
        for m in ("exact", "approx")
    ]
    assert np.max(np.abs(forces[0].piston_force - forces[1].piston_force)) == pytest.approx(diff, rel=1e-9)


def test_zero_speed_leaves_gas_and_weight_only() -> None:
    alpha = cycle_grid(64)
    k = crank_kinematics(alpha, TRAIN.crank_radius, TRAIN.rod_ratio)
    out = crank_train_forces(k, TRAIN, crank_speed=0.0, gas_force=1e5, gravity=0.0)
    np.testing.assert_allclose(out.inertia_force_x, 0.0, atol=0)
    np.testing.assert_allclose(out.piston_force, 1e5, rtol=1e-15)
    np.testing.assert_allclose(out.torque, 1e5 * k.dx, rtol=1e-12, atol=1e-6)  # virtual work: M = F dx/da


@given(omega=st.floats(0.0, 1e4), lam=st.floats(1e-3, 0.999999))
def test_forces_stay_finite_over_the_domain(omega: float, lam: float) -> None:
    """Any speed up to 1e4 rad/s and rod ratio in [1e-3, 1): finite forces in both rod models."""
    train = dataclasses.replace(TRAIN, rod_ratio=lam)
    alpha = np.concatenate([cycle_grid(32), [np.pi / 2, 3 * np.pi / 2]])
    k = crank_kinematics(alpha, train.crank_radius, train.rod_ratio)
    for model in ("rigid", "two-mass"):
        out = crank_train_forces(k, train, crank_speed=omega, gas_force=1e6, rod_model=model)  # type: ignore[arg-type]
        for field in dataclasses.fields(out):
            assert np.all(np.isfinite(getattr(out, field.name))), (model, field.name)


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("rod_ratio", 1e-6, "expected >= 0.001"),
        ("rod_ratio", 1.0, "expected 0 <= rod_ratio < 1"),
        ("rod_mass", 0.0, "rod_mass = 0.0: expected a positive"),
        ("rod_cg_fraction", 1.5, "expected 0..1"),
    ],
)
def test_bad_crank_train_is_refused(field: str, value: float, message: str) -> None:
    with pytest.raises(ModelError, match=message):
        dataclasses.replace(TRAIN, **{field: value})


def test_bad_inputs_are_refused() -> None:
    alpha = cycle_grid(8)
    exact = crank_kinematics(alpha, 1.0, 0.3)
    approx = crank_kinematics(alpha, 1.0, 0.3, model="approx")
    with pytest.raises(ModelError, match="crank_speed = nan"):
        crank_train_forces(exact, TRAIN, crank_speed=float("nan"))
    with pytest.raises(ModelError, match="crank_acceleration = inf"):
        crank_train_forces(exact, TRAIN, crank_speed=1.0, crank_acceleration=float("inf"))
    with pytest.raises(ModelError, match="gas_force contains NaN"):
        crank_train_forces(exact, TRAIN, crank_speed=1.0, gas_force=np.full(8, np.nan))
    with pytest.raises(ModelError, match="needs the exact kinematics"):
        crank_train_forces(approx, TRAIN, crank_speed=1.0, rod_model="rigid")
    with pytest.raises(ModelError, match="rod_model = 'beam'"):
        crank_train_forces(exact, TRAIN, crank_speed=1.0, rod_model="beam")  # type: ignore[arg-type]
    with pytest.raises(ModelError, match="kinematics model = 'exactish'"):
        crank_kinematics(alpha, 1.0, 0.3, model="exactish")  # type: ignore[arg-type]
