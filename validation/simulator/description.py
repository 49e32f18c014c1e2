"""The engine description given to the product: what an operator would know, perturbed."""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from monitor.model.engine import Engine, parse_engine
from validation.simulator.engine import DoubleWiebe, SimEngine
from validation.simulator.gas import burned_fraction, wiebe
from validation.simulator.shared import DESCRIPTION_STREAM, FloatArray


def _fit_single_wiebe(law: DoubleWiebe) -> tuple[float, float]:
    """(duration [rad], m) of the Wiebe law (a = 6.9) from the same start closest to a double Wiebe."""
    theta = np.linspace(law.start, law.end + 0.05, 400)
    target, _ = burned_fraction(theta, law)

    def residual(v: FloatArray) -> FloatArray:
        x, _ = wiebe(theta, law.start, v[0], v[1], 6.9)
        return np.asarray(x - target)

    fit = least_squares(
        residual,
        np.array([law.end - law.start, 1.0]),
        bounds=([math.radians(6.0), 0.05], [math.radians(170.0), 4.5]),
    )
    return float(fit.x[0]), float(fit.x[1])


def _float(value: float) -> str:
    text = f"{value:.6g}"
    return text if any(ch in text for ch in ".en") else text + ".0"


@dataclass(frozen=True)
class _Perturbed:
    """The description's values that differ from the true engine's (see :func:`engine_description`)."""

    bore: float
    stroke: float
    rod: float
    cg: float
    pitch: float
    duration: float  # of the fitted single Wiebe law [rad]
    shape: float  # its m [-]
    start_deg: float
    throw: float
    flywheel: float
    driven: float
    piston_mass: float
    rod_mass: float
    rod_inertia: float
    crank_unbalance: float
    counterweight: float
    compression_ratio: float
    bank_offset: float = 0.0  # a V engine's, side-by-side rods [m]
    slave: tuple[float, ...] = ()  # articulated rods: knuckle radius [m] and angle [rad], slave rod
    # length [m], centre of gravity from its piston pin [m] and mass [kg]


def _perturb(engine: SimEngine) -> _Perturbed:
    """Draw the description's errors from the engine's description stream, in the stream's order."""
    rng = np.random.default_rng(np.random.SeedSequence([engine.seed, DESCRIPTION_STREAM]))

    def geo(v: float) -> float:
        return v * float(rng.uniform(0.98, 1.02))

    def heavy(v: float) -> float:
        return v * float(rng.uniform(0.9, 1.1))

    deg = 180 / math.pi
    bore, stroke, rod = geo(engine.bore), geo(2 * engine.crank_radius), geo(engine.rod_length)
    cg, pitch = geo(engine.rod_cg_from_pin), geo(engine.cylinder_pitch)
    law = engine.combustion
    duration, shape = _fit_single_wiebe(law)
    start_deg = law.start * deg + float(rng.uniform(-3, 3))
    start_deg = min(max(start_deg, engine.inlet_closing * deg + 1), engine.exhaust_opening * deg - 1)
    throw, flywheel, driven = (
        heavy(engine.throw_inertia),
        heavy(engine.flywheel_inertia),
        heavy(engine.driven_inertia),
    )
    piston_mass, rod_mass = heavy(engine.piston_mass), heavy(engine.rod_mass)
    rod_inertia = heavy(engine.rod_inertia)
    crank_unbalance, counterweight = heavy(engine.crank_unbalance), heavy(engine.counterweight)
    compression_ratio = engine.compression_ratio * float(rng.uniform(0.97, 1.03))
    offset = geo(engine.bank_offset) if engine.is_vee else 0.0  # drawn last: in-line streams unchanged
    slave: tuple[float, ...] = ()
    if engine.rods == "articulated":  # after the rest: the other engines' streams unchanged
        slave = (
            geo(engine.knuckle_radius),
            engine.knuckle_angle + math.radians(float(rng.uniform(-1, 1))),
            geo(engine.slave_rod_length),
            geo(engine.slave_rod_cg_from_pin),
            heavy(engine.slave_rod_mass),
        )
    return _Perturbed(
        bore,
        stroke,
        rod,
        cg,
        pitch,
        duration,
        shape,
        start_deg,
        throw,
        flywheel,
        driven,
        piston_mass,
        rod_mass,
        rod_inertia,
        crank_unbalance,
        counterweight,
        compression_ratio,
        offset,
        slave,
    )


def _vee_lines(engine: SimEngine, d: _Perturbed) -> list[str]:
    """A V engine's ``[vee]`` table (the bank angle as the maker states it, the offset perturbed; an
    articulated slave rod's pin and its rod perturbed as the master's, the knuckle angle by +-1 deg)."""
    if not engine.is_vee:
        return []
    lines = [
        "[vee]",
        f"bank_angle_deg = {_float(math.degrees(engine.bank_angle))}",
        f'leading_bank = "{engine.leading_bank}"',
        f'rods = "{engine.rods}"',
        f"bank_offset_m = {_float(d.bank_offset)}",
    ]
    if d.slave:
        knuckle, angle, length, cg, mass = d.slave
        lines += [
            f"knuckle_radius_m = {_float(knuckle)}",
            f"knuckle_angle_deg = {_float(math.degrees(angle))}",
            f"slave_rod_length_m = {_float(length)}",
            f"slave_rod_kg = {_float(mass)}",
            f"slave_rod_cg_from_piston_pin_m = {_float(cg)}",
        ]
    return [*lines, ""]


def _firing_line(engine: SimEngine) -> str:
    """The firing order: by number in line, by name (``"A1"``, ``"B3"``) on a V."""
    if not engine.is_vee:
        return f"order = [{', '.join(str(c) for c in engine.firing_order)}]"
    names = engine.cylinder_names
    return f"order = [{', '.join(chr(34) + names[c - 1] + chr(34) for c in engine.firing_order)}]"


def _shaft_line_lines(d: _Perturbed, stiffness: float, machine: str, damping: float) -> list[str]:
    """The description's shaft line: throws, flywheel and driven machine on stiff connections."""
    return [
        "[shaft_line]",
        f"throw_inertia_kgm2 = {_float(d.throw)}",
        f"throw_stiffness_nm_per_rad = {_float(stiffness)}",
        'tooth_wheel = "flywheel"',
        "",
        "[[shaft_line.driven_end]]",
        'name = "flywheel"',
        'kind = "flywheel"',
        f"inertia_kgm2 = {_float(d.flywheel)}",
        f"stiffness_to_previous_nm_per_rad = {_float(stiffness)}",
        "",
        "[[shaft_line.driven_end]]",
        f'name = "{machine}"',
        f'kind = "{machine}"',
        f"inertia_kgm2 = {_float(d.driven)}",
        f"stiffness_to_previous_nm_per_rad = {_float(stiffness)}",
        f"absolute_damping_nms_per_rad = {_float(damping)}",
        "",
    ]


def engine_description(engine: SimEngine) -> str:
    """The engine description (TOML) given to the product: what an operator would know, perturbed.

    Parameters
    ----------
    engine : SimEngine

    Returns
    -------
    str
        TOML text accepted by ``monitor.model.engine.parse_engine`` (checked before returning).

    Notes
    -----
    Perturbations, from the engine's own stream (so every case of the engine gets the same file):
    bore, stroke, rod length, rod centre of gravity and cylinder pitch +-2 %; masses, rod inertia,
    unbalances and every inertia +-10 %; combustion start +-3 deg; compression ratio +-3 %.  The
    combustion is one Wiebe law from the true start, its duration and shape fitted to the true
    double Wiebe's burned fraction (least squares); rated IMEP, charge pressure and valve timing
    are the true ones.  The simulated crank is rigid, so the shaft line states its
    connections as stiff: ``10 J (50 omega_rated)^2`` with ``J`` the whole rigid inertia, which puts
    every torsional mode far above the 50th order.  A V engine's file has a ``[vee]`` table (its true
    bank angle, leading bank and rods, its bank offset +-2 %) and its firing order by name.
    """
    d = _perturb(engine)
    deg = 180 / math.pi
    law = engine.combustion
    # stiff enough that even the whole rigid inertia on one connection rings at 50 x the rated speed
    stiffness = 10 * engine.rigid_inertia * (50 * engine.rated_speed) ** 2
    rated_rpm = engine.rated_speed * 30 / math.pi
    power = (
        (engine.rated_imep - engine.friction_mep)
        * engine.swept_volume
        * engine.cylinders
        * engine.rated_speed
        / engine.cycle_angle
        / 1000
    )
    machine = "propeller" if engine.load_type == "propeller" else "generator"
    damping = 0.0
    if engine.load_type == "propeller":
        damping = 2 * (engine.rated_indicated_torque - engine.friction_torque) / engine.rated_speed
    kind_text = "two-stroke" if engine.cycle_revolutions == 1 else "four-stroke"
    lines = [
        f"# Simulated engine of validation case seed {engine.seed} ({engine.engine_class}); written by",
        "# validation.simulator with the errors a real description has (geometry +-2 %, masses +-10 %,",
        "# combustion start +-3 deg, compression ratio +-3 %).",
        f'id = "{engine.ident}"',
        f'name = "{engine.cylinders}-cylinder {engine.engine_class}, simulated (seed {engine.seed})"',
        f'cycle = "{kind_text}"',
        f"cylinders = {engine.cylinders}",
        'notes = "Validation engine; its simulator has a rigid crankshaft."',
        "",
        "[geometry]",
        f"bore_m = {_float(d.bore)}",
        f"stroke_m = {_float(d.stroke)}",
        f"rod_length_m = {_float(d.rod)}",
        f"cylinder_pitch_m = {_float(d.pitch)}",
        "",
        *_vee_lines(engine, d),
        "[masses]",
        f"piston_assembly_kg = {_float(d.piston_mass)}",
        f"conrod_kg = {_float(d.rod_mass)}",
        f"conrod_cg_from_piston_pin_m = {_float(min(d.cg, 0.95 * d.rod))}",
        f"conrod_inertia_kgm2 = {_float(d.rod_inertia)}",
        f"crank_unbalance_kgm = {_float(d.crank_unbalance)}",
        f"counterweight_kgm = {_float(d.counterweight)}",
        "",
        "[firing]",
        _firing_line(engine),
        "",
        "[operation]",
        f"rated_speed_rpm = {_float(rated_rpm)}",
        f"rated_power_kw = {_float(power)}",
        "",
        "[combustion]",
        f"rated_imep_bar = {_float(engine.rated_imep / 1e5)}",
        f"compression_ratio = {_float(d.compression_ratio)}",
        f"intake_pressure_bar = {_float(engine.rated_charge_pressure / 1e5)}",
        f"inlet_closing_deg = {_float(engine.inlet_closing * deg)}",
        f"exhaust_opening_deg = {_float(engine.exhaust_opening * deg)}",
        f"blowdown_deg = {_float(engine.blowdown * deg)}",
        f"combustion_start_deg = {_float(d.start_deg)}",
        f"combustion_duration_deg = {_float(d.duration * deg)}",
        f"wiebe_a = {_float(law.a)}",
        f"wiebe_m = {_float(d.shape)}",
        "",
        *_shaft_line_lines(d, stiffness, machine, damping),
    ]
    text = "\n".join(lines)
    description_engine(text)  # refuse to hand out a description the product would refuse
    return text


def description_engine(text: str) -> Engine:
    """Parse a description with the product's own validation.

    Parameters
    ----------
    text : str
        TOML.

    Returns
    -------
    monitor.model.engine.Engine

    Raises
    ------
    monitor.errors.EngineDescriptionError
        If the product refuses it.
    """
    return parse_engine(tomllib.loads(text), origin="validation description")
