"""The validation simulator's V engines: their draw, firing and physics, by routes of their own.

Nothing here uses the product's V models (``monitor.model.banks`` and its neighbours): the firing
angles are checked against the rule stated in words, the forces against the crank torque, a
V-twin's classical balance and finite differences of positions computed here.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from monitor.model.banks import tdc_offsets
from validation.simulator import (
    AMBIENT_PRESSURE,
    HEAT_LEVELS,
    HEAT_STEP,
    bearing_split,
    cycle_table,
    equivalent_inertia,
    operating_load,
    rated_heat,
    run_crank,
    slider_crank,
    throw_vertical_force,
)
from validation.simulator.description import description_engine, engine_description
from validation.simulator.engine import SimEngine, random_engine
from validation.simulator.kinematics import cylinder_vertical_forces, throw_across_force
from validation.simulator.shared import FloatArray
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
    assert (engine.rods == "side-by-side") == (engine.bank_offset > 0.0)
    slave_rod = (
        engine.knuckle_radius,
        engine.slave_rod_length,
        engine.slave_rod_mass,
        engine.slave_rod_inertia,
    )
    if engine.rods == "articulated":  # the knuckle pin near the crank pin, the slave rod shorter and lighter
        assert 0.8 <= engine.knuckle_radius / engine.crank_radius <= 1.2
        assert abs(engine.knuckle_angle - engine.bank_angle) <= math.radians(5.0)
        assert engine.slave_rod_length < engine.rod_length and engine.slave_rod_mass < engine.rod_mass
        assert 0 < engine.slave_rod_cg_from_pin < engine.slave_rod_length and engine.slave_rod_inertia > 0
    else:
        assert slave_rod == (0.0, 0.0, 0.0, 0.0)


@pytest.mark.parametrize("seed", VEE_SEEDS)
def test_vee_firing_follows_the_bank_rule(seed: int) -> None:
    """Each bank fires evenly over 720 deg; each trailing cylinder the bank angle after its partner (an
    articulated slave at its own TDC, a few degrees off the bank angle)."""
    engine = random_vee_engine(seed)
    m, cycle = engine.throws, engine.cycle_angle
    angles = engine.firing_angles
    assert angles[0] == 0.0
    trailing = slice(m, 2 * m) if engine.leading_bank == "A" else slice(0, m)
    leading = slice(0, m) if engine.leading_bank == "A" else slice(m, 2 * m)
    gap = np.mod(angles[trailing] - angles[leading], cycle)
    assert np.allclose(gap, engine.trailing_offset)
    if engine.rods == "articulated":
        assert 0 < abs(engine.trailing_offset - engine.bank_angle) < math.radians(10)
        assert list(np.flatnonzero(engine.slaves)) == list(range(2 * m))[trailing]
    else:
        assert engine.trailing_offset == engine.bank_angle and not engine.slaves.any()
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


def _twin(bank_deg: float, *, rod: bool = True, unbalance: bool = True) -> SimEngine:
    """A V-twin on one throw (fork-and-blade) from a drawn V engine's parts, bank A leading."""
    base = random_vee_engine(300001)
    return replace(
        base,
        firing_order=(1, 2),
        bank_angle=math.radians(bank_deg),
        leading_bank="A",
        rods="fork-and-blade",
        bank_offset=0.0,
        bearing_positions=base.bearing_positions[:2],
        rod_mass=base.rod_mass if rod else 0.0,
        rod_inertia=base.rod_inertia if rod else 0.0,
        crank_unbalance=base.crank_unbalance if unbalance else 0.0,
        counterweight=base.counterweight if unbalance else 0.0,
    )


def _positions(engine: SimEngine, psi: FloatArray) -> dict[str, FloatArray]:
    """Piston pin, crank pin, rod centre of gravity and rod angle from the geometry (cylinder frame)."""
    r, length, a = engine.crank_radius, engine.rod_length, engine.rod_cg_from_pin
    pin = np.stack([r * np.sin(psi), r * np.cos(psi)])
    piston = np.stack([0 * psi, pin[1] + np.sqrt(length**2 - pin[0] ** 2)])
    return {
        "piston": piston,
        "crank": pin,
        "rod": piston + (a / length) * (pin - piston),
        "angle": np.arctan2(pin[0] - piston[0], piston[1] - pin[1]),  # from the axis, towards +x
    }


@pytest.mark.parametrize("seed", (300000, 300003, 300004))
def test_across_force_is_newton_euler_by_finite_differences(seed: int) -> None:
    """The 3x3 Newton-Euler system of piston and rod, solved numerically with accelerations from
    finite differences of positions, gives the across-axis and along-axis forces on the bearings."""
    engine = random_vee_engine(seed)
    rng = np.random.default_rng(seed)
    mp, mr, ir, length = engine.piston_mass, engine.rod_mass, engine.rod_inertia, engine.rod_length
    u = (engine.crank_unbalance - engine.counterweight) * engine.unbalance_share
    for psi0 in rng.uniform(0, 2 * math.pi, 6):
        w, wdot = float(rng.uniform(50, 200)), float(rng.uniform(-300, 300))
        pressure = float(rng.uniform(1e5, 150e5))
        h = 1e-5
        times = np.array([-h, 0.0, h])
        psi = psi0 + w * times + 0.5 * wdot * times**2
        pos = _positions(engine, psi)
        acc = {k: (v[..., 0] - 2 * v[..., 1] + v[..., 2]) / h**2 for k, v in pos.items()}
        unb = u * (np.stack([np.sin(psi), np.cos(psi)]))
        unb_acc = (unb[:, 0] - 2 * unb[:, 1] + unb[:, 2]) / h**2
        gas = (pressure - AMBIENT_PRESSURE) * engine.piston_area
        # unknowns N (liner on piston, +x), C = (Cx, Cy) (crank pin on rod); the rod's force on the
        # piston is P = (-N, mp a_py + gas); the rod: mr a_G = C - P; moments about G
        q = mp * acc["piston"][1] + gas
        piston_pin, crank_pin, cg = pos["piston"][:, 1], pos["crank"][:, 1], pos["rod"][:, 1]
        rp, rc = piston_pin - cg, crank_pin - cg
        # rows: rod across (C_x + N = mr a_Gx), rod along (C_y = mr a_Gy + q), moments about G
        # (I phi_ddot = rp x (-P) + rc x C, with the rod's angle phi counter-clockwise-positive here)
        matrix = np.array([[1.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-rp[1], -rc[1], rc[0]]])
        rhs = np.array([mr * acc["rod"][0], mr * acc["rod"][1] + q, ir * acc["angle"] + rp[0] * q])
        n_liner, cx, cy = np.linalg.solve(matrix, rhs)
        across_expected = -cx - unb_acc[0]
        along_expected = -cy - unb_acc[1]
        across = throw_across_force(engine, psi0, pressure, w, wdot)
        along = throw_vertical_force(engine, psi0, pressure, w, wdot)
        scale = abs(gas) + mp * engine.crank_radius * w**2 + 1.0
        assert float(across) == pytest.approx(across_expected, abs=2e-5 * scale)
        assert float(along) == pytest.approx(along_expected, abs=2e-5 * scale)
        assert n_liner + cx == pytest.approx(mr * acc["rod"][0], abs=2e-5 * scale)
        assert length > 0


@pytest.mark.parametrize("seed", (300010, 300011))
def test_across_and_along_forces_give_the_crank_torque(seed: int) -> None:
    """The force the rod puts on the crank pin, across and along, times the pin's moment arms is the
    gas torque less the inertia torque of the energy route ``-(J_c w_dot + J_c' w^2 / 2)``."""
    engine = random_vee_engine(seed)
    assert engine.rods == "fork-and-blade"  # slider-cranks (tests/validation/test_articulated_simulator.py)
    rng = np.random.default_rng(seed)
    psi = rng.uniform(0, 2 * math.pi, 50)
    w, wdot = rng.uniform(40, 200, 50), rng.uniform(-500, 500, 50)
    pressure = rng.uniform(1e5, 200e5, 50)
    r = engine.crank_radius
    u = (engine.crank_unbalance - engine.counterweight) * engine.unbalance_share
    across = throw_across_force(engine, psi, pressure, w, wdot)
    along = throw_vertical_force(engine, psi, pressure, w, wdot)
    # the rod's force on the pin: the bearings' plus what accelerates the throw's unbalance
    pin_x = across + u * (-np.sin(psi) * w**2 + np.cos(psi) * wdot)
    pin_y = along + u * (-np.cos(psi) * w**2 - np.sin(psi) * wdot)
    torque = r * np.cos(psi) * pin_x - r * np.sin(psi) * pin_y  # pin at (r sin psi, r cos psi)
    inertia, derivative = equivalent_inertia(engine, psi)
    travel = slider_crank(
        psi, crank_radius=r, rod_length=engine.rod_length, rod_cg_from_pin=engine.rod_cg_from_pin
    ).piston_1
    gas = (pressure - AMBIENT_PRESSURE) * engine.piston_area
    expected = -gas * travel - inertia * wdot - 0.5 * derivative * w**2
    assert np.allclose(torque, expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())


def test_ninety_degree_twin_primary_is_a_rotating_force() -> None:
    """A 90 deg V-twin's first-order force on its bearings turns with the crank at a constant size
    (the classical result), about ``m_p R w^2`` for pistons alone, and a counterweight cancels it."""
    w, points = 100.0, 720
    theta = 2 * math.pi * np.arange(points) / points  # crank from the V's bisector towards +x
    for rod in (False, True):
        engine = _twin(90.0, rod=rod, unbalance=False)
        lean = engine.cylinder_leans
        psi = theta[None, :] - lean[:, None]
        ambient = np.full(psi.shape, AMBIENT_PRESSURE)
        along = throw_vertical_force(engine, psi, ambient, w, 0.0)
        across = throw_across_force(engine, psi, ambient, w, 0.0)
        y = (np.cos(lean)[:, None] * along - np.sin(lean)[:, None] * across).sum(axis=0)
        x = (np.sin(lean)[:, None] * along + np.cos(lean)[:, None] * across).sum(axis=0)
        assert np.allclose(cylinder_vertical_forces(engine, psi, ambient, w, 0.0).sum(axis=0), y)
        fy, fx = np.fft.rfft(y)[1] * 2 / points, np.fft.rfft(x)[1] * 2 / points
        size = abs(fy)
        assert fy.real == pytest.approx(size, rel=1e-9)  # y1 = F cos(theta)
        assert fx.imag == pytest.approx(-size, rel=1e-9)  # x1 = F sin(theta)
        if not rod:
            # the pistons' primary m_p R w^2, and the first order the rod's slant brings to the pin
            # (tan(phi) times the piston's second order: of order lambda^2)
            lam = engine.crank_radius / engine.rod_length
            assert size == pytest.approx(engine.piston_mass * engine.crank_radius * w**2, rel=lam**2)
        # a counterweight opposite the pin of F / w^2 (kg m) takes the first order away
        balanced = replace(engine, counterweight=size / w**2)
        y_b = cylinder_vertical_forces(balanced, psi, ambient, w, 0.0).sum(axis=0)
        assert abs(np.fft.rfft(y_b)[1]) * 2 / points < 1e-9 * size


def test_vee_bearing_rows_of_a_crank_run_are_the_vertical_forces() -> None:
    """A V engine's kept force rows are the lever split of each cylinder's vertical (and horizontal)
    force, recomputed here from the run's speed and acceleration and each cylinder's own crank angle."""
    engine = random_vee_engine(300000)
    table = cycle_table(
        engine,
        speed=engine.rated_speed,
        charge_pressure=engine.rated_charge_pressure,
        fuel=HEAT_STEP * np.arange(HEAT_LEVELS),
        heat_reference=rated_heat(engine),
    )
    load, _, speed = operating_load(engine, table, 0.7, np.ones(engine.cylinders))
    split = bearing_split(engine.cylinder_positions, engine.bearing_positions, engine.throw_bearings)
    run = run_crank(
        engine,
        table,
        load,
        fuel=0.0,
        end_time=0.05,
        initial_speed=speed,
        mixes=split,
        horizontal_mixes=split,
        settle_start=False,
    )
    alpha = run.step * np.arange(run.time.size)
    psi = alpha[None, :] - engine.firing_angles[:, None]
    local = np.mod(psi + 2 * math.pi, 4 * math.pi) - 2 * math.pi
    pressure = np.stack(
        [np.interp(row, table.crank_angle, table.pressure[0], period=4 * math.pi) for row in local]
    )
    b = engine.bearing_count
    assert run.forces.shape == (2 * b, run.time.size)
    forces = cylinder_vertical_forces(engine, psi, pressure, run.speed, run.acceleration)
    assert np.allclose(run.forces[:b], split @ forces, rtol=1e-4, atol=1e-4 * np.abs(forces).max())
    # the horizontal rows: each cylinder's along and across forces turned by its lean, here
    along = throw_vertical_force(engine, psi, pressure, run.speed, run.acceleration)
    across = throw_across_force(engine, psi, pressure, run.speed, run.acceleration)
    lean = engine.cylinder_leans[:, None]
    x = np.sin(lean) * along + np.cos(lean) * across
    assert np.allclose(run.forces[b:], split @ x, rtol=1e-4, atol=1e-4 * np.abs(x).max())


# 300155 and 300185: articulated V16s of 88.8 and 86.0 deg whose slaves reach their own TDCs after
# the next master (92.3 and 90.1 deg after their partners): the order is stated by own TDCs
@pytest.mark.parametrize("seed", VEE_SEEDS + tuple(range(300020, 300040)) + (300155, 300185))
def test_product_reads_the_vee_description_and_fires_as_the_simulator(seed: int) -> None:
    """The product loads a V engine's description and derives the simulator's firing angles."""
    engine = random_vee_engine(seed)
    text = engine_description(engine)
    described = description_engine(text)
    assert described.cylinders == engine.cylinders
    assert described.vee is not None
    assert described.vee.leading_bank == engine.leading_bank and described.vee.rods == engine.rods
    assert described.vee.bank_angle_deg == pytest.approx(math.degrees(engine.bank_angle), abs=1e-4)
    assert described.vee.bank_offset_m == pytest.approx(engine.bank_offset, rel=0.021)
    assert described.cylinder_names == engine.cylinder_names
    assert [described.cylinder_names[c] for c in described.firing_order] == [
        engine.cylinder_names[c - 1] for c in engine.firing_order
    ]
    # both fire each cylinder at its own TDC, from A1's own TDC: the product's slaves' TDCs from the
    # description's geometry, off the true ones by ``miss`` (once for a slave A1, once for the others)
    rod = described.articulated
    miss = 0.0 if rod is None else abs(rod.stroke().tdc_angle - engine.trailing_offset)
    own = described.firing_angles + tdc_offsets(described.cylinders, described.vee, rod)
    gap = np.mod(own - engine.firing_angles + math.pi, 4 * math.pi) - math.pi
    # the product fires evenly when a bank angle is within 0.05 deg of even firing (a 60.02 deg V12)
    assert np.abs(gap).max() < math.radians(0.05) + 2 * miss
    assert described.bearing_count == engine.bearing_count
    assert (rod is not None) == (engine.rods == "articulated")
    if rod is not None:  # perturbed as the master rod's geometry (2 %), the knuckle angle by 1 deg
        assert rod.knuckle_radius == pytest.approx(engine.knuckle_radius, rel=0.021)
        assert rod.slave_length == pytest.approx(engine.slave_rod_length, rel=0.021)
        assert abs(rod.knuckle_angle - engine.knuckle_angle) <= math.radians(1.0001)
        # so the product's slave fires within a degree of the true TDC
        assert abs(rod.stroke().tdc_angle - engine.trailing_offset) < math.radians(1.0)
