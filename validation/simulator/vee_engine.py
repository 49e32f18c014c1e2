"""V engines of the validation population: how a seed draws one (its own engine stream)."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Literal

import numpy as np

from validation.simulator.engine import _FIRING_ORDERS, DoubleWiebe, SimEngine, random_engine
from validation.simulator.shared import ENGINE_STREAM, FloatArray

#: Third word of a V engine's engine stream (an in-line engine's stream has two words).
VEE_WORD = 7

#: Share of V engines on articulated (master-and-slave) rods [-].
ARTICULATED_SHARE = 1 / 3


def _uniform(rng: np.random.Generator, low: float, high: float) -> float:
    return float(rng.uniform(low, high))


def _vee_order(angles: FloatArray) -> tuple[int, ...]:
    """Cylinder indices (1-based) in the order their firing angles come, A1 first."""
    return tuple(int(c) + 1 for c in np.argsort(angles, kind="stable"))


def _law(rng: np.random.Generator, medium: bool) -> DoubleWiebe:
    deg = math.pi / 180
    return DoubleWiebe(
        start=_uniform(rng, -8, -2) * deg,
        premixed_fraction=_uniform(rng, 0.05, 0.3) if medium else _uniform(rng, 0.1, 0.35),
        premixed_duration=_uniform(rng, 5, 12) * deg,
        premixed_shape=_uniform(rng, 1.5, 3.0),
        diffusion_delay=_uniform(rng, 3, 6) * deg,
        diffusion_duration=_uniform(rng, 40, 70) * deg,
        diffusion_shape=_uniform(rng, 0.6, 1.2),
    )


Rods = Literal["side-by-side", "fork-and-blade", "articulated"]


def _rods(
    rng: np.random.Generator,
    side_by_side: bool,
    *,
    radius: float,
    rod_length: float,
    rod_mass: float,
    bank: float,
) -> tuple[Rods, dict[str, float]]:
    """The rods (:func:`random_vee_engine`): articulated for a share of the engines, with the slave rod's
    and knuckle pin's SimEngine fields, else as drawn before."""
    if not rng.random() < ARTICULATED_SHARE:
        return ("side-by-side" if side_by_side else "fork-and-blade"), {}
    knuckle = radius * _uniform(rng, 0.8, 1.2)
    length = (rod_length - knuckle) * _uniform(rng, 0.97, 1.05)
    mass = rod_mass * _uniform(rng, 0.5, 0.7)  # no big-end bearing of its own
    return "articulated", {
        "knuckle_radius": knuckle,
        "knuckle_angle": bank + math.radians(_uniform(rng, -5.0, 5.0)),
        "slave_rod_length": length,
        "slave_rod_cg_from_pin": length * _uniform(rng, 0.55, 0.65),
        "slave_rod_mass": mass,
        "slave_rod_inertia": mass * (length * _uniform(rng, 0.26, 0.33)) ** 2,
    }


def random_vee_engine(seed: int) -> SimEngine:
    """Draw a V engine: a medium-speed or high-speed four-stroke of 12 to 20 cylinders.

    Parameters
    ----------
    seed : int
        The case seed, >= 0 (the engine comes from its own stream, apart from an in-line engine's).

    Returns
    -------
    SimEngine
        ``bank_angle > 0``.

    Notes
    -----
    Medium-speed (60 %): 45-60 deg V, 500-1000 rpm; high-speed: 60-90 deg V, 1200-1900 rpm; 12-20
    cylinders. Each bank fires as an in-line four-stroke of ``m = n / 2`` cylinders in a usual order,
    the trailing bank's cylinder of each throw the bank angle after its partner
    (:attr:`SimEngine.firing_angles`); the firing order is their order from A1. Side-by-side rods
    (70 %) put the B bank 0.30-0.40 bore further along the shaft; fork-and-blade rods put both in one
    plane; a third (drawn last) run articulated rods in one plane, the leading bank's the masters:
    knuckle pin 0.8-1.2 crank radii from the crank pin at the bank angle +-5 deg, slave rod 0.97-1.05
    times the master's length less that radius, 0.5-0.7 times its mass; a slave fires at its own TDC.
    A throw counts two rods; the rigid inertia counts throws. The rest as :func:`random_engine`.
    """
    if seed < 0:
        raise ValueError(f"seed = {seed}: expected an integer >= 0")
    rng = np.random.default_rng(np.random.SeedSequence([seed, ENGINE_STREAM, VEE_WORD]))
    deg = math.pi / 180
    medium = bool(rng.random() < 0.6)
    if medium:
        rpm, bank = _uniform(rng, 500.0, 1000.0), _uniform(rng, 45.0, 60.0)
        piston_speed, stroke_bore = _uniform(rng, 8.0, 10.5), _uniform(rng, 1.15, 1.45)
        rod_ratio = _uniform(rng, 0.22, 0.30)
        imep, charge = _uniform(rng, 20e5, 27e5), _uniform(rng, 3.0e5, 4.5e5)
        compression, friction = _uniform(rng, 12.5, 15.0), _uniform(rng, 0.9e5, 1.4e5)
    else:
        rpm, bank = _uniform(rng, 1200.0, 1900.0), _uniform(rng, 60.0, 90.0)
        piston_speed, stroke_bore = _uniform(rng, 9.0, 11.5), _uniform(rng, 1.05, 1.3)
        rod_ratio = _uniform(rng, 0.24, 0.32)
        imep, charge = _uniform(rng, 16e5, 24e5), _uniform(rng, 2.2e5, 3.5e5)
        compression, friction = _uniform(rng, 14.0, 17.0), _uniform(rng, 1.0e5, 1.6e5)
    cylinders = int(rng.choice([12, 14, 16, 18, 20], p=[0.3, 0.1, 0.3, 0.1, 0.2]))
    m = cylinders // 2
    ivc, evo, blowdown = -_uniform(rng, 200, 220), _uniform(rng, 120, 140), _uniform(rng, 40, 55)
    law = _law(rng, medium)
    stroke = piston_speed * 30.0 / rpm
    bore = stroke / stroke_bore
    radius = stroke / 2
    rod_length = radius / rod_ratio
    piston = _uniform(rng, 2500, 3500) * bore**3
    rod = piston * _uniform(rng, 1.0, 1.3)
    cg = rod_length * _uniform(rng, 0.55, 0.70)
    rod_inertia = rod * (rod_length * _uniform(rng, 0.26, 0.33)) ** 2
    crank_unbalance = _uniform(rng, 0.6, 1.0) * 2 * rod * radius  # pin and webs of a two-rod throw
    counterweight = _uniform(rng, 0.4, 1.1) * crank_unbalance
    throw = _uniform(rng, 1.5, 2.5) * 2 * (piston + rod) * radius**2
    choices = _FIRING_ORDERS[(2, m)]
    bank_order = choices[int(rng.integers(len(choices)))]
    leading: Literal["A", "B"] = "A" if rng.random() < 0.5 else "B"
    side_by_side = bool(rng.random() < 0.7)
    offset = bore * _uniform(rng, 0.30, 0.40) if side_by_side else 0.0
    load_type: Literal["propeller", "generator"] = "propeller" if rng.random() < 0.4 else "generator"
    irregularity = 1 / _uniform(rng, 150, 300) if load_type == "generator" else 1 / _uniform(rng, 70, 150)
    omega = rpm * math.pi / 30
    work = imep * math.pi * bore**2 / 4 * stroke
    recip_mean = cylinders * (piston + 0.5 * rod) * radius**2 * 0.5
    rest = max(work * 0.35 / (irregularity * omega**2) - m * throw - recip_mean, 0.3 * m * throw)
    flywheel_share = _uniform(rng, 0.4, 0.8)
    pitch = bore * _uniform(rng, 1.45, 1.75)
    bearings = pitch * (np.arange(m + 1) + rng.uniform(-0.02, 0.02, m + 1))
    bearings -= bearings[0]
    lead_offset = 0 if leading == "A" else m
    # drawn after the rest, so that the other engines' values stay those of earlier streams
    rods, slave = _rods(
        rng, side_by_side, radius=radius, rod_length=rod_length, rod_mass=rod, bank=bank * deg
    )
    provisional = tuple(lead_offset + k for k in bank_order) + tuple(
        (m - lead_offset) + k for k in bank_order
    )
    engine = SimEngine(
        seed=seed,
        ident=f"val-{seed:06d}-{cylinders}v-4s",
        engine_class="medium-speed V four-stroke" if medium else "high-speed V four-stroke",
        cycle_revolutions=2,
        firing_order=provisional,
        bore=bore,
        crank_radius=radius,
        rod_length=rod_length,
        rod_cg_from_pin=cg,
        cylinder_pitch=pitch,
        bearing_positions=bearings,
        piston_mass=piston,
        rod_mass=rod,
        rod_inertia=rod_inertia,
        crank_unbalance=crank_unbalance,
        counterweight=counterweight,
        throw_inertia=throw,
        flywheel_inertia=flywheel_share * rest,
        driven_inertia=(1 - flywheel_share) * rest,
        compression_ratio=compression,
        inlet_closing=ivc * deg,
        exhaust_opening=evo * deg,
        blowdown=blowdown * deg,
        combustion=law,
        rated_speed=omega,
        rated_imep=imep,
        rated_charge_pressure=charge,
        charge_temperature=_uniform(rng, 320, 350),
        wall_temperature=_uniform(rng, 450, 550),
        friction_mep=friction,
        load_type=load_type,
        peak_pressure_scatter=_uniform(rng, 0.01, 0.02),
        bank_angle=bank * deg,
        leading_bank=leading,
        rods=rods,
        bank_offset=offset if rods == "side-by-side" else 0.0,
        **slave,
    )
    return replace(engine, firing_order=_vee_order(engine.firing_angles))


def engine_of_seed(seed: int, vee: bool = False) -> SimEngine:
    """The true engine of a seed: :func:`random_vee_engine` or :func:`~validation.simulator.random_engine`.

    Parameters
    ----------
    seed : int
    vee : bool, optional
        Draw a V engine.

    Returns
    -------
    SimEngine
    """
    return random_vee_engine(seed) if vee else random_engine(seed)
