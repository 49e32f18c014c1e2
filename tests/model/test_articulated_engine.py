"""A V engine on articulated rods through the crank train, by routes apart from its own.

- The limit: a slave rod of the master's length and mass hung on the crank pin (knuckle radius 0) is a
  fork-and-blade V's trailing rod, so every predicted order (torques, gas torques, bearing forces, free
  forces and moments) and every cylinder's parts for the balance are the fork-and-blade engine's.
- The slave's own cycle: its pressure times its volume to the polytropic exponent stays constant
  through the compression, with the volume taken here from the slave's place at the master's crank
  angle a bank angle on (a pressure timed from the bank angle instead of the slave's own TDC breaks
  it); and the mean of its gas torque is its cycle's work, which exceeds a master's on the same fuel
  (its stroke is longer).
- The torsional side: the slave's moving masses' mean inertia is their kinetic energy's over a
  revolution (the knuckle share moves with the knuckle pin, not the crank pin).
"""

from __future__ import annotations

import copy
import math
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from monitor.model.banks import slave_cylinders, tdc_offsets
from monitor.model.crankshaft import EngineModel
from monitor.model.engine import Engine, bundled_engines, parse_engine
from monitor.model.predicted import cylinder_parts, predict_orders

OMEGA = 750 * math.pi / 30  # the 12V32's rated speed [rad/s]


def _twelve_v(**vee: Any) -> Engine:
    """The bundled 12V32 with its ``[vee]`` table changed."""
    path = bundled_engines()["medium-speed-12v32"]
    data = tomllib.loads(path.read_text())
    data["vee"] = {**copy.deepcopy(data["vee"]), "bank_offset_m": 0.0, **vee}
    return parse_engine(data, source_dir=path.parent)


HUNG_ON_THE_PIN = {
    "rods": "articulated",
    "knuckle_radius_m": 0.0,
    "knuckle_angle_deg": 0.0,
    "slave_rod_length_m": 0.80,  # the master's
    "slave_rod_kg": 130.0,
    "slave_rod_cg_from_piston_pin_m": 0.50,
}
ARTICULATED = {
    "rods": "articulated",
    "knuckle_radius_m": 0.20,  # a quarter of the master rod
    "knuckle_angle_deg": 55.0,  # at the bank angle from the master rod's axis
    "slave_rod_length_m": 0.60,
    "slave_rod_kg": 95.0,
    "slave_rod_cg_from_piston_pin_m": 0.37,
}


def test_a_slave_rod_hung_on_the_crank_pin_predicts_the_fork_and_blade_engines_orders() -> None:
    """Knuckle radius 0, the slave rod the master's: every order of the articulated model is the
    fork-and-blade engine's, to round-off of each quantity's scale. Both with the two-mass rod (the
    slave's model) and without weights (a slave's knuckle share weighs along the master's axis, a
    slider-crank's rotating share along its own)."""
    fork = _twelve_v(rods="fork-and-blade")
    hung = _twelve_v(**HUNG_ON_THE_PIN)
    assert slave_cylinders(hung.cylinders, hung.vee).sum() == 6
    models = [EngineModel(e, rod_model="two-mass", gravity=0.0) for e in (fork, hung)]
    expected, got = (predict_orders(m, crank_speed=OMEGA, load=0.8) for m in models)
    torque = np.abs(expected.cylinder_torque).max()
    force = np.abs(expected.bearing_force).max()
    length = float(np.ptp(fork.cylinder_positions))
    # a balanced 12V's free forces and moments are round-off: each compared on its cylinders' scale
    scales = {
        "cylinder_torque": torque,
        "cylinder_gas_torque": torque,
        "cylinder_inertia_force": force,
        "bearing_force": force,
        "free_force": force,
        "free_moment": force * length,
    }
    for name, scale in scales.items():
        np.testing.assert_allclose(
            getattr(got, name), getattr(expected, name), rtol=0, atol=1e-9 * scale, err_msg=name
        )
    expected_parts, got_parts = (cylinder_parts(m, crank_speed=OMEGA, load=0.8) for m in models)
    for reference, each in zip(expected_parts.per_cylinder(12), got_parts.per_cylinder(12), strict=True):
        np.testing.assert_allclose(each, reference, rtol=0, atol=1e-9 * np.abs(reference).max())


def test_the_slaves_pressure_follows_its_own_volume_and_its_work_is_its_gas_torques() -> None:
    """Through the compression (inlet closing to the start of combustion, timed from the slave's own
    TDC) ``p V^n`` of a slave stays what it was at inlet closing, ``V`` its volume at the master's crank
    angle a bank angle after the grid's (the slave's nominal TDC), from the slave's place alone; the
    mean of its gas torque times the cycle's angle is ``oint p dV`` (``dV`` from the place's
    derivative). To 1e-9: both are sums over the same grid; a volume timed from the nominal TDC (the
    slave's TDC lies ``tdc_offset``, 1.35 degrees here, away) breaks the invariant by 7 %."""
    engine = _twelve_v(**ARTICULATED)
    rod = engine.articulated
    assert rod is not None
    model = EngineModel(engine)
    pressure = model.slave_pressure(0.8)
    master = model.crank_angle + rod.bank_angle
    place, dplace, _ = rod.slave_position(master)
    area = engine.piston_area
    assert engine.combustion is not None
    clearance = area * 2 * engine.crank_radius / (engine.combustion.compression_ratio - 1)
    volume = clearance + area * (rod.stroke().top - place)
    offset = rod.stroke().tdc_offset
    assert abs(math.degrees(offset)) > 1.0  # the articulation moves the slave's TDC by over a degree
    own = np.mod(model.crank_angle - offset + 2 * math.pi, 4 * math.pi) - 2 * math.pi  # from its TDC
    c = engine.combustion
    closed = (own > math.radians(c.inlet_closing_deg) + 0.05) & (own < math.radians(c.combustion_start_deg))
    invariant = pressure[closed] * volume[closed] ** c.polytropic_compression
    np.testing.assert_allclose(invariant, invariant[0], rtol=1e-9)
    order = predict_orders(model, crank_speed=OMEGA, load=0.8)
    b1 = engine.cylinder_names.index("B1")
    period = 2 * math.pi * engine.cycle_revolutions
    work = float(np.mean((pressure - model.ambient_pressure) * area * -dplace)) * period
    assert order.cylinder_gas_torque[b1, 0].real * period == pytest.approx(work, rel=1e-9)
    a1 = engine.cylinder_names.index("A1")
    # the same fuel on a longer stroke and a higher compression: half a percent more work here
    assert order.cylinder_gas_torque[b1, 0].real > 1.002 * order.cylinder_gas_torque[a1, 0].real


def test_a_slave_hung_on_the_crank_pin_turns_with_the_fork_and_blade_engines_inertia() -> None:
    """Knuckle radius 0: the slave's knuckle share turns with the crank pin, so the engine side's
    inertia and every throw's, mean or at a crank angle, are the fork-and-blade engine's (the share
    counted with the slave's varying inertia instead of the throw's): to round-off."""
    from monitor.model.inertia import engine_side_inertia, node_inertias

    fork, hung = _twelve_v(rods="fork-and-blade"), _twelve_v(**HUNG_ON_THE_PIN)
    assert engine_side_inertia(hung) == pytest.approx(engine_side_inertia(fork), rel=1e-12)
    for reciprocating in ("mean", 0.3):
        expected = [inertia for _, inertia in node_inertias(fork, reciprocating=reciprocating)]
        got = [inertia for _, inertia in node_inertias(hung, reciprocating=reciprocating)]
        np.testing.assert_allclose(got, expected, rtol=1e-12)


def test_an_articulated_slaves_knuckle_share_adds_its_own_varying_inertia() -> None:
    """With the knuckle pin off the crank pin, a throw's mean inertia differs from the fork-and-blade
    engine's by the slave's own: its mean ``m_s s'^2 + m_k |K'|^2`` less what a slider-crank slave of
    the same masses would carry (``m_s x'^2`` and ``m_k R^2``)."""
    from monitor.model.banks import slave_masses
    from monitor.model.inertia import mean_moving_inertia, throw_inertia

    engine = _twelve_v(**ARTICULATED)
    rod = engine.articulated
    assert rod is not None and engine.vee is not None
    piston, knuckle = slave_masses(engine.vee, engine.masses.piston_assembly_kg)
    grid = np.linspace(0.0, 2 * math.pi, 512, endpoint=False)
    slave_mean = float(np.mean(rod.slave_inertia(grid, reciprocating_mass=piston, knuckle_mass=knuckle)))
    moving = mean_moving_inertia(engine)
    slaves = slave_cylinders(engine.cylinders, engine.vee)
    np.testing.assert_allclose(moving[slaves], slave_mean, rtol=1e-12)
    assert engine.shaft_line is not None
    own = engine.shaft_line.throw_inertia_kgm2 + engine.rotating_rod_mass * engine.crank_radius**2
    assert throw_inertia(engine) == pytest.approx(own, rel=1e-12)  # the master's share alone


def test_a_scene_of_an_articulated_v_gives_the_models_torque_and_bearing_forces() -> None:
    """The scene simulator's sources (each cylinder's forces as ``A + omega^2 B``, the slaves' from
    their own rows and pressures) at the scene's speed are the crank-train model's predicted orders,
    to round-off: the two paths split the forces differently (by speed against by source)."""
    from monitor.scene.loading import load_scene
    from monitor.scene.sources import sources_of

    engine = _twelve_v(**ARTICULATED)
    scene = load_scene(Path(__file__).parents[2] / "recordings" / "scenes" / "12v32-baseline.toml")
    sources = sources_of(scene, engine, [])
    assert sources is not None and sources.torque is not None and sources.bearing is not None
    speed = scene.operating_point.speed_rpm * math.pi / 30
    model = EngineModel(engine, grid_size=1024)
    predicted = predict_orders(model, crank_speed=speed, load=scene.operating_point.load, max_order=24)
    keep = sources.orders <= 24 + 1e-9
    torque = sources.torque.at(speed)[keep]
    np.testing.assert_allclose(torque, predicted.engine_torque, rtol=0, atol=1e-9 * np.abs(torque).max())
    bearing = sources.bearing.at(speed)[..., keep]
    np.testing.assert_allclose(bearing, predicted.bearing_force, rtol=0, atol=1e-9 * np.abs(bearing).max())


def test_the_documented_articulated_vee_table_is_the_one_tested_here() -> None:
    """docs/engines.md's ``[vee]`` example of articulated rods parses, and is this module's engine."""
    text = (Path(__file__).parents[2] / "docs" / "engines.md").read_text()
    blocks = [b.split("```")[0] for b in text.split("```toml")[1:]]
    block = next(b for b in blocks if 'rods = "articulated"' in b)
    documented = tomllib.loads(block)["vee"]
    assert documented == {"bank_angle_deg": 55.0, **ARTICULATED}
    _twelve_v(**documented)


def test_crank_angles_run_from_a1s_own_tdc_when_a1_is_a_slave() -> None:
    """With the B bank leading, A1 is a slave: crank angles are measured from its own TDC (where a
    flywheel's TDC mark puts it), so every firing angle is the fork-and-blade engine's less A1's TDC
    offset, and A1's own TDC is at 0."""
    path = bundled_engines()["medium-speed-12v32"]
    data = tomllib.loads(path.read_text())
    # the bundled order with each throw's B cylinder firing first, from A1
    data["firing"]["order"] = ["A1", "B5", "A5", "B3", "A3", "B6", "A6", "B2", "A2", "B4", "A4", "B1"]

    def b_leading(**vee: Any) -> Engine:
        data["vee"] = {**data["vee"], "bank_offset_m": 0.0, "leading_bank": "B", **vee}
        return parse_engine(copy.deepcopy(data), source_dir=path.parent)

    fork, articulated = b_leading(rods="fork-and-blade"), b_leading(**ARTICULATED)
    assert articulated.articulated is not None
    offsets = tdc_offsets(articulated.cylinders, articulated.vee, articulated.articulated)
    assert offsets[0] > math.radians(0.5)  # A1 is a slave, its TDC well past the bank angle's
    span = 4 * math.pi
    shift = np.mod(fork.firing_angles - articulated.firing_angles - offsets[0] + math.pi, span) - math.pi
    np.testing.assert_allclose(shift, 0.0, atol=1e-12)  # round-off of angles of order 4 pi
    own = np.mod(articulated.firing_angles + offsets + math.pi, span) - math.pi
    assert abs(own[0]) < 1e-12
