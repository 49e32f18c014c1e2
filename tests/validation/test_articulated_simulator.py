"""The validation simulator's articulated rods (``validation.simulator.linkage``), by routes of their own.

The linkage is solved numerically and its forces come from Lagrange multipliers on rigid bodies, so
it is checked against what it must agree with: the simulator's own slider-crank Newton-Euler closed
forms when the knuckle pin sits on the crank pin (the fork-and-blade engine), finite differences of
its positions, virtual work and the kinetic energy (the moments of its crank-pin forces), and the
product's closed form of the slave's dead centres and stroke (a code written apart, compared to
round-off).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from monitor.model.articulated import ArticulatedRod
from validation.simulator import (
    AMBIENT_PRESSURE,
    HEAT_LEVELS,
    HEAT_STEP,
    bearing_split,
    cycle_table,
    operating_load,
    rated_heat,
    run_crank,
)
from validation.simulator.engine import SimEngine
from validation.simulator.gas import CycleTable, closed_cycle
from validation.simulator.kinematics import (
    engine_kinematics,
    equivalent_inertia,
    piston_arm,
    vertical_force_coefficients,
)
from validation.simulator.linkage import linkage_motion, linkage_terms, slave_dead_centres
from validation.simulator.vee_engine import random_vee_engine

ARTICULATED_SEEDS = (300002, 300004, 310003)  # drawn with articulated rods (checked below)
FORK_SEED = 300000


def _articulated(seed: int) -> SimEngine:
    engine = random_vee_engine(seed)
    assert engine.rods == "articulated" and engine.bank_offset == 0.0
    return engine


def _rated_table(engine: SimEngine, points: int | None = None) -> CycleTable:
    """The engine's cycle table at its rated speed and charge pressure."""
    return cycle_table(
        engine,
        speed=engine.rated_speed,
        charge_pressure=engine.rated_charge_pressure,
        fuel=HEAT_STEP * np.arange(HEAT_LEVELS),
        heat_reference=rated_heat(engine),
        points=points,
    )


def _grid(engine: SimEngine, points: int = 97) -> np.ndarray:
    """Each cylinder's crank angle from its own TDC over one cycle, shape (n, points) [rad]."""
    psi = np.linspace(-engine.cycle_angle / 2, engine.cycle_angle / 2, points)
    return np.tile(psi, (engine.cylinders, 1))


def test_a_knuckle_on_the_crank_pin_is_the_fork_and_blade_simulator() -> None:
    """Knuckle radius 0 and the slave rod the master's: every cylinder's inertia, gas-torque arm and
    vertical and horizontal force coefficients are the fork-and-blade engine's, which the simulator
    computes by Newton-Euler in closed form. Round-off of each quantity's scale (the linkage's Newton
    solve settles to 1e-13 of the crank radius)."""
    drawn = random_vee_engine(FORK_SEED)
    fork = replace(drawn, rods="fork-and-blade", bank_offset=0.0)
    hung = replace(
        fork,
        rods="articulated",
        knuckle_radius=0.0,
        knuckle_angle=0.7,  # without effect at radius 0
        slave_rod_length=drawn.rod_length,
        slave_rod_cg_from_pin=drawn.rod_cg_from_pin,
        slave_rod_mass=drawn.rod_mass,
        slave_rod_inertia=drawn.rod_inertia,
    )
    assert hung.slaves.sum() == hung.throws
    assert hung.trailing_offset == pytest.approx(hung.bank_angle, abs=1e-10)
    np.testing.assert_allclose(hung.firing_angles, fork.firing_angles, rtol=0, atol=1e-10)
    psi = _grid(fork)
    expected = [*equivalent_inertia(fork, psi), -engine_kinematics(fork, psi).piston_1]
    got = [*equivalent_inertia(hung, psi), piston_arm(hung, psi)]
    for horizontal in (False, True):
        expected += vertical_force_coefficients(fork, psi, horizontal=horizontal)
        got += vertical_force_coefficients(hung, psi, horizontal=horizontal)
    for e, g in zip(expected, got, strict=True):
        np.testing.assert_allclose(g, e, rtol=0, atol=1e-9 * np.abs(e).max())


@pytest.mark.parametrize("seed", ARTICULATED_SEEDS)
def test_the_crank_pin_forces_do_the_work_of_the_torque(seed: int) -> None:
    """The moment of each cylinder's crank-pin force about the crankshaft axis is, per unit gas
    force, its piston's arm (virtual work); per omega^2, ``-J'/2``; per omega_dot, ``-J``, with ``J``
    from the bodies' kinetic energy. The multipliers and the energy are computed apart."""
    engine = _articulated(seed)
    t = np.linspace(0, 2 * math.pi, 181)
    terms = linkage_terms(engine.linkage, t)
    pin = engine.crank_radius * np.array([np.sin(t), np.cos(t)])

    def moment(force: np.ndarray) -> np.ndarray:  # in the direction of rotation, from y towards x
        return np.asarray(pin[1] * force[0] - pin[0] * force[1])

    for kind in (0, 1):
        arm, inertia = terms.arm[kind], terms.inertia[kind]
        np.testing.assert_allclose(moment(terms.gas[kind]), arm, rtol=0, atol=1e-12 * np.abs(arm).max())
        np.testing.assert_allclose(
            moment(terms.k2[kind]), -terms.inertia_1[kind] / 2, rtol=0, atol=1e-12 * inertia.max()
        )
        np.testing.assert_allclose(moment(terms.k1[kind]), -inertia, rtol=0, atol=1e-12 * inertia.max())
        assert inertia.min() > 0


@pytest.mark.parametrize("seed", ARTICULATED_SEEDS)
def test_the_linkage_motion_derivatives_are_finite_differences(seed: int) -> None:
    """Central differences of the solved positions (step 1e-4 rad: truncation ~ 1e-9 of the scale,
    round-off ~ 1e-12 / 1e-4)."""
    k = _articulated(seed).linkage
    t = np.linspace(0.05, 2 * math.pi, 60)
    h = 1e-4
    here, ahead, behind = (linkage_motion(k, t + d) for d in (0.0, h, -h))
    for row, scale in enumerate((1.0, k.crank_radius, 1.0, k.crank_radius)):  # [rad], [m]
        first = (ahead.z[row] - behind.z[row]) / (2 * h)
        second = (ahead.z_1[row] - behind.z_1[row]) / (2 * h)
        np.testing.assert_allclose(here.z_1[row], first, rtol=0, atol=1e-7 * scale)
        np.testing.assert_allclose(here.z_2[row], second, rtol=0, atol=1e-7 * scale)


@pytest.mark.parametrize("seed", ARTICULATED_SEEDS)
def test_slave_dead_centres_and_stroke_match_the_products_closed_form(seed: int) -> None:
    """The slave's TDC and BDC angles and its stroke, from the numerical linkage here and from the
    product's closed form (``monitor.model.articulated``), agree to 1e-9 of the stroke."""
    engine = _articulated(seed)
    k = engine.linkage
    closed = ArticulatedRod(
        crank_radius=k.crank_radius,
        master_length=k.rod_length,
        knuckle_radius=k.knuckle_radius,
        knuckle_angle=k.knuckle_angle,
        slave_length=k.slave_rod_length,
        bank_angle=k.bank_angle,
    ).stroke()
    top, bottom = slave_dead_centres(k)
    s_top, s_bottom = linkage_motion(k, np.array([top, bottom])).z[3]
    assert abs(top - closed.tdc_angle) < 1e-9
    assert abs(bottom - closed.bdc_angle) < 1e-9
    assert (s_top - s_bottom) == pytest.approx(closed.stroke, abs=1e-9 * closed.stroke)
    assert engine.trailing_offset == top


def test_a_slave_compresses_on_its_own_volume() -> None:
    """Motored and adiabatic, the slave's volume is least and its pressure highest at its own TDC, and
    its swept volume is the piston area times its own stroke; its fired trace (the same fuel) differs
    from the master's."""
    engine = _articulated(ARTICULATED_SEEDS[0])
    top, bottom = slave_dead_centres(engine.linkage)
    psi = np.radians(np.arange(-180.0, 180.01, 0.05))
    cycle = closed_cycle(
        engine,
        heat=[0.0],
        speed=engine.rated_speed,
        charge_pressure=2e5,
        crank_angle=psi,
        heat_loss=False,
        slave=True,
    )
    assert abs(psi[np.argmin(cycle.volume)]) < 1e-12
    assert abs(psi[np.argmax(cycle.pressure[0])]) < 1e-12
    assert cycle.volume.min() == pytest.approx(engine.clearance_volume, rel=1e-12)
    s_top, s_bottom = linkage_motion(engine.linkage, np.array([top, bottom])).z[3]
    bdc = np.mod(bottom - top + math.pi, 2 * math.pi) - math.pi
    swept = np.interp(bdc, psi, cycle.volume) - engine.clearance_volume
    assert swept == pytest.approx(engine.piston_area * (s_top - s_bottom), rel=1e-6)
    table = _rated_table(engine, points=1440)
    assert table.slave_pressure is not None and table.slave_pressure.shape == table.pressure.shape
    # this slave's stroke is 3 % longer (its knuckle angle past the bank angle): it compresses the
    # same charge further, to a higher motored peak
    assert table.slave_pressure[0].max() > 1.01 * table.pressure[0].max()


def test_an_articulated_crank_run_keeps_each_cylinders_own_forces() -> None:
    """A crank run's bearing rows are the lever split of each cylinder's vertical and horizontal force,
    recomputed here from the run's speed and acceleration, each cylinder's crank angle from its own TDC
    and its own pressure trace (a slave's on its own volume)."""
    engine = _articulated(ARTICULATED_SEEDS[0])
    table = _rated_table(engine)
    assert table.slave_pressure is not None
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
    traces = [table.slave_pressure[0] if slave else table.pressure[0] for slave in engine.slaves]
    pressure = np.stack(
        [
            np.interp(row, table.crank_angle, trace, period=4 * math.pi)
            for row, trace in zip(local, traces, strict=True)
        ]
    )
    gas = (pressure - AMBIENT_PRESSURE) * engine.piston_area
    b = engine.bearing_count
    for rows, horizontal in ((run.forces[:b], False), (run.forces[b:], True)):
        g, k2, k1 = vertical_force_coefficients(engine, psi, horizontal=horizontal)
        forces = g * gas + k2 * run.speed**2 + k1 * run.acceleration
        # the run interpolates its tabulated pressure on its own grid: 1e-4 of the largest force
        np.testing.assert_allclose(rows, split @ forces, rtol=1e-4, atol=1e-4 * np.abs(forces).max())
