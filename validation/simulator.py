"""A second engine simulator, independent of the product's, for validating its diagnosis.

Everything here is written from first principles and shares no code with the product's scene
simulator or physics (``monitor.scene``, ``monitor.model.crankshaft``, ``monitor.model.gas``,
``monitor.model.forces``, ``monitor.model.predicted``, ``monitor.torsion``). From ``monitor`` it uses only
the recording containers (:class:`~monitor.io.recording.Channel`, :class:`~monitor.io.recording.Recording`),
their clipping check, and the engine-description parser, to prove that the description it writes
for each case is one the product accepts.

The models, and how they differ from the product's
------------------------------------------------------------------------------------------------
Engine.  A random engine of one of four classes (slow two-stroke crosshead, 60-200 rpm;
medium-speed four-stroke, 300-1000 rpm; high-speed four-stroke, 1000-1500 rpm; small two-stroke,
300-1000 rpm), 1 to 12 cylinders, even firing.  Bore and stroke follow from a mean piston speed
and a stroke-to-bore ratio typical of the class, masses scale with the bore cubed, and the
flywheel is sized for a cyclic irregularity typical of the drive (gensets 1/300-1/150,
propulsion 1/150-1/70).

Cylinder pressure (:func:`closed_cycle`, :func:`cycle_table`).  A single-zone first-law model of
the closed part of the cycle (inlet closing to exhaust opening), integrated in temperature with
``scipy.integrate.solve_ivp``::

    m c_v(T) dT/dtheta = dQ_c/dtheta - dQ_w/dtheta - p dV/dtheta,      p = m R T / V,

with ``c_v(T) = R / (gamma(T) - 1)`` and a temperature-dependent ratio of specific heats
``gamma(T) = 1.39 - 6.5e-5 (T - 300 K)``, a double-Wiebe heat release (a premixed and a
diffusion phase, :func:`burned_fraction`) and a wall heat loss ``dQ_w/dt = h A_w (T - T_w)`` with
Woschni's motored-engine coefficient (:func:`wall_heat_transfer_coefficient`).  The open part is
an exponential blowdown from exhaust opening and a gas exchange at exhaust and charge pressure.
Misfire is a motored cycle (no heat release), a weak cylinder's heat is scaled by 0.5-0.8.

Crank dynamics (:func:`run_crank`).  One rigid crankshaft whose kinetic energy is
``E = J(alpha) omega^2 / 2``, ``J`` including every rod's and piston's exact kinetic energy (no
two-mass split).  Lagrange's equation with the crank angle ``alpha`` as the independent variable
is the energy balance ``dE/dalpha = T_gas(alpha) - T_friction - T_load``; with a propeller load
``T_load = k omega^2 = 2 k E / J`` this is linear in ``E`` and is integrated exactly over each
cycle with an integrating factor; a generator load is a constant torque with a PI speed governor
that sets the fuel of the cycle after next.  Each cylinder's heat release varies from cycle to
cycle by a random 1-2 % of its peak pressure.

Main-bearing forces (:func:`throw_vertical_force`, :func:`bearing_split`).  Newton's law on the
free bodies of piston, rod and throw gives the vertical force a throw puts on its bearings:
``F = -(p - p_amb) A - sum_i m_i ddot(y_i)`` over piston, rod centre of gravity and the throw's
net unbalance.  It is shared by its two main bearings by the lever rule at the true (slightly
irregular) bearing positions.

Structure and sensors.  A bearing's accelerometer sees its own bearing's vertical force plus 5-20 %
of each neighbouring bearing's, through two or three structural modes in parallel, each a
second-order IIR filter (bilinear transform of ``g s^2 / (s^2 + 2 zeta w s + w^2)``), then an
anti-aliasing filter; plus broadband noise, mains hum (50 or 60 Hz with its third harmonic) and
16-bit quantisation over a stated range.  Angle sensors are event channels: a 60-2 tooth wheel
with pitch errors (0.02 deg rms) and timing jitter, a cam pulse once per cycle on four-strokes,
sometimes a keyphasor.

Faults (one per case, or none).  ``misfire``: one cylinder motored.  ``weak``: one cylinder's heat
release times 0.5-0.8.  ``worn_bearing``: short decaying 2-8 kHz bursts (a two-pole resonator
struck at each event) on a bearing's sensor where that bearing's vertical load reverses sign
(where it never does, at the prominent minima of its magnitude), 3-6 times that sensor's noise,
and on the other sensors with that ratio times 0.15-0.35 per bearing of distance.
``sensor_fault``: one bearing channel clipped (its range lowered until the peaks are cut),
dead (flat, or noise only), or in the wrong unit (data x 1000 or / 9.81, range with them).
A generator engine keeps its speed through a misfire or a weak cylinder by giving the others
more fuel; a propeller engine at a fixed fuel slows down.

The description given to the product (:func:`engine_description`) is what an operator would know,
perturbed as real files differ from real engines: geometry +-2 %, masses and inertias +-10 %,
combustion start +-3 deg, compression ratio +-3 %; its combustion is a single Wiebe law fitted to
the true double Wiebe, and its shaft line states the simulated rigid crank as stiff elements.

Randomness.  Every number comes from ``numpy.random.default_rng`` seeded by the case seed only, in
separate streams for the engine, its installation, its description, the operating point and fault,
and the noise; the same engine with another noise stream is :func:`healthy_twin`.

References
----------
Heywood, J. B., Internal Combustion Engine Fundamentals, 2nd ed., McGraw-Hill 2018: sec. 9.2
(Wiebe function, single-zone heat-release analysis), sec. 12.4 (Woschni's correlation).
Woschni, G., "A universally applicable equation for the instantaneous heat transfer coefficient
in the internal combustion engine", SAE 670931, 1967, doi:10.4271/670931.
Miyamoto, N. et al., "Description and analysis of diesel engine rate of combustion and
performance using Wiebe's functions", SAE 850107, 1985, doi:10.4271/850107 (double Wiebe).
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from functools import lru_cache
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
from scipy import signal
from scipy.integrate import solve_ivp
from scipy.optimize import least_squares

from monitor.io.recording import Channel, Recording, quality_spans
from monitor.model.engine import Engine, parse_engine

__all__ = [
    "AMBIENT_PRESSURE",
    "FAULT_CLASSES",
    "GAMMA_300",
    "GAMMA_SLOPE",
    "GAS_CONSTANT",
    "HEAT_LEVELS",
    "HEAT_STEP",
    "Case",
    "ClosedCycle",
    "CrankRun",
    "CycleTable",
    "DoubleWiebe",
    "Installation",
    "Load",
    "SimEngine",
    "SimulationError",
    "SliderCrank",
    "bearing_split",
    "burned_fraction",
    "closed_cycle",
    "cycle_table",
    "description_engine",
    "engine_description",
    "equivalent_inertia",
    "gamma",
    "healthy_twin",
    "internal_energy",
    "operating_load",
    "population",
    "random_case",
    "random_engine",
    "random_installation",
    "rated_heat",
    "run_crank",
    "slider_crank",
    "throw_vertical_force",
    "wall_heat_transfer_coefficient",
]

FloatArray = npt.NDArray[np.float64]

#: Specific gas constant of the cylinder charge [J/(kg K)].
GAS_CONSTANT = 287.0
#: Ratio of specific heats at 300 K [-] and its fall per kelvin [1/K] (linear fit for air/burned gas).
GAMMA_300 = 1.39
GAMMA_SLOPE = 6.5e-5
#: Ambient (crankcase) pressure [Pa].
AMBIENT_PRESSURE = 1.013e5
#: Fuel (heat release) levels of a cycle table, in units of the engine's rated heat [-].
HEAT_STEP = 0.05
HEAT_LEVELS = 33  # 0 .. 1.6
#: The fault classes of a case.
FAULT_CLASSES: tuple[str, ...] = ("healthy", "misfire", "weak", "worn_bearing", "sensor_fault")

# random streams (second word of the seed sequence)
_ENGINE, _INSTALLATION, _DESCRIPTION, _OPERATION, _NOISE = range(5)
_TWIN = 1  # third word of a healthy twin's noise stream


class SimulationError(RuntimeError):
    """The simulation cannot produce the case asked for (e.g. the engine stalls); the message says why."""


# =============================================================================== the engine
@dataclass(frozen=True)
class DoubleWiebe:
    """Heat release as two Wiebe functions: a premixed and a diffusion phase.

    Attributes
    ----------
    start : float
        Start of the premixed phase, from firing TDC [rad].
    premixed_fraction : float
        Share of the heat released in the premixed phase [-].
    premixed_duration, diffusion_duration : float
        Durations of the phases [rad].
    premixed_shape, diffusion_shape : float
        Wiebe shape exponents m [-].
    diffusion_delay : float
        Start of the diffusion phase after ``start`` [rad].
    a : float
        Wiebe efficiency parameter (6.9: 99.9 % burned at the end of a phase) [-].
    """

    start: float
    premixed_fraction: float
    premixed_duration: float
    premixed_shape: float
    diffusion_delay: float
    diffusion_duration: float
    diffusion_shape: float
    a: float = 6.9

    @property
    def end(self) -> float:
        """End of combustion, from firing TDC [rad]."""
        return max(
            self.start + self.premixed_duration,
            self.start + self.diffusion_delay + self.diffusion_duration,
        )


@dataclass(frozen=True)
class SimEngine:
    """The true engine of a case (SI units throughout).

    Attributes
    ----------
    seed : int
        The case seed it was drawn from.
    ident : str
        Engine id, unique per seed (``^[a-z0-9][a-z0-9._-]*$``).
    engine_class : str
        "slow two-stroke", "medium-speed four-stroke", "high-speed four-stroke" or "small two-stroke".
    cycle_revolutions : int
        1 (two-stroke) or 2 (four-stroke).
    firing_order : tuple of int
        Cylinders (1-based, numbered from the free end) in firing order, cylinder 1 first.
    bore, crank_radius, rod_length : float
        [m].
    rod_cg_from_pin : float
        Rod centre of gravity from the piston (crosshead) pin [m].
    cylinder_pitch : float
        [m].
    bearing_positions : ndarray
        True axial positions of the n + 1 main bearings from bearing 1 [m].
    piston_mass, rod_mass : float
        Piston assembly (with rod and crosshead on a crosshead engine), connecting rod [kg].
    rod_inertia : float
        Rod's moment of inertia about its centre of gravity [kg m^2].
    crank_unbalance, counterweight : float
        Mass times radius of crank pin and webs, and of the counterweights [kg m].
    throw_inertia, flywheel_inertia, driven_inertia : float
        Rotating inertia of one throw, of the flywheel, of the rigidly coupled driven machine [kg m^2].
    compression_ratio : float
        Geometric [-].
    inlet_closing, exhaust_opening, blowdown : float
        Start and end of the closed cycle from firing TDC, and the blowdown duration [rad].
    combustion : DoubleWiebe
    rated_speed : float
        [rad/s].
    rated_imep : float
        Indicated mean effective pressure at rated load [Pa].
    rated_charge_pressure : float
        Absolute charge (scavenge) air pressure at rated load [Pa].
    charge_temperature, wall_temperature : float
        Charge temperature at inlet closing, mean combustion-chamber wall temperature [K].
    friction_mep : float
        Friction mean effective pressure [Pa].
    load_type : str
        "propeller" (torque proportional to speed squared) or "generator" (governed, constant torque).
    peak_pressure_scatter : float
        Cycle-to-cycle standard deviation of a cylinder's peak pressure, relative [-].
    """

    seed: int
    ident: str
    engine_class: str
    cycle_revolutions: int
    firing_order: tuple[int, ...]
    bore: float
    crank_radius: float
    rod_length: float
    rod_cg_from_pin: float
    cylinder_pitch: float
    bearing_positions: FloatArray
    piston_mass: float
    rod_mass: float
    rod_inertia: float
    crank_unbalance: float
    counterweight: float
    throw_inertia: float
    flywheel_inertia: float
    driven_inertia: float
    compression_ratio: float
    inlet_closing: float
    exhaust_opening: float
    blowdown: float
    combustion: DoubleWiebe
    rated_speed: float
    rated_imep: float
    rated_charge_pressure: float
    charge_temperature: float
    wall_temperature: float
    friction_mep: float
    load_type: Literal["propeller", "generator"]
    peak_pressure_scatter: float

    @property
    def cylinders(self) -> int:
        """Number of cylinders."""
        return len(self.firing_order)

    @property
    def cycle_angle(self) -> float:
        """Crank angle of one working cycle [rad]."""
        return 2 * math.pi * self.cycle_revolutions

    @property
    def piston_area(self) -> float:
        """[m^2]."""
        return math.pi * self.bore**2 / 4

    @property
    def swept_volume(self) -> float:
        """Of one cylinder [m^3]."""
        return self.piston_area * 2 * self.crank_radius

    @property
    def clearance_volume(self) -> float:
        """[m^3]."""
        return self.swept_volume / (self.compression_ratio - 1)

    @property
    def firing_angles(self) -> FloatArray:
        """Angle of cylinder 1's crank at which each cylinder (index c - 1) fires [rad]."""
        angles = np.empty(self.cylinders)
        step = self.cycle_angle / self.cylinders
        for position, cylinder in enumerate(self.firing_order):
            angles[cylinder - 1] = position * step
        return angles

    @property
    def cylinder_positions(self) -> FloatArray:
        """True axial position of each cylinder from bearing 1 [m]: mid-bay of the nominal pitch."""
        return np.asarray(self.cylinder_pitch * (np.arange(self.cylinders, dtype=np.float64) + 0.5))

    @property
    def throw_bearings(self) -> list[tuple[int, int]]:
        """The main bearings (1-based) each throw sits between."""
        return [(c, c + 1) for c in range(1, self.cylinders + 1)]

    @property
    def bearing_count(self) -> int:
        """Number of main bearings."""
        return self.cylinders + 1

    @property
    def rigid_inertia(self) -> float:
        """Constant part of the crank's inertia: throws, flywheel, driven machine [kg m^2]."""
        return self.cylinders * self.throw_inertia + self.flywheel_inertia + self.driven_inertia

    @property
    def friction_torque(self) -> float:
        """Mean friction torque [N m] (friction mep over one cycle of all cylinders)."""
        return self.friction_mep * self.swept_volume * self.cylinders / self.cycle_angle

    @property
    def rated_indicated_torque(self) -> float:
        """Mean indicated torque at rated load [N m]."""
        return self.rated_imep * self.swept_volume * self.cylinders / self.cycle_angle


_FIRING_ORDERS: dict[tuple[int, int], tuple[tuple[int, ...], ...]] = {
    # four-stroke, in-line (usual orders; the 10- and 11-cylinder ones are plausible permutations)
    (2, 1): ((1,),),
    (2, 2): ((1, 2),),
    (2, 3): ((1, 3, 2), (1, 2, 3)),
    (2, 4): ((1, 3, 4, 2), (1, 2, 4, 3)),
    (2, 5): ((1, 2, 4, 5, 3), (1, 3, 5, 4, 2)),
    (2, 6): ((1, 5, 3, 6, 2, 4), (1, 4, 2, 6, 3, 5)),
    (2, 7): ((1, 2, 4, 6, 7, 5, 3), (1, 3, 5, 7, 6, 4, 2)),
    (2, 8): ((1, 6, 2, 5, 8, 3, 7, 4), (1, 4, 7, 6, 8, 5, 2, 3)),
    (2, 9): ((1, 7, 4, 2, 8, 6, 3, 9, 5), (1, 6, 3, 2, 8, 7, 4, 9, 5)),
    (2, 10): ((1, 6, 3, 8, 5, 10, 4, 9, 2, 7),),
    (2, 11): ((1, 4, 9, 6, 2, 10, 7, 3, 11, 5, 8),),
    (2, 12): ((1, 7, 5, 11, 3, 9, 6, 12, 2, 8, 4, 10), (1, 12, 5, 8, 3, 10, 6, 7, 2, 11, 4, 9)),
    # two-stroke
    (1, 1): ((1,),),
    (1, 2): ((1, 2),),
    (1, 3): ((1, 3, 2), (1, 2, 3)),
    (1, 4): ((1, 4, 3, 2), (1, 3, 2, 4)),
    (1, 5): ((1, 4, 3, 2, 5), (1, 5, 2, 3, 4)),
    (1, 6): ((1, 5, 3, 4, 2, 6), (1, 6, 2, 4, 3, 5)),
    (1, 7): ((1, 7, 2, 5, 4, 3, 6),),
    (1, 8): ((1, 8, 3, 4, 7, 2, 5, 6),),
    (1, 9): ((1, 6, 7, 3, 5, 8, 2, 4, 9),),
    (1, 10): ((1, 8, 7, 3, 5, 10, 2, 6, 4, 9),),
    (1, 11): ((1, 8, 11, 4, 5, 9, 2, 7, 10, 3, 6),),
    (1, 12): ((1, 8, 11, 4, 5, 9, 2, 7, 12, 3, 6, 10),),
}


def _uniform(rng: np.random.Generator, low: float, high: float) -> float:
    return float(rng.uniform(low, high))


def _log_uniform(rng: np.random.Generator, low: float, high: float) -> float:
    return float(math.exp(rng.uniform(math.log(low), math.log(high))))


def random_engine(seed: int) -> SimEngine:
    """Draw the true engine of a case.

    Parameters
    ----------
    seed : int
        The case seed, >= 0 (the engine comes from its own random stream of that seed).

    Returns
    -------
    SimEngine

    Notes
    -----
    Stroke ``S = c_m 30 / n`` from a mean piston speed ``c_m`` [m/s] and the rated speed ``n``
    [rpm], bore from a stroke-to-bore ratio typical of the class; piston assembly mass
    ``k_p D^3`` (``k_p`` about 6300 kg/m^3 for a crosshead engine with piston rod and
    crosshead, 3000 for a trunk piston), rod 1.0-1.5 times that; throw inertia
    ``(1.5-2.5) (m_p + m_r) R^2``; total rigid inertia ``J = dE / (delta omega^2)`` with an
    estimated energy fluctuation ``dE`` per cycle and a cyclic irregularity ``delta`` of the drive.
    """
    if seed < 0:
        raise ValueError(f"seed = {seed}: expected an integer >= 0")
    rng = np.random.default_rng(np.random.SeedSequence([seed, _ENGINE]))
    classes = ("slow two-stroke", "medium-speed four-stroke", "high-speed four-stroke", "small two-stroke")
    engine_class = classes[int(rng.choice(4, p=[0.3, 0.35, 0.25, 0.1]))]
    deg = math.pi / 180
    if engine_class == "slow two-stroke":
        rpm = _log_uniform(rng, 60.0, 200.0)
        cylinders = int(rng.integers(4, 13))
        piston_speed, stroke_bore, rod_ratio = _uniform(rng, 6.5, 9.0), _uniform(rng, 3.2, 4.4), 0.0
        rod_ratio = _uniform(rng, 0.40, 0.48)
        revs, crosshead = 1, True
        imep, charge = _uniform(rng, 17e5, 21e5), _uniform(rng, 3.2e5, 4.0e5)
        compression = _uniform(rng, 17.0, 21.0)
        friction = _uniform(rng, 0.6e5, 1.0e5)
        ivc, evo, blowdown = -_uniform(rng, 100, 120), _uniform(rng, 105, 120), _uniform(rng, 30, 45)
        law = DoubleWiebe(
            start=_uniform(rng, -5, 0) * deg,
            premixed_fraction=_uniform(rng, 0.05, 0.15),
            premixed_duration=_uniform(rng, 6, 10) * deg,
            premixed_shape=_uniform(rng, 1.5, 2.5),
            diffusion_delay=_uniform(rng, 2, 5) * deg,
            diffusion_duration=_uniform(rng, 45, 70) * deg,
            diffusion_shape=_uniform(rng, 0.7, 1.2),
        )
    elif engine_class == "small two-stroke":
        rpm = _uniform(rng, 300.0, 1000.0)
        cylinders = int(rng.integers(1, 5))
        piston_speed, stroke_bore = _uniform(rng, 4.0, 7.0), _uniform(rng, 1.1, 2.0)
        rod_ratio = _uniform(rng, 0.22, 0.30)
        revs, crosshead = 1, False
        imep, charge = _uniform(rng, 4e5, 7e5), _uniform(rng, 1.05e5, 1.2e5)
        compression = _uniform(rng, 6.0, 9.0)
        friction = _uniform(rng, 0.4e5, 0.8e5)
        ivc, evo, blowdown = -_uniform(rng, 100, 115), _uniform(rng, 95, 110), _uniform(rng, 30, 40)
        law = DoubleWiebe(
            start=_uniform(rng, -18, -8) * deg,
            premixed_fraction=_uniform(rng, 0.2, 0.5),
            premixed_duration=_uniform(rng, 10, 20) * deg,
            premixed_shape=_uniform(rng, 1.5, 2.5),
            diffusion_delay=_uniform(rng, 4, 8) * deg,
            diffusion_duration=_uniform(rng, 40, 60) * deg,
            diffusion_shape=_uniform(rng, 1.0, 2.0),
        )
    else:
        medium = engine_class == "medium-speed four-stroke"
        if medium:
            rpm = _log_uniform(rng, 300.0, 1000.0)
            counts = [4, 5, 6, 7, 8, 9, 10, 12]
            cylinders = int(rng.choice(counts, p=[0.08, 0.08, 0.3, 0.08, 0.16, 0.14, 0.06, 0.1]))
            piston_speed, stroke_bore = _uniform(rng, 8.0, 10.5), _uniform(rng, 1.15, 1.45)
            rod_ratio = _uniform(rng, 0.22, 0.30)
            imep, charge = _uniform(rng, 20e5, 27e5), _uniform(rng, 3.0e5, 4.5e5)
            compression = _uniform(rng, 12.5, 15.0)
            friction = _uniform(rng, 0.9e5, 1.4e5)
        else:
            rpm = _log_uniform(rng, 1000.0, 1500.0)
            cylinders = int(
                rng.choice(np.arange(1, 13), p=np.array([3, 2, 2, 3, 1, 3, 1, 2, 1, 1, 1, 2]) / 22)
            )
            piston_speed, stroke_bore = _uniform(rng, 9.0, 11.5), _uniform(rng, 1.05, 1.3)
            rod_ratio = _uniform(rng, 0.24, 0.32)
            imep, charge = _uniform(rng, 16e5, 24e5), _uniform(rng, 2.2e5, 3.5e5)
            compression = _uniform(rng, 14.0, 17.0)
            friction = _uniform(rng, 1.0e5, 1.6e5)
        revs, crosshead = 2, False
        ivc, evo, blowdown = -_uniform(rng, 200, 220), _uniform(rng, 120, 140), _uniform(rng, 40, 55)
        law = DoubleWiebe(
            start=_uniform(rng, -8, -2) * deg,
            premixed_fraction=_uniform(rng, 0.05, 0.3),
            premixed_duration=_uniform(rng, 5, 12) * deg,
            premixed_shape=_uniform(rng, 1.5, 3.0),
            diffusion_delay=_uniform(rng, 3, 6) * deg,
            diffusion_duration=_uniform(rng, 40, 70) * deg,
            diffusion_shape=_uniform(rng, 0.6, 1.2),
        )
    stroke = min(piston_speed * 30.0 / rpm, 3.6)
    bore = stroke / stroke_bore
    radius = stroke / 2
    rod_length = radius / rod_ratio
    density = _uniform(rng, 5500, 7000) if crosshead else _uniform(rng, 2500, 3500)
    piston = density * bore**3
    rod = piston * (_uniform(rng, 1.1, 1.5) if crosshead else _uniform(rng, 1.0, 1.3))
    cg = rod_length * _uniform(rng, 0.55, 0.70)
    rod_inertia = rod * (rod_length * _uniform(rng, 0.26, 0.33)) ** 2
    crank_unbalance = _uniform(rng, 0.6, 1.0) * rod * radius
    counterweight = _uniform(rng, 0.4, 1.1) * crank_unbalance
    throw = _uniform(rng, 1.5, 2.5) * (piston + rod) * radius**2
    order_choices = _FIRING_ORDERS[(revs, cylinders)]
    firing_order = order_choices[int(rng.integers(len(order_choices)))]
    load_type: Literal["propeller", "generator"]
    if engine_class == "slow two-stroke":
        load_type = "propeller"
    else:
        load_type = "propeller" if rng.random() < 0.5 else "generator"
    irregularity = 1 / _uniform(rng, 150, 300) if load_type == "generator" else 1 / _uniform(rng, 70, 150)
    omega = rpm * math.pi / 30
    work = imep * math.pi * bore**2 / 4 * stroke
    fluctuation = work * (1.3 if cylinders == 1 else 0.8 if cylinders == 2 else 0.35)
    recip_mean = cylinders * (piston + 0.5 * rod) * radius**2 * 0.5
    rest = fluctuation / (irregularity * omega**2) - cylinders * throw - recip_mean
    rest = max(rest, 0.3 * cylinders * throw)
    flywheel_share = _uniform(rng, 0.4, 0.8)
    pitch = bore * _uniform(rng, 1.6, 1.9)
    bearings = pitch * (np.arange(cylinders + 1) + rng.uniform(-0.02, 0.02, cylinders + 1))
    bearings -= bearings[0]
    return SimEngine(
        seed=seed,
        ident=f"val-{seed:06d}-{cylinders}cyl-{'2s' if revs == 1 else '4s'}",
        engine_class=engine_class,
        cycle_revolutions=revs,
        firing_order=tuple(int(c) for c in firing_order),
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
        charge_temperature=_uniform(rng, 320, 350) + (10.0 if revs == 1 else 0.0),
        wall_temperature=_uniform(rng, 450, 550),
        friction_mep=friction,
        load_type=load_type,
        peak_pressure_scatter=_uniform(rng, 0.01, 0.02),
    )


# =============================================================================== kinematics
@dataclass(frozen=True)
class SliderCrank:
    """Positions and their derivatives in the crank angle of one cylinder's crank train.

    ``y`` is measured along the cylinder axis from the crank axis towards the head, ``x`` across
    it; ``phi`` is the rod's angle to the cylinder axis. Primes are derivatives in the crank angle.

    Attributes
    ----------
    piston, piston_1, piston_2 : ndarray
        Piston pin height y_p and its first and second derivatives [m], [m/rad], [m/rad^2].
    rod_x_1, rod_x_2, rod_y_1, rod_y_2 : ndarray
        Derivatives of the rod centre of gravity's position [m/rad], [m/rad^2].
    rod_angle_1, rod_angle_2 : ndarray
        Derivatives of the rod angle [-], [1/rad].
    """

    piston: FloatArray
    piston_1: FloatArray
    piston_2: FloatArray
    rod_x_1: FloatArray
    rod_x_2: FloatArray
    rod_y_1: FloatArray
    rod_y_2: FloatArray
    rod_angle_1: FloatArray
    rod_angle_2: FloatArray


def slider_crank(
    crank_angle: npt.ArrayLike, *, crank_radius: float, rod_length: float, rod_cg_from_pin: float
) -> SliderCrank:
    """Exact slider-crank kinematics.

    Parameters
    ----------
    crank_angle : array_like
        The cylinder's crank angle from its TDC, psi [rad].
    crank_radius : float
        R [m].
    rod_length : float
        L, pin centre to pin centre [m].
    rod_cg_from_pin : float
        a, the rod's centre of gravity from the piston pin [m].

    Returns
    -------
    SliderCrank

    Notes
    -----
    ``sin phi = lambda sin psi`` (``lambda = R / L``); crank pin at ``(R sin psi, R cos psi)``,
    piston pin at ``(0, y_p)`` with ``y_p = R cos psi + L cos phi``, rod centre of gravity at
    ``((a / L) R sin psi, R cos psi + (L - a) cos phi)``.  ``phi' = lambda cos psi / cos phi`` and
    ``phi'' = lambda (cos psi sin phi phi' - sin psi cos phi) / cos^2 phi``.
    """
    psi = np.asarray(crank_angle, dtype=np.float64)
    r, length, a = crank_radius, rod_length, rod_cg_from_pin
    lam = r / length
    s, c = np.sin(psi), np.cos(psi)
    sin_phi = lam * s
    cos_phi = np.sqrt(1 - sin_phi**2)
    phi_1 = lam * c / cos_phi
    phi_2 = lam * (c * sin_phi * phi_1 - s * cos_phi) / cos_phi**2
    bend = cos_phi * phi_1**2 + sin_phi * phi_2  # d^2(cos phi)/dpsi^2 with the sign flipped
    return SliderCrank(
        piston=r * c + length * cos_phi,
        piston_1=-r * s - length * sin_phi * phi_1,
        piston_2=-r * c - length * bend,
        rod_x_1=(a / length) * r * c,
        rod_x_2=-(a / length) * r * s,
        rod_y_1=-r * s - (length - a) * sin_phi * phi_1,
        rod_y_2=-r * c - (length - a) * bend,
        rod_angle_1=phi_1,
        rod_angle_2=phi_2,
    )


def _kinematics(engine: SimEngine, psi: npt.ArrayLike) -> SliderCrank:
    return slider_crank(
        psi,
        crank_radius=engine.crank_radius,
        rod_length=engine.rod_length,
        rod_cg_from_pin=engine.rod_cg_from_pin,
    )


def equivalent_inertia(engine: SimEngine, crank_angle: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """One cylinder's piston and rod as an inertia on the crank, and its derivative.

    Parameters
    ----------
    engine : SimEngine
    crank_angle : array_like
        The cylinder's crank angle from its TDC [rad].

    Returns
    -------
    inertia, derivative : ndarray
        ``J_c`` [kg m^2] and ``dJ_c/dpsi`` [kg m^2/rad].

    Notes
    -----
    From the kinetic energy ``T = J_c omega^2 / 2`` of piston and rod (exact, no two-mass split):
    ``J_c = m_p y_p'^2 + m_r (x_g'^2 + y_g'^2) + I_r phi'^2``.
    """
    k = _kinematics(engine, crank_angle)
    mp, mr, ir = engine.piston_mass, engine.rod_mass, engine.rod_inertia
    inertia = mp * k.piston_1**2 + mr * (k.rod_x_1**2 + k.rod_y_1**2) + ir * k.rod_angle_1**2
    derivative = 2 * (
        mp * k.piston_1 * k.piston_2
        + mr * (k.rod_x_1 * k.rod_x_2 + k.rod_y_1 * k.rod_y_2)
        + ir * k.rod_angle_1 * k.rod_angle_2
    )
    return inertia, derivative


def _inertia_force_coefficients(engine: SimEngine, psi: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """``K2, K1`` with ``sum_i m_i ddot(y_i) = K2 omega^2 + K1 omega_dot``, piston, rod, throw [kg m]."""
    k = _kinematics(engine, psi)
    psi = np.asarray(psi, dtype=np.float64)
    net = engine.crank_unbalance - engine.counterweight  # throw's mass x radius towards the pin
    k2 = engine.piston_mass * k.piston_2 + engine.rod_mass * k.rod_y_2 - net * np.cos(psi)
    k1 = engine.piston_mass * k.piston_1 + engine.rod_mass * k.rod_y_1 - net * np.sin(psi)
    return k2, k1


def throw_vertical_force(
    engine: SimEngine,
    crank_angle: npt.ArrayLike,
    pressure: npt.ArrayLike,
    speed: npt.ArrayLike,
    acceleration: npt.ArrayLike,
) -> FloatArray:
    """Vertical force of one throw on its main bearings, upwards (towards the head) positive.

    Parameters
    ----------
    engine : SimEngine
    crank_angle : array_like
        The cylinder's crank angle from its TDC [rad].
    pressure : array_like
        Its cylinder pressure, absolute [Pa].
    speed : array_like
        Crank speed [rad/s].
    acceleration : array_like
        Crank angular acceleration [rad/s^2].

    Returns
    -------
    ndarray
        [N].

    Notes
    -----
    Newton's second law along the cylinder axis for piston, rod and throw, each a free body: the
    rod passes the piston's load plus its own inertia to the crank pin, and the throw passes
    that plus its own to the bearings, so ``F = -(p - p_amb) A - (m_p ddot(y_p) + m_r ddot(y_g)
    + u ddot(cos psi))`` with ``ddot(y) = y'' omega^2 + y' omega_dot`` and the throw's net
    unbalance ``u`` (crank pin and webs less counterweights) [kg m].
    """
    k2, k1 = _inertia_force_coefficients(engine, crank_angle)
    w = np.asarray(speed, dtype=np.float64)
    gas = (np.asarray(pressure, dtype=np.float64) - AMBIENT_PRESSURE) * engine.piston_area
    return np.asarray(-gas - (k2 * w**2 + k1 * np.asarray(acceleration, dtype=np.float64)))


def bearing_split(
    cylinder_positions: npt.ArrayLike,
    bearing_positions: npt.ArrayLike,
    throw_bearings: list[tuple[int, int]],
) -> FloatArray:
    """Share of each throw's force carried by each main bearing (statically determinate throws).

    Parameters
    ----------
    cylinder_positions : array_like, shape (n,)
        Axial position of each throw's force [m].
    bearing_positions : array_like, shape (b,)
        Axial position of each main bearing [m].
    throw_bearings : list of (int, int)
        The two bearings (1-based) each throw sits between.

    Returns
    -------
    ndarray, shape (b, n)
        ``F_bearings = share @ F_throws`` [-].

    Raises
    ------
    ValueError
        If a throw does not lie between its two bearings.

    Notes
    -----
    Each throw is a beam simply supported on its two bearings: moments about one bearing give the
    other's reaction, ``F_2 = F (z_c - z_1) / (z_2 - z_1)`` and ``F_1 = F - F_2``, so every column
    sums to 1 (force equilibrium) and ``sum_b z_b share[b, c] = z_c`` (moment equilibrium).
    """
    zc = np.asarray(cylinder_positions, dtype=np.float64)
    zb = np.asarray(bearing_positions, dtype=np.float64)
    if len(throw_bearings) != zc.size:
        raise ValueError(f"throw_bearings has {len(throw_bearings)} pairs: expected {zc.size}, one per throw")
    share = np.zeros((zb.size, zc.size))
    for c, (b1, b2) in enumerate(throw_bearings):
        z1, z2 = zb[b1 - 1], zb[b2 - 1]
        if not min(z1, z2) <= zc[c] <= max(z1, z2) or z1 == z2:
            raise ValueError(
                f"throw {c + 1} at {zc[c]:.4g} m: expected between its bearings {b1} and {b2} "
                f"({z1:.4g}, {z2:.4g} m)"
            )
        w2 = (zc[c] - z1) / (z2 - z1)
        share[b1 - 1, c] += 1 - w2
        share[b2 - 1, c] += w2
    return share


# =============================================================================== thermodynamics
def gamma(temperature: npt.ArrayLike) -> FloatArray:
    """Ratio of specific heats of the charge, ``gamma(T) = 1.39 - 6.5e-5 (T - 300)``.

    Parameters
    ----------
    temperature : array_like
        [K].

    Returns
    -------
    ndarray
        [-].
    """
    return np.asarray(GAMMA_300 - GAMMA_SLOPE * (np.asarray(temperature, dtype=np.float64) - 300.0))


def internal_energy(temperature: npt.ArrayLike, mass: float) -> FloatArray:
    """Internal energy of the charge from 300 K, ``m int c_v dT`` with ``c_v = R / (gamma(T) - 1)``.

    Parameters
    ----------
    temperature : array_like
        [K].
    mass : float
        [kg].

    Returns
    -------
    ndarray
        [J].

    Notes
    -----
    With ``gamma - 1 = g0 - s (T - 300)`` the integral is ``-(R / s) ln((gamma(T) - 1) / (g0))``.
    """
    ratio = (gamma(temperature) - 1) / (GAMMA_300 - 1)
    return np.asarray(-mass * GAS_CONSTANT / GAMMA_SLOPE * np.log(ratio))


def _wiebe(
    theta: FloatArray, start: float, duration: float, shape: float, a: float
) -> tuple[FloatArray, FloatArray]:
    u = np.clip((theta - start) / duration, 0.0, 1.0)
    norm = 1 - math.exp(-a)
    e = np.exp(-a * u ** (shape + 1))
    x = (1 - e) / norm
    rate = np.where((u > 0) & (u < 1), a * (shape + 1) * u**shape * e / (duration * norm), 0.0)
    return x, rate


def burned_fraction(crank_angle: npt.ArrayLike, law: DoubleWiebe) -> tuple[FloatArray, FloatArray]:
    """Double-Wiebe burned mass fraction and its rate.

    Parameters
    ----------
    crank_angle : array_like
        From firing TDC [rad].
    law : DoubleWiebe

    Returns
    -------
    fraction, rate : ndarray
        ``x`` [-] (0 before the start, 1 after the end) and ``dx/dtheta`` [1/rad].

    Notes
    -----
    ``x = beta W_p + (1 - beta) W_d`` with ``W = (1 - exp(-a u^(m+1))) / (1 - exp(-a))``,
    ``u = (theta - theta_0) / duration`` clipped to [0, 1] (Miyamoto et al. 1985).
    """
    theta = np.asarray(crank_angle, dtype=np.float64)
    xp, rp = _wiebe(theta, law.start, law.premixed_duration, law.premixed_shape, law.a)
    xd, rd = _wiebe(
        theta, law.start + law.diffusion_delay, law.diffusion_duration, law.diffusion_shape, law.a
    )
    beta = law.premixed_fraction
    return beta * xp + (1 - beta) * xd, beta * rp + (1 - beta) * rd


def wall_heat_transfer_coefficient(
    pressure: npt.ArrayLike, temperature: npt.ArrayLike, *, bore: float, mean_piston_speed: float
) -> FloatArray:
    """Woschni's heat-transfer coefficient with its gas-exchange and compression velocity term only.

    Parameters
    ----------
    pressure : array_like
        [Pa].
    temperature : array_like
        [K].
    bore : float
        [m].
    mean_piston_speed : float
        [m/s].

    Returns
    -------
    ndarray
        [W/(m^2 K)].

    Notes
    -----
    ``h = 3.26 B^-0.2 p^0.8 T^-0.55 (2.28 c_m)^0.8`` with p in kPa (Woschni 1967; Heywood
    eq. 12.19 without the combustion term).
    """
    p_kpa = np.asarray(pressure, dtype=np.float64) / 1000
    t = np.asarray(temperature, dtype=np.float64)
    return np.asarray(3.26 * bore**-0.2 * p_kpa**0.8 * t**-0.55 * (2.28 * mean_piston_speed) ** 0.8)


def _volume(engine: SimEngine, psi: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Cylinder volume [m^3] and dV/dpsi [m^3/rad]: ``V = V_c + A (R + L - y_p)``."""
    k = _kinematics(engine, psi)
    top = engine.crank_radius + engine.rod_length
    return engine.clearance_volume + engine.piston_area * (top - k.piston), -engine.piston_area * k.piston_1


def _wall_area(engine: SimEngine, volume: float | FloatArray) -> float | FloatArray:
    """Head, piston crown (1.2 x its area for a bowl) and the liner uncovered above the piston [m^2]."""
    return 2.2 * engine.piston_area + 4 * volume / engine.bore


@dataclass(frozen=True)
class ClosedCycle:
    """The closed part of the cycle for one or more heat releases.

    Attributes
    ----------
    crank_angle : ndarray, shape (N,)
        From firing TDC [rad].
    volume : ndarray, shape (N,)
        [m^3].
    pressure, temperature, wall_heat : ndarray, shape (L, N)
        Absolute pressure [Pa], temperature [K], heat lost to the walls since the start [J].
    heat : ndarray, shape (L,)
        Total heat release of each row [J].
    mass : float
        Trapped mass [kg].
    speed : float
        Crank speed the heat loss was evaluated at [rad/s].
    """

    crank_angle: FloatArray
    volume: FloatArray
    pressure: FloatArray
    temperature: FloatArray
    wall_heat: FloatArray
    heat: FloatArray
    mass: float
    speed: float


def closed_cycle(
    engine: SimEngine,
    *,
    heat: npt.ArrayLike,
    speed: float,
    charge_pressure: float,
    crank_angle: npt.ArrayLike | None = None,
    heat_loss: bool = True,
) -> ClosedCycle:
    """Integrate the single-zone first law from inlet closing (or the first angle given).

    Parameters
    ----------
    engine : SimEngine
    heat : array_like, shape (L,)
        Total heat released by combustion, one cycle per value [J] (0: motored).
    speed : float
        Crank speed, for the heat loss per degree [rad/s].
    charge_pressure : float
        Pressure at the first angle (inlet closing), absolute [Pa].
    crank_angle : array_like, optional
        Increasing angles from firing TDC to report at, the first one the start [rad]; default
        inlet closing to exhaust opening in steps of 0.1 deg.
    heat_loss : bool, optional
        False: adiabatic walls.

    Returns
    -------
    ClosedCycle

    Notes
    -----
    State: the temperature of each row and its wall heat, with
    ``m c_v(T) dT/dtheta = Q dx/dtheta - h A_w (T - T_w) / omega - p dV/dtheta`` and
    ``p = m R T / V``, solved by ``solve_ivp`` (RK45, relative tolerance 1e-9).  The charge
    temperature at the start is the engine's; the trapped mass follows from the ideal-gas law.
    """
    q = np.atleast_1d(np.asarray(heat, dtype=np.float64))
    if crank_angle is None:
        step = math.radians(0.1)
        n = math.floor((engine.exhaust_opening - engine.inlet_closing) / step)
        theta = np.append(engine.inlet_closing + step * np.arange(n + 1), engine.exhaust_opening)
        theta = np.unique(theta)
    else:
        theta = np.asarray(crank_angle, dtype=np.float64)
    if theta.ndim != 1 or theta.size < 2 or np.any(np.diff(theta) <= 0):
        raise ValueError("crank_angle: expected at least two increasing angles [rad]")
    if not speed > 0:
        raise ValueError(f"speed = {speed!r}: expected a positive crank speed [rad/s]")
    rows = q.size
    v0, _ = _volume(engine, theta[0])
    t0 = engine.charge_temperature
    mass = float(charge_pressure * v0 / (GAS_CONSTANT * t0))
    mean_piston_speed = 2 * engine.crank_radius * speed / math.pi
    law = engine.combustion
    tw = engine.wall_temperature
    loss = 1.0 if heat_loss else 0.0

    def rhs(angle: float, y: FloatArray) -> FloatArray:
        temperature = np.maximum(y[:rows], 50.0)
        v, dv = _volume(engine, angle)
        p = mass * GAS_CONSTANT * temperature / v
        _, rate = burned_fraction(angle, law)
        h = wall_heat_transfer_coefficient(
            p, temperature, bore=engine.bore, mean_piston_speed=mean_piston_speed
        )
        wall = loss * h * _wall_area(engine, float(v)) * (temperature - tw) / speed
        cv = GAS_CONSTANT / (gamma(temperature) - 1)
        dt = (q * rate - wall - p * dv) / (mass * cv)
        return np.concatenate([dt, wall])

    y0 = np.concatenate([np.full(rows, t0), np.zeros(rows)])
    scale = max(float(q.max()), 1.0)
    atol = np.concatenate([np.full(rows, 1e-7), np.full(rows, 1e-11 * scale)])
    sol = solve_ivp(
        rhs,
        (float(theta[0]), float(theta[-1])),
        y0,
        method="RK45",
        t_eval=theta,
        rtol=1e-9,
        atol=atol,
        max_step=math.radians(2.0),
    )
    if not sol.success:
        raise SimulationError(f"closed cycle of engine {engine.ident}: the integration failed: {sol.message}")
    volume, _ = _volume(engine, theta)
    temperature = sol.y[:rows]
    pressure = mass * GAS_CONSTANT * temperature / volume
    return ClosedCycle(theta, volume, pressure, temperature, sol.y[rows:], q, mass, float(speed))


def _open_pressure(
    engine: SimEngine, theta: FloatArray, exhaust_pressure: FloatArray, charge_pressure: float
) -> FloatArray:
    """Pressure of the open part, exhaust opening to the next inlet closing [Pa], shape (L, n)."""
    evo, ivc, cycle = engine.exhaust_opening, engine.inlet_closing, engine.cycle_angle
    if engine.cycle_revolutions == 2:
        back = AMBIENT_PRESSURE + 0.8 * (charge_pressure - AMBIENT_PRESSURE) + 0.05e5
    else:
        back = 0.97 * charge_pressure
    tau = 0.2
    u = np.clip((theta - evo) / engine.blowdown, 0.0, 1.0)
    decay = np.exp(-u / tau) - u * math.exp(-1 / tau)
    p = back + (exhaust_pressure[:, None] - back) * decay[None, :]
    # gas exchange: four-stroke, exhaust stroke at the back pressure, then the intake at the charge
    # pressure across a 40 deg overlap around the gas-exchange TDC; two-stroke, scavenging at the
    # back pressure rising to the charge pressure over the last 30 deg before the ports close
    if engine.cycle_revolutions == 2:
        centre, width = cycle / 2, math.radians(40.0)
    else:
        width = math.radians(30.0)
        centre = ivc + cycle - width / 2
    s = np.clip((theta - (centre - width / 2)) / width, 0.0, 1.0)
    blend = 0.5 - 0.5 * np.cos(math.pi * s)
    return np.asarray(p + (charge_pressure - back) * blend[None, :])


@dataclass(frozen=True)
class CycleTable:
    """Whole-cycle pressure traces of one cylinder at one operating point, for a ladder of fuel levels.

    Attributes
    ----------
    crank_angle : ndarray, shape (N,)
        Uniform grid over one cycle from ``-cycle / 2`` [rad].
    fuel : ndarray, shape (L,)
        Fuel levels, heat release over the engine's rated heat [-].
    heat : ndarray, shape (L,)
        Heat released per cycle at each level [J].
    pressure : ndarray, shape (L, N)
        Absolute cylinder pressure [Pa].
    imep : ndarray, shape (L,)
        Net indicated mean effective pressure (gas exchange included) [Pa].
    peak_pressure : ndarray, shape (L,)
        [Pa].
    speed : float
        Crank speed the heat loss was evaluated at [rad/s].
    charge_pressure : float
        [Pa].
    """

    crank_angle: FloatArray
    fuel: FloatArray
    heat: FloatArray
    pressure: FloatArray
    imep: FloatArray
    peak_pressure: FloatArray
    speed: float
    charge_pressure: float

    def imep_at(self, fuel: npt.ArrayLike) -> FloatArray:
        """Net IMEP at any fuel level (linear between the table's levels) [Pa]."""
        return np.asarray(np.interp(np.asarray(fuel, dtype=np.float64), self.fuel, self.imep))

    def fuel_for(self, imep: float) -> float:
        """The fuel level that gives an IMEP [-] (IMEP rises with fuel)."""
        if not self.imep[0] <= imep <= self.imep[-1]:
            raise SimulationError(
                f"IMEP {imep / 1e5:.3g} bar is outside the table's {self.imep[0] / 1e5:.3g} to "
                f"{self.imep[-1] / 1e5:.3g} bar"
            )
        return float(np.interp(imep, self.imep, self.fuel))


def cycle_table(
    engine: SimEngine,
    *,
    speed: float,
    charge_pressure: float,
    fuel: npt.ArrayLike,
    heat_reference: float,
    points: int | None = None,
) -> CycleTable:
    """Whole-cycle pressure of one cylinder for several fuel levels.

    Parameters
    ----------
    engine : SimEngine
    speed : float
        Crank speed for the heat loss [rad/s].
    charge_pressure : float
        Absolute [Pa].
    fuel : array_like, shape (L,)
        Increasing fuel levels [-].
    heat_reference : float
        Heat released at fuel level 1 [J].
    points : int, optional
        Grid points over the cycle (default one per 0.1 deg).

    Returns
    -------
    CycleTable
    """
    levels = np.asarray(fuel, dtype=np.float64)
    cycle = engine.cycle_angle
    n = 3600 * engine.cycle_revolutions if points is None else points
    theta = -cycle / 2 + cycle * np.arange(n) / n
    closed = (theta > engine.inlet_closing) & (theta < engine.exhaust_opening)
    angles = np.concatenate([[engine.inlet_closing], theta[closed], [engine.exhaust_opening]])
    heat = levels * heat_reference
    part = closed_cycle(engine, heat=heat, speed=speed, charge_pressure=charge_pressure, crank_angle=angles)
    pressure = np.empty((levels.size, n))
    pressure[:, closed] = part.pressure[:, 1:-1]
    open_angle = np.where(theta <= engine.inlet_closing, theta + cycle, theta)[~closed]
    pressure[:, ~closed] = _open_pressure(engine, open_angle, part.pressure[:, -1], charge_pressure)
    _, dv = _volume(engine, theta)
    imep = (pressure @ dv) * (cycle / n) / engine.swept_volume
    return CycleTable(
        crank_angle=theta,
        fuel=levels,
        heat=heat,
        pressure=pressure,
        imep=imep,
        peak_pressure=pressure.max(axis=1),
        speed=float(speed),
        charge_pressure=float(charge_pressure),
    )


def _charge_pressure(engine: SimEngine, load: float) -> float:
    """Charge pressure at a load (turbocharger boost about proportional to load) [Pa]."""
    return AMBIENT_PRESSURE + max(load, 0.0) * (engine.rated_charge_pressure - AMBIENT_PRESSURE)


def _rated_table(engine: SimEngine) -> tuple[float, CycleTable]:
    guess = engine.rated_imep * engine.swept_volume / 0.45
    levels = np.array([0.8, 1.0, 1.2])
    table = cycle_table(
        engine,
        speed=engine.rated_speed,
        charge_pressure=engine.rated_charge_pressure,
        fuel=levels,
        heat_reference=guess,
        points=1440 * engine.cycle_revolutions,
    )
    fit = np.polynomial.Polynomial.fit(table.imep, levels, 2)
    return float(fit(engine.rated_imep)) * guess, table


def rated_heat(engine: SimEngine) -> float:
    """Heat released per cylinder and cycle that gives the rated IMEP at rated speed and charge [J].

    Parameters
    ----------
    engine : SimEngine

    Returns
    -------
    float
        [J].

    Notes
    -----
    The IMEP of three heat releases around an estimate (45 % indicated efficiency), fitted by a
    quadratic in the IMEP and evaluated at the rated IMEP.
    """
    return _rated_table(engine)[0]


@lru_cache(maxsize=64)
def _rated_of_seed(seed: int) -> tuple[float, FloatArray, FloatArray]:
    """Rated heat [J], and the crank angle [rad] and pressure [Pa] of the rated cycle, of a seed's engine."""
    engine = random_engine(seed)
    heat, table = _rated_table(engine)
    pressure = np.array([np.interp(heat / table.heat[1], table.fuel, column) for column in table.pressure.T])
    return heat, table.crank_angle, pressure


# =============================================================================== crank dynamics
@dataclass(frozen=True)
class Load:
    """What the crank drives.

    Attributes
    ----------
    kind : str
        "propeller": torque ``k omega^2`` at a fixed fuel; "generator": a constant torque with a
        PI governor on the cycle-mean speed acting on the fuel of the cycle after next.
    torque : float
        Constant torque: friction, plus the generator's torque [N m].
    propeller_coefficient : float
        k [N m s^2/rad^2] (0 for a generator).
    speed_reference : float
        Governor set point [rad/s] (generator).
    governor_gains : (float, float)
        Proportional and integral gain, relative fuel per relative speed error per cycle [-].
    fuel_limit : float
        Largest fuel level the governor may set [-].
    """

    kind: Literal["propeller", "generator"]
    torque: float
    propeller_coefficient: float = 0.0
    speed_reference: float = 0.0
    governor_gains: tuple[float, float] = (0.0, 0.0)
    fuel_limit: float = (HEAT_LEVELS - 1) * HEAT_STEP * 0.97


@dataclass(frozen=True)
class CrankRun:
    """A simulated run of the crank, on a uniform crank-angle grid.

    Attributes
    ----------
    step : float
        Grid step [rad].
    time : ndarray, shape (N,)
        Time at each grid angle ``k * step`` (cylinder 1's crank angle from its firing TDC) [s].
    speed : ndarray, shape (N,)
        [rad/s].
    acceleration : ndarray, shape (N,)
        [rad/s^2].
    forces : ndarray, shape (R, N), float32
        The rows of vertical bearing forces asked for (``mixes @ throw forces``) [N].
    fuel : ndarray, shape (n, F)
        Fuel level of each cylinder's firings, firing 0 the one in the first cycle [-].
    imep : ndarray, shape (n, F)
        IMEP of each of those firings [Pa].
    cycle_speed : ndarray, shape (K,)
        Mean speed of each simulated cycle [rad/s].
    """

    step: float
    time: FloatArray
    speed: FloatArray
    acceleration: FloatArray
    forces: npt.NDArray[np.float32]
    fuel: FloatArray
    imep: FloatArray
    cycle_speed: FloatArray


def _cumtrapz(values: FloatArray, step: float) -> FloatArray:
    out = np.empty_like(values)
    out[..., 0] = 0.0
    np.cumsum(0.5 * step * (values[..., 1:] + values[..., :-1]), axis=-1, out=out[..., 1:])
    return out


def run_crank(
    engine: SimEngine,
    table: CycleTable,
    load: Load,
    *,
    fuel: float,
    end_time: float,
    initial_speed: float,
    fault_factors: npt.ArrayLike | None = None,
    variation: Callable[[int], FloatArray] | None = None,
    mixes: npt.ArrayLike | None = None,
    points_per_revolution: int = 720,
    settle_start: bool = True,
) -> CrankRun:
    """Integrate the rigid crank over angle until ``end_time``.

    Parameters
    ----------
    engine : SimEngine
    table : CycleTable
        Cylinder pressure against fuel level at this operating point.
    load : Load
    fuel : float
        Fuel level of a healthy cylinder at the start (and throughout, for a propeller) [-].
    end_time : float
        Simulate at least this long [s].
    initial_speed : float
        Mean speed of the first cycle [rad/s].
    fault_factors : array_like, shape (n,), optional
        Each cylinder's fuel multiplier (0 misfire, 0.5-0.8 weak) [-]; default all 1.
    variation : callable, optional
        ``variation(firing)`` gives the cylinders' cycle-to-cycle fuel multipliers of that firing
        index, shape (n,), called once per firing in increasing order; default none.
    mixes : array_like, shape (R, n), optional
        Rows of throw-force weights whose sums to keep (bearing sensors' views) [-].
    points_per_revolution : int, optional
        Grid points per revolution.
    settle_start : bool, optional
        Scale the first cycle's energy so that its mean speed is ``initial_speed`` (start on the
        periodic orbit).

    Returns
    -------
    CrankRun

    Raises
    ------
    SimulationError
        If the crank stalls (its kinetic energy reaches zero).
    ValueError
        If the table's fuel levels are not uniform from zero.

    Notes
    -----
    With the kinetic energy ``E = J(alpha) omega^2 / 2``, Lagrange's equation in the crank angle
    is ``dE/dalpha = T_gas - T_0 - k omega^2 = S(alpha) - beta(alpha) E``, ``beta = 2 k / J``,
    solved on each cycle by the integrating factor ``G = int beta``:
    ``E = exp(-G) (E_0 + int exp(G) S)`` (trapezoidal quadrature); then ``omega = sqrt(2 E / J)``,
    ``domega/dt = (dE/dalpha - J' omega^2 / 2) / J`` and ``t = int dalpha / omega``.
    ``T_gas = sum_c (p_c - p_amb) A x_c'`` by virtual work, ``x_c`` the piston's travel from TDC.
    """
    n = engine.cylinders
    cycle = engine.cycle_angle
    m = points_per_revolution * engine.cycle_revolutions
    step = cycle / m
    alpha = step * np.arange(m + 1)
    phase = engine.firing_angles
    psi = alpha[None, :] - phase[:, None]
    factors = np.ones(n) if fault_factors is None else np.asarray(fault_factors, dtype=np.float64)
    weights = np.zeros((0, n)) if mixes is None else np.atleast_2d(np.asarray(mixes, dtype=np.float64))
    # per-window constants
    inertia_c, derivative_c = equivalent_inertia(engine, psi)
    inertia = engine.rigid_inertia + inertia_c.sum(axis=0)
    inertia_1 = derivative_c.sum(axis=0)
    arm = -_kinematics(engine, psi).piston_1  # dx/dpsi, piston travel from TDC
    k2, k1 = _inertia_force_coefficients(engine, psi)
    k2_rows, k1_rows = weights @ k2, weights @ k1
    area = engine.piston_area
    # firing index of each grid point of each cylinder, relative to the window (-1, 0 or 1)
    part = np.floor((psi + cycle / 2) / cycle).astype(int)
    low = part.min(axis=1)
    high = part == low[:, None] + 1
    wrapped = np.mod(psi + cycle / 2, cycle) - cycle / 2
    tab = np.empty((n, table.fuel.size, m + 1))
    for c in range(n):
        for level in range(table.fuel.size):
            tab[c, level] = np.interp(wrapped[c], table.crank_angle, table.pressure[level], period=cycle)
    fuel_step = float(table.fuel[1] - table.fuel[0]) if table.fuel.size >= 2 else 0.0
    if not (fuel_step > 0 and table.fuel[0] == 0 and np.allclose(np.diff(table.fuel), fuel_step)):
        raise ValueError("table: expected fuel levels 0, d, 2 d, ... (uniform, from zero) [-]")
    top = table.fuel.size - 2
    rows = np.arange(n)
    k_prop = load.propeller_coefficient
    beta = 2 * k_prop / inertia
    growth = _cumtrapz(beta, step)
    grow, shrink = np.exp(growth), np.exp(-growth)

    def pressure_of(levels: FloatArray) -> FloatArray:
        pos = np.clip(levels / fuel_step, 0.0, top + 1.0)
        i = np.minimum(pos.astype(int), top)
        w = (pos - i)[:, None]
        return np.asarray((1 - w) * tab[rows, i] + w * tab[rows, i + 1])

    # fuel of every firing; firing f is stored at column f + 1
    estimate = int(end_time * initial_speed / cycle * 1.3) + 8
    sigma = np.full(estimate + 4, fuel)
    multiplier = np.ones((n, estimate + 4))
    drawn = 0

    def draw_until(column: int) -> None:
        nonlocal sigma, multiplier, drawn
        while column >= sigma.size:
            sigma = np.concatenate([sigma, np.full(sigma.size, sigma[-1])])
            multiplier = np.concatenate([multiplier, np.ones_like(multiplier)], axis=1)
        while drawn <= column:
            if variation is not None:
                multiplier[:, drawn] = variation(drawn - 1)
            drawn += 1

    def window(k: int, energy0: float, time0: float, keep: bool) -> tuple[FloatArray, ...]:
        draw_until(k + 2)
        col0 = k + low + 1
        q0 = sigma[col0] * factors * multiplier[rows, col0]
        q1 = sigma[col0 + 1] * factors * multiplier[rows, col0 + 1]
        p = np.where(high, pressure_of(q1), pressure_of(q0))
        gas = (p - AMBIENT_PRESSURE) * area
        source = (gas * arm).sum(axis=0) - load.torque
        if k_prop > 0:
            energy = shrink * (energy0 + _cumtrapz(grow * source, step))
        else:
            energy = energy0 + _cumtrapz(source, step)
        if energy.min() <= 0:
            raise SimulationError(
                f"engine {engine.ident}: the crank stalled in cycle {k} (load torque above the drive)"
            )
        omega = np.sqrt(2 * energy / inertia)
        rate = source - beta * energy
        accel = (rate - 0.5 * inertia_1 * omega**2) / inertia
        time = time0 + _cumtrapz(1.0 / omega, step)
        forces = (-(weights @ gas) - k2_rows * omega**2 - k1_rows * accel) if keep else np.zeros((0, m + 1))
        return energy, omega, accel, time, forces

    energy0 = 0.5 * float(inertia[0]) * initial_speed**2
    if settle_start:
        for _ in range(4):
            _, _, _, time, _ = window(0, energy0, 0.0, False)
            energy0 *= (initial_speed * time[-1] / cycle) ** 2
    times: list[FloatArray] = []
    speeds: list[FloatArray] = []
    accels: list[FloatArray] = []
    force_parts: list[FloatArray] = []
    cycle_speed: list[float] = []
    t0, k, integral = 0.0, 0, 0.0
    kp, ki = load.governor_gains
    base = fuel
    while t0 < end_time:
        energy, omega, accel, time, forces = window(k, energy0, t0, True)
        times.append(time[:-1])
        speeds.append(omega[:-1])
        accels.append(accel[:-1])
        force_parts.append(forces[:, :-1].astype(np.float32))
        mean = cycle / (time[-1] - time[0])
        cycle_speed.append(mean)
        if load.kind == "generator":
            error = (load.speed_reference - mean) / load.speed_reference
            integral += error
            draw_until(k + 3)
            sigma[k + 3] = float(np.clip(base * (1 + kp * error + ki * integral), 0.0, load.fuel_limit))
        energy0, t0 = float(energy[-1]), float(time[-1])
        k += 1
        if k > 10_000_000:  # pragma: no cover - a guard, not a case
            raise SimulationError("the crank simulation does not advance")
    windows = k
    columns = np.arange(1, windows + 1)  # firings 0 .. windows - 1
    fired = sigma[columns][None, :] * factors[:, None] * multiplier[:, columns]
    return CrankRun(
        step=step,
        time=np.concatenate(times),
        speed=np.concatenate(speeds),
        acceleration=np.concatenate(accels),
        forces=np.concatenate(force_parts, axis=1) if force_parts else np.zeros((0, 0), np.float32),
        fuel=fired,
        imep=table.imep_at(fired),
        cycle_speed=np.asarray(cycle_speed),
    )


def operating_load(
    engine: SimEngine, table: CycleTable, load: float, fault_factors: FloatArray
) -> tuple[Load, float, float]:
    """The load, the fuel level and the expected mean speed of a case.

    Parameters
    ----------
    engine : SimEngine
    table : CycleTable
        At the case's charge pressure and (healthy) speed.
    load : float
        Engine load, mean IMEP of all cylinders over the rated IMEP, of the healthy engine [-].
    fault_factors : ndarray, shape (n,)
        Each cylinder's fuel multiplier [-].

    Returns
    -------
    load : Load
    fuel : float
        Healthy cylinders' fuel level at the start [-].
    speed : float
        The expected mean speed [rad/s].

    Notes
    -----
    Propeller: the curve ``k omega^2`` passes through the rated point (indicated less friction
    torque at rated speed); the fuel is fixed, and the speed is where ``sum_c imep_c V_d / cycle
    - T_f = k omega^2``.  Generator: a constant torque (generator and friction) of ``load`` times
    the rated indicated torque, held at the rated speed by the governor, so the indicated load
    is ``load``; the fuel starts where the cylinders (faulty ones included) carry it.
    """
    cycle = engine.cycle_angle
    vd = engine.swept_volume
    friction = engine.friction_torque
    healthy_fuel = table.fuel_for(load * engine.rated_imep)
    rated_net = engine.rated_indicated_torque - friction
    if engine.load_type == "propeller":
        k = rated_net / engine.rated_speed**2
        drive = float(table.imep_at(healthy_fuel * fault_factors).sum()) * vd / cycle - friction
        if drive <= 0:
            raise SimulationError(f"engine {engine.ident}: the drive does not overcome friction")
        return Load("propeller", friction, propeller_coefficient=k), healthy_fuel, math.sqrt(drive / k)
    torque = load * engine.rated_indicated_torque  # generator and friction, at the rated speed
    grid = np.linspace(0.0, table.fuel[-1], 2001)
    total = table.imep_at(grid[:, None] * fault_factors[None, :]).sum(axis=1)
    if total[-1] < torque * cycle / vd:
        raise SimulationError(f"engine {engine.ident}: the faulty engine cannot carry load {load:.3g}")
    start = float(np.interp(torque * cycle / vd, total, grid))
    inertia = (
        engine.rigid_inertia
        + float(equivalent_inertia(engine, np.linspace(0, 2 * math.pi, 64, endpoint=False))[0].mean())
        * engine.cylinders
    )
    work = torque * cycle
    kappa = work / (inertia * engine.rated_speed**2)
    return (
        Load(
            "generator",
            torque,
            speed_reference=engine.rated_speed,
            governor_gains=(0.25 / kappa, 0.05 / kappa),
        ),
        start,
        engine.rated_speed,
    )


# =============================================================================== installation
@dataclass(frozen=True)
class Installation:
    """The sensors on an engine: the same for every case of that engine.

    Attributes
    ----------
    sample_rate : float
        Of the bearing channels [Hz].
    sensor_bearings : tuple of int
        Main bearings (1-based) carrying a vertical accelerometer.
    crosstalk : ndarray, shape (s, b)
        Each sensor's view of the bearings' vertical forces (1 for its own) [-].
    modes : tuple of ndarray
        Per sensor, rows (frequency [Hz], damping ratio [-], gain [1/kg]).
    level : ndarray, shape (s,)
        Expected rms acceleration of each sensor in rated operation [m/s^2].
    noise : ndarray, shape (s,)
        Broadband noise, standard deviation [m/s^2].
    hum_frequency : float
        Mains [Hz].
    hum : ndarray, shape (s,)
        Mains hum amplitude [m/s^2].
    adc_range : ndarray, shape (s,)
        Symmetric measuring range [m/s^2].
    tooth_errors : ndarray, shape (60,)
        Angular error of each tooth position (0 for the first after the gap) [rad].
    first_tooth_angle : float
        Crank angle of the first tooth after the gap after cylinder 1's TDC [rad].
    cam_angle : float or None
        Cycle angle of the cam pulse after cylinder 1's firing TDC [rad] (four-strokes).
    keyphasor_angle : float or None
        Crank angle of the keyphasor pulse after cylinder 1's TDC [rad], if fitted.
    tooth_jitter : float
        Timing jitter of the tooth and keyphasor events, standard deviation [s].
    cam_jitter : float
        Of the cam events [s].
    """

    sample_rate: float
    sensor_bearings: tuple[int, ...]
    crosstalk: FloatArray
    modes: tuple[FloatArray, ...]
    level: FloatArray
    noise: FloatArray
    hum_frequency: float
    hum: FloatArray
    adc_range: FloatArray
    tooth_errors: FloatArray
    first_tooth_angle: float
    cam_angle: float | None
    keyphasor_angle: float | None
    tooth_jitter: float
    cam_jitter: float

    def channel_name(self, sensor: int) -> str:
        """Name of sensor ``sensor``'s channel (index into ``sensor_bearings``)."""
        return f"mb{self.sensor_bearings[sensor]}-vertical"


def _mode_sos(frequency: float, damping: float, gain: float, sample_rate: float) -> FloatArray:
    """``g s^2 / (s^2 + 2 zeta w s + w^2)`` by the bilinear transform, prewarped at the mode."""
    w = 2 * sample_rate * math.tan(math.pi * frequency / sample_rate)
    poles = np.roots([1.0, 2 * damping * w, w**2])
    z, p, k = signal.bilinear_zpk(np.zeros(2), poles, gain, sample_rate)
    return np.asarray(signal.zpk2sos(z, p, k))


def _antialias_sos(sample_rate: float) -> FloatArray:
    return np.asarray(signal.butter(6, 0.4 * sample_rate, fs=sample_rate, output="sos"))


def _sensor_mix(engine: SimEngine, crosstalk: FloatArray) -> FloatArray:
    """Throw-force weights of each sensor's input, ``crosstalk @ split`` [-]."""
    split = bearing_split(engine.cylinder_positions, engine.bearing_positions, engine.throw_bearings)
    return np.asarray(crosstalk @ split)


def _nice_ceiling(value: float) -> float:
    """The next value of the 1-2-5 series at or above ``value``."""
    decade = 10 ** math.floor(math.log10(value))
    for mantissa in (1, 2, 5, 10):
        if mantissa * decade >= value:
            return float(mantissa * decade)
    return float(10 * decade)  # pragma: no cover


def random_installation(engine: SimEngine) -> Installation:
    """Draw the sensors of an engine (from the engine's seed, its own stream).

    Parameters
    ----------
    engine : SimEngine

    Returns
    -------
    Installation

    Notes
    -----
    Mode frequencies are log-uniform between ``30 sqrt(0.32 / D)`` and ``2500 sqrt(0.32 / D)`` Hz
    (below 0.4 of the sample rate), damping ratios 0.02-0.08, modal gains (inverse modal masses)
    in a random ratio.  A sensor's steady response to the bearing forces of the rated cycle at an
    even rated speed is computed over the cycle's harmonics (Parseval), and its gains are scaled
    so that its rms velocity over 2-1000 Hz is 2-8 mm/s (a healthy engine in ISO 10816-6 terms);
    its rms acceleration then sets the noise (0.5-3 %), the hum (0.2-1 %) and the measuring range
    (20-40 times, rounded up to 1-2-5: an engine's structure-borne acceleration has crest factors
    past 10, and an installer leaves headroom above them), the same in every case of the engine.
    """
    rng = np.random.default_rng(np.random.SeedSequence([engine.seed, _INSTALLATION]))
    rated_rpm = engine.rated_speed * 30 / math.pi
    fs = 10240.0 if rated_rpm < 300 else 25600.0
    nb = engine.bearing_count
    count = min(nb, int(rng.integers(2, 5)))
    bearings = tuple(sorted(int(b) + 1 for b in rng.choice(nb, size=count, replace=False)))
    crosstalk = np.zeros((count, nb))
    for s, b in enumerate(bearings):
        crosstalk[s, b - 1] = 1.0
        for nb_ in (b - 1, b + 1):
            if 1 <= nb_ <= nb:
                crosstalk[s, nb_ - 1] = rng.uniform(0.05, 0.2)
    size = math.sqrt(0.32 / engine.bore)
    f_low, f_high = 30 * size, min(2500 * size, 0.4 * fs)
    modes = []
    for _ in bearings:
        k = int(rng.integers(2, 4))
        modes.append(
            np.column_stack(
                [
                    np.exp(rng.uniform(math.log(f_low), math.log(f_high), k)),
                    rng.uniform(0.02, 0.08, k),
                    1 / rng.uniform(0.5, 2.0, k),
                ]
            )
        )
    # expected level: the steady response, at rated speed and load, to the bearing forces of the
    # rated cycle with the crank turning evenly (Parseval over the cycle's harmonics)
    _, angle, rated_pressure = _rated_of_seed(engine.seed)
    mix = _sensor_mix(engine, crosstalk)
    points = 4096
    cycle = engine.cycle_angle
    psi = cycle * np.arange(points)[None, :] / points - engine.firing_angles[:, None]
    local = np.mod(psi + cycle / 2, cycle) - cycle / 2
    pressure = np.interp(local, angle, rated_pressure, period=cycle)
    throws = throw_vertical_force(engine, psi, pressure, engine.rated_speed, 0.0)
    spectrum = np.fft.rfft(mix @ throws, axis=1) / points
    frequency = np.arange(spectrum.shape[1]) * engine.rated_speed / cycle
    s_var = 2j * math.pi * frequency
    band = (frequency >= 2.0) & (frequency <= 1000.0)
    level = np.empty(count)
    for s in range(count):
        response = np.zeros(frequency.size, dtype=complex)
        for f, z, g in modes[s]:
            w = 2 * math.pi * f
            response += g * s_var**2 / (s_var**2 + 2 * z * w * s_var + w**2)
        response[frequency > 0.45 * fs] = 0.0
        acceleration = spectrum[s] * response
        velocity = math.sqrt(2 * float(np.sum(np.abs(acceleration[band] / s_var[band]) ** 2)))
        scale = float(rng.uniform(2e-3, 8e-3)) / velocity  # healthy rated velocity 2-8 mm/s rms
        modes[s][:, 2] *= scale
        level[s] = scale * math.sqrt(2 * float(np.sum(np.abs(acceleration[1:]) ** 2)))
    noise = level * rng.uniform(0.005, 0.03, count)
    hum = level * rng.uniform(0.002, 0.01, count)
    adc = np.array([_nice_ceiling(v * rng.uniform(20, 40)) for v in level])
    errors = rng.normal(0.0, math.radians(0.02), 60)
    errors[0] = 0.0
    first = math.radians(float(rng.uniform(0, 360)))
    cam = math.radians(float(rng.uniform(0, 720))) if engine.cycle_revolutions == 2 else None
    keyphasor = math.radians(float(rng.uniform(0, 360))) if rng.random() < 0.3 else None
    return Installation(
        sample_rate=fs,
        sensor_bearings=bearings,
        crosstalk=crosstalk,
        modes=tuple(modes),
        level=level,
        noise=noise,
        hum_frequency=float(rng.choice([50.0, 60.0])),
        hum=hum,
        adc_range=adc,
        tooth_errors=errors,
        first_tooth_angle=first,
        cam_angle=cam,
        keyphasor_angle=keyphasor,
        tooth_jitter=float(rng.uniform(0.2e-6, 1e-6)),
        cam_jitter=20e-6,
    )


# =============================================================================== the description
def _fit_single_wiebe(law: DoubleWiebe) -> tuple[float, float]:
    """(duration [rad], m) of the Wiebe law (a = 6.9) from the same start closest to a double Wiebe."""
    theta = np.linspace(law.start, law.end + 0.05, 400)
    target, _ = burned_fraction(theta, law)

    def residual(v: FloatArray) -> FloatArray:
        x, _ = _wiebe(theta, law.start, v[0], v[1], 6.9)
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
    every torsional mode far above the 50th order.
    """
    rng = np.random.default_rng(np.random.SeedSequence([engine.seed, _DESCRIPTION]))

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
        f"bore_m = {_float(bore)}",
        f"stroke_m = {_float(stroke)}",
        f"rod_length_m = {_float(rod)}",
        f"cylinder_pitch_m = {_float(pitch)}",
        "",
        "[masses]",
        f"piston_assembly_kg = {_float(heavy(engine.piston_mass))}",
        f"conrod_kg = {_float(heavy(engine.rod_mass))}",
        f"conrod_cg_from_piston_pin_m = {_float(min(cg, 0.95 * rod))}",
        f"conrod_inertia_kgm2 = {_float(heavy(engine.rod_inertia))}",
        f"crank_unbalance_kgm = {_float(heavy(engine.crank_unbalance))}",
        f"counterweight_kgm = {_float(heavy(engine.counterweight))}",
        "",
        "[firing]",
        f"order = [{', '.join(str(c) for c in engine.firing_order)}]",
        "",
        "[operation]",
        f"rated_speed_rpm = {_float(rated_rpm)}",
        f"rated_power_kw = {_float(power)}",
        "",
        "[combustion]",
        f"rated_imep_bar = {_float(engine.rated_imep / 1e5)}",
        f"compression_ratio = {_float(engine.compression_ratio * float(rng.uniform(0.97, 1.03)))}",
        f"intake_pressure_bar = {_float(engine.rated_charge_pressure / 1e5)}",
        f"inlet_closing_deg = {_float(engine.inlet_closing * deg)}",
        f"exhaust_opening_deg = {_float(engine.exhaust_opening * deg)}",
        f"blowdown_deg = {_float(engine.blowdown * deg)}",
        f"combustion_start_deg = {_float(start_deg)}",
        f"combustion_duration_deg = {_float(duration * deg)}",
        f"wiebe_a = {_float(law.a)}",
        f"wiebe_m = {_float(shape)}",
        "",
        "[shaft_line]",
        f"throw_inertia_kgm2 = {_float(throw)}",
        f"throw_stiffness_nm_per_rad = {_float(stiffness)}",
        'tooth_wheel = "flywheel"',
        "",
        "[[shaft_line.driven_end]]",
        'name = "flywheel"',
        'kind = "flywheel"',
        f"inertia_kgm2 = {_float(flywheel)}",
        f"stiffness_to_previous_nm_per_rad = {_float(stiffness)}",
        "",
        "[[shaft_line.driven_end]]",
        f'name = "{machine}"',
        f'kind = "{machine}"',
        f"inertia_kgm2 = {_float(driven)}",
        f"stiffness_to_previous_nm_per_rad = {_float(stiffness)}",
        f"absolute_damping_nms_per_rad = {_float(damping)}",
        "",
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


# =============================================================================== signals
def _cubic(values: FloatArray | npt.NDArray[np.float32], position: FloatArray) -> FloatArray:
    """Catmull-Rom interpolation of rows sampled on a uniform grid at fractional indices."""
    size = values.shape[-1]
    i = np.floor(position).astype(np.int64)
    f = position - i
    f2, f3 = f * f, f * f * f
    weights = (
        0.5 * (-f3 + 2 * f2 - f),
        0.5 * (3 * f3 - 5 * f2 + 2),
        0.5 * (-3 * f3 + 4 * f2 + f),
        0.5 * (f3 - f2),
    )
    out = np.zeros(values.shape[:-1] + position.shape)
    for shift, w in zip((-1, 0, 1, 2), weights, strict=True):
        out += w * values[..., np.clip(i + shift, 0, size - 1)]
    return out


def _quantise(x: FloatArray, full_scale: float, bits: int = 16) -> FloatArray:
    lsb = 2 * full_scale / 2**bits
    codes = np.clip(np.round(x / lsb), -(2 ** (bits - 1)), 2 ** (bits - 1) - 1)
    return np.asarray(codes * lsb)


def _reversals(force: npt.NDArray[np.float32], hysteresis: float) -> tuple[FloatArray, str]:
    """Fractional grid indices where a force changes sign (with hysteresis), else its magnitude's minima.

    A reversal is a sign change between excursions beyond +-``hysteresis`` [N]; a force that never
    reverses gives instead the prominent minima of its magnitude (prominence 0.2 of its span, below
    its mean), where the bearing is nearest to unloading.
    """
    f = np.asarray(force, dtype=np.float64)
    state = np.where(f > hysteresis, 1, np.where(f < -hysteresis, -1, 0))
    settled = np.flatnonzero(state)
    if settled.size >= 2:
        flips = settled[1:][np.diff(state[settled]) != 0]
        if flips.size >= 4:
            sign_change = np.flatnonzero(np.signbit(f[1:]) != np.signbit(f[:-1]))
            idx = sign_change[np.searchsorted(sign_change, flips, side="left") - 1]
            frac = f[idx] / (f[idx] - f[idx + 1])
            return idx + frac, "sign"
    magnitude = np.abs(f)
    spread = float(magnitude.max() - magnitude.min())
    minima, _ = signal.find_peaks(-magnitude, prominence=0.2 * spread)
    minima = minima[magnitude[minima] < magnitude.mean()]
    return minima.astype(np.float64), "minimum"


# =============================================================================== cases
@dataclass(frozen=True)
class Case:
    """One validation case.

    Attributes
    ----------
    seed : int
        The seed of its noise and cycle variation (and, for a case from :func:`random_case`, of
        everything; a healthy twin's engine comes from ``truth["engine_seed"]``).
    engine_toml : str
        The perturbed engine description given to the product.
    recording : Recording
        The simulated recording; its ``engine_id`` is the description's id.
    load_given : float
        The load the product is told: the true load times 0.9-1.1 [-].
    truth : dict
        ``class`` (one of :data:`FAULT_CLASSES`), ``cylinder``, ``bearing``, ``channel``,
        ``strength``, ``true_load`` and the details of the simulation (see :func:`random_case`).
    """

    seed: int
    engine_toml: str
    recording: Recording
    load_given: float
    truth: dict[str, Any] = field(hash=False)


@dataclass(frozen=True)
class _Scenario:
    """What a case simulates: the operating point and the fault (drawn from the operation stream)."""

    load: float
    given_ratio: float
    fault: str
    cylinder: int | None = None
    factor: float = 1.0
    bearing_choice: float = 0.0
    burst_frequency: float = 0.0
    burst_cycles: float = 0.0
    burst_size: float = 0.0
    neighbour: float = 0.0
    sensor: int | None = None
    sensor_fault: str | None = None
    clip_fraction: float = 0.0


_SENSOR_FAULTS = ("clipped", "dead_flat", "dead_noise", "unit_x1000", "unit_per_9.81")


def _scenario(engine: SimEngine, install: Installation, seed: int, fault: str | None) -> _Scenario:
    rng = np.random.default_rng(np.random.SeedSequence([seed, _OPERATION]))
    load = float(rng.uniform(0.45, 0.95))
    given_ratio = float(rng.uniform(0.9, 1.1))
    choices = [c for c in FAULT_CLASSES if not (c == "misfire" and engine.cylinders == 1)]
    drawn = choices[int(rng.integers(len(choices)))]
    forced_sensor_fault = None
    if fault == "random":
        kind = drawn
    elif fault is None:
        kind = "healthy"
    elif fault in FAULT_CLASSES:
        kind = fault
    elif fault.startswith("sensor_fault:") and fault.split(":", 1)[1] in _SENSOR_FAULTS:
        kind, forced_sensor_fault = "sensor_fault", fault.split(":", 1)[1]
    else:
        raise ValueError(
            f"fault = {fault!r}: expected 'random', None, one of {', '.join(FAULT_CLASSES)}, or "
            f"'sensor_fault:KIND' with KIND one of {', '.join(_SENSOR_FAULTS)}"
        )
    if kind == "misfire" and engine.cylinders == 1:
        raise SimulationError(
            f"seed {seed}: the engine has a single cylinder, which cannot run with a permanent misfire; "
            "choose another seed or fault"
        )
    cylinder = int(rng.integers(1, engine.cylinders + 1))
    factor = float(rng.uniform(0.5, 0.8))
    bearing_choice = float(rng.random())
    burst_frequency = float(rng.uniform(2000.0, min(8000.0, 0.4 * install.sample_rate)))
    burst_cycles = float(rng.uniform(4, 10))
    burst_size = float(rng.uniform(3, 6))
    neighbour = float(rng.uniform(0.15, 0.35))
    sensor = int(rng.integers(len(install.sensor_bearings)))
    sensor_fault = _SENSOR_FAULTS[int(rng.integers(len(_SENSOR_FAULTS)))]
    if forced_sensor_fault is not None:
        sensor_fault = forced_sensor_fault
    clip_fraction = float(rng.uniform(0.25, 0.5))
    factor = 0.0 if kind == "misfire" else factor if kind == "weak" else 1.0
    if engine.load_type == "generator" and kind in ("misfire", "weak"):
        # the governor makes the other cylinders carry the load: keep the fuel within 1.3 x rated
        load = min(load, 1.3 * (engine.cylinders - 1 + factor) / engine.cylinders)
    return _Scenario(
        load=load,
        given_ratio=given_ratio,
        fault=kind,
        cylinder=cylinder if kind in ("misfire", "weak") else None,
        factor=factor,
        bearing_choice=bearing_choice,
        burst_frequency=burst_frequency,
        burst_cycles=burst_cycles,
        burst_size=burst_size,
        neighbour=neighbour,
        sensor=sensor if kind == "sensor_fault" else None,
        sensor_fault=sensor_fault if kind == "sensor_fault" else None,
        clip_fraction=clip_fraction,
    )


def _events(
    run: CrankRun,
    offset: float,
    span: float,
    angles0: FloatArray,
    period: float,
    jitter: float,
    rng: np.random.Generator,
) -> FloatArray:
    """Times in the recording of events at crank angles ``angles0 + j period`` (cylinder 1's angle) [s]."""
    total_angle = run.step * (run.time.size - 1)
    j = np.arange(np.floor(-angles0.max() / period), np.ceil(total_angle / period) + 1)
    angles = (j[:, None] * period + angles0[None, :]).ravel()
    angles = np.sort(angles[(angles >= 0) & (angles <= total_angle)])
    times = _cubic(run.time, angles / run.step) - offset
    times = times + rng.normal(0.0, jitter, times.size)
    out = times[(times >= 0) & (times < span)]
    if np.any(np.diff(out) <= 0):
        raise SimulationError("event jitter reordered two events: the jitter is too large for the spacing")
    return np.asarray(out)


def _structural_response(
    run: CrankRun, install: Installation, pre: float, duration_s: float
) -> tuple[FloatArray, FloatArray]:
    """Clean accelerations of the bearing sensors, shape (s, samples), and the sample times' grid index."""
    fs = install.sample_rate
    count = len(install.sensor_bearings)
    samples = round((pre + duration_s) * fs)
    first = round(pre * fs)
    t = np.arange(samples) / fs
    index = np.interp(t, run.time, np.arange(run.time.size, dtype=np.float64))
    inputs = _cubic(run.forces[:count], index)
    aa = _antialias_sos(fs)
    clean = np.empty((count, samples - first))
    for s in range(count):
        y = np.zeros(samples)
        for f, z, g in install.modes[s]:
            sos = _mode_sos(float(f), float(z), float(g), fs)
            zi = signal.sosfilt_zi(sos) * inputs[s, 0]  # start in the steady state of the first force
            y += signal.sosfilt(sos, inputs[s], zi=zi)[0]
        clean[s] = signal.sosfilt(aa, y)[first:]
    return clean, index[first:]


def _worn_bearing(
    run: CrankRun,
    cycle: float,
    install: Installation,
    scenario: _Scenario,
    pre: float,
    duration_s: float,
    rng: np.random.Generator,
) -> tuple[FloatArray, dict[str, Any]]:
    """Ringing bursts at a bearing's load reversals, as seen by every sensor, shape (s, samples).

    ``cycle`` is the engine's cycle angle [rad].
    """
    fs = install.sample_rate
    count = len(install.sensor_bearings)
    span = round((pre + duration_s) * fs) - round(pre * fs)
    found = []
    for s in range(count):
        force = run.forces[count + s]
        found.append(_reversals(force, 0.03 * float(np.abs(force).max())))
    pool = [s for s in range(count) if found[s][1] == "sign"] or list(range(count))
    worn = pool[min(int(scenario.bearing_choice * len(pool)), len(pool) - 1)]
    where, how = found[worn]
    when = _cubic(run.time, where) - pre
    when = np.sort(when[(when >= 0) & (when < duration_s - 0.01)])
    position = when * fs
    i0 = np.floor(position).astype(np.int64)
    frac = position - i0
    sizes = np.clip(1 + 0.3 * rng.standard_normal(when.size), 0.3, None) * rng.choice([-1.0, 1.0], when.size)
    pulses = np.zeros(span)
    np.add.at(pulses, i0, sizes * (1 - frac))
    np.add.at(pulses, np.minimum(i0 + 1, span - 1), sizes * frac)
    w0 = 2 * math.pi * scenario.burst_frequency / fs
    r = math.exp(-scenario.burst_frequency / (scenario.burst_cycles * fs))
    ring = signal.lfilter([0.0, r * math.sin(w0)], [1.0, -2 * r * math.cos(w0), r * r], pulses)
    bursts = np.empty((count, span))
    for s in range(count):  # burst over noise falls by the attenuation per bearing of distance
        distance = abs(install.sensor_bearings[s] - install.sensor_bearings[worn])
        bursts[s] = scenario.burst_size * scenario.neighbour**distance * float(install.noise[s]) * ring
    first = float(np.searchsorted(run.time, pre))  # the recording's first grid point
    one = where[(where >= first) & (where < first + cycle / run.step)]  # one cycle's reversals
    angles = np.sort(np.mod(np.degrees(one * run.step), math.degrees(cycle)))
    truth = {
        "bearing": install.sensor_bearings[worn],
        "channel": install.channel_name(worn),
        "strength": scenario.burst_size,
        "burst_frequency_hz": scenario.burst_frequency,
        "burst_decay_cycles": scenario.burst_cycles,
        "burst_count": int(when.size),
        "burst_amplitude_m_s2": scenario.burst_size * float(install.noise[worn]),
        "neighbour_attenuation": scenario.neighbour,
        "reversal": how,
        "reversal_angles_deg": [round(float(a), 2) for a in angles],
    }
    return bursts, truth


def _bearing_channel(
    x: FloatArray, s: int, install: Installation, scenario: _Scenario, rng: np.random.Generator
) -> tuple[Channel, dict[str, Any]]:
    """One accelerometer channel, with its sensor fault if it has one (16-bit over its range)."""
    fs = install.sample_rate
    full = float(install.adc_range[s])
    unit_scale = 1.0
    truth: dict[str, Any] = {}
    if scenario.sensor == s:
        kind = scenario.sensor_fault
        truth = {
            "channel": install.channel_name(s),
            "bearing": install.sensor_bearings[s],
            "sensor_fault": kind,
        }
        if kind == "clipped":
            peak = float(np.abs(x).max())
            level = scenario.clip_fraction * peak
            for _ in range(8):  # lower the range until the product's own rule sees clipped runs
                cut = np.clip(x, -level, level).astype(np.float32)
                spans, _ = quality_spans(cut, fs, limits=(-level, level))
                if len(spans) >= 3:
                    break
                level *= 0.8
            full = level
            x = np.clip(x, -level, level)
            truth["strength"] = level / peak
        elif kind == "dead_flat":
            x = np.full(x.size, float(rng.normal(0.0, install.noise[s])))
            truth["strength"] = 0.0
        elif kind == "dead_noise":
            x = rng.normal(0.0, float(install.noise[s]) * float(rng.uniform(0.5, 2.0)), x.size)
            truth["strength"] = 0.0
        elif kind == "unit_x1000":
            unit_scale = 1000.0
            truth["strength"] = 1000.0
        else:
            unit_scale = 1 / 9.81
            truth["strength"] = 1 / 9.81
    data = (_quantise(x, full) * unit_scale).astype(np.float32)
    lsb = 2 * full / 2**16  # the range is the converter's codes: -32768 to +32767 LSB
    low, high = -full * unit_scale, (full - lsb) * unit_scale
    channel = Channel(
        name=install.channel_name(s),
        kind="acceleration",
        unit="m/s^2",
        data=data,
        sample_rate=fs,
        location=f"main bearing {install.sensor_bearings[s]}",
        direction="vertical",
        range=(low, high),
    )
    return channel, truth


def _angle_channels(
    engine: SimEngine,
    install: Installation,
    run: CrankRun,
    pre: float,
    duration_s: float,
    rng: np.random.Generator,
) -> list[Channel]:
    """The 60-2 tooth wheel, the cam (four-strokes) and the keyphasor (if fitted), as event times."""
    present = np.arange(58)
    tooth_angles = install.first_tooth_angle + 2 * math.pi * present / 60 + install.tooth_errors[present]
    teeth = _events(run, pre, duration_s, tooth_angles, 2 * math.pi, install.tooth_jitter, rng)
    channels = [
        Channel(
            name="crank-teeth",
            kind="tooth",
            unit="s",
            data=teeth,
            sample_rate=None,
            location="flywheel",
            fields={
                "teeth": 60,
                "missing_teeth": 2,
                "first_tooth_angle_deg": round(math.degrees(install.first_tooth_angle), 6),
            },
        )
    ]
    if install.cam_angle is not None:
        cam = _events(
            run, pre, duration_s, np.array([install.cam_angle]), engine.cycle_angle, install.cam_jitter, rng
        )
        channels.append(
            Channel(
                name="cam",
                kind="cam",
                unit="s",
                data=cam,
                sample_rate=None,
                location="camshaft",
                fields={"cam_angle_deg": round(math.degrees(install.cam_angle), 6)},
            )
        )
    if install.keyphasor_angle is not None:
        pulses = _events(
            run, pre, duration_s, np.array([install.keyphasor_angle]), 2 * math.pi, install.tooth_jitter, rng
        )
        channels.append(
            Channel(
                name="keyphasor",
                kind="keyphasor",
                unit="s",
                data=pulses,
                sample_rate=None,
                location="flywheel",
                fields={"pulse_angle_deg": round(math.degrees(install.keyphasor_angle), 6)},
            )
        )
    return channels


def _simulate(
    engine_seed: int,
    noise_seed: int,
    *,
    twin: bool,
    duration_s: float,
    fault: str | None,
    load: float | None = None,
) -> Case:
    """A case: ``engine_seed`` gives engine, installation, description, operating point and fault."""
    if not (math.isfinite(duration_s) and duration_s >= 1.0):
        raise ValueError(f"duration_s = {duration_s!r}: expected a duration of at least 1 s")
    if noise_seed < 0:
        raise ValueError(f"seed = {noise_seed}: expected an integer >= 0")
    engine = random_engine(engine_seed)
    install = random_installation(engine)
    toml_text = engine_description(engine)
    scenario = _scenario(engine, install, engine_seed, fault)
    if load is not None:  # a healthy twin at the case's operating point
        scenario = _Scenario(load=load, given_ratio=scenario.given_ratio, fault="healthy")
    words = [noise_seed, _NOISE, _TWIN] if twin else [noise_seed, _NOISE]
    rng = np.random.default_rng(np.random.SeedSequence(words))
    n = engine.cylinders
    factors = np.ones(n)
    if scenario.cylinder is not None:
        factors[scenario.cylinder - 1] = scenario.factor
    # the cycle table at the healthy operating speed (propeller: where the rated curve meets the load)
    rated_net = engine.rated_indicated_torque - engine.friction_torque
    if engine.load_type == "propeller":
        net = scenario.load * engine.rated_indicated_torque - engine.friction_torque
        speed_guess = engine.rated_speed * math.sqrt(max(net, 0.05 * rated_net) / rated_net)
    else:
        speed_guess = engine.rated_speed
    table = cycle_table(
        engine,
        speed=speed_guess,
        charge_pressure=_charge_pressure(engine, scenario.load),
        fuel=HEAT_STEP * np.arange(HEAT_LEVELS),
        heat_reference=_rated_of_seed(engine_seed)[0],
    )
    load_model, fuel, speed0 = operating_load(engine, table, scenario.load, factors)
    # cycle-to-cycle scatter of the heat release that gives the engine's peak-pressure scatter
    healthy = table.fuel_for(scenario.load * engine.rated_imep)
    fired = float(np.interp(healthy, table.fuel, table.peak_pressure))
    rise = float(np.interp(healthy * 1.02, table.fuel, table.peak_pressure)) - fired
    heat_scatter = min(engine.peak_pressure_scatter / max(rise / (0.02 * fired), 1e-3), 0.04)

    def variation(_: int) -> FloatArray:
        return np.asarray(1 + np.clip(rng.normal(0.0, heat_scatter, n), -4 * heat_scatter, 4 * heat_scatter))

    fs = install.sample_rate
    pre = math.ceil(max(0.5, 2 * engine.cycle_angle / speed0) * fs) / fs
    split = bearing_split(engine.cylinder_positions, engine.bearing_positions, engine.throw_bearings)
    pure = split[[b - 1 for b in install.sensor_bearings]]
    revolutions_per_second = speed0 / (2 * math.pi)
    ppr = (
        720 if fs / revolutions_per_second <= 720 else int(360 * math.ceil(fs / revolutions_per_second / 360))
    )
    run = run_crank(
        engine,
        table,
        load_model,
        fuel=fuel,
        end_time=pre + duration_s + 0.05,
        initial_speed=speed0,
        fault_factors=factors,
        variation=variation,
        mixes=np.vstack([_sensor_mix(engine, install.crosstalk), pure]),
        points_per_revolution=ppr,
    )
    count = len(install.sensor_bearings)
    clean, _ = _structural_response(run, install, pre, duration_s)
    span = clean.shape[1]
    tt = np.arange(span) / fs
    phase = rng.uniform(0, 2 * math.pi, (count, 2))
    data = np.empty((count, span))
    for s in range(count):
        hum = install.hum[s] * (
            np.sin(2 * math.pi * install.hum_frequency * tt + phase[s, 0])
            + 0.3 * np.sin(6 * math.pi * install.hum_frequency * tt + phase[s, 1])
        )
        data[s] = clean[s] + hum + rng.normal(0.0, install.noise[s], span)
    truth: dict[str, Any] = {
        "class": scenario.fault,
        "cylinder": scenario.cylinder,
        "bearing": None,
        "channel": None,
        "strength": None,
        "sensor_fault": None,
    }
    if scenario.fault == "worn_bearing":
        bursts, details = _worn_bearing(run, engine.cycle_angle, install, scenario, pre, duration_s, rng)
        data += bursts
        truth.update(details)
    elif scenario.fault == "weak":
        truth.update(strength=1 - scenario.factor, weak_factor=scenario.factor)
    elif scenario.fault == "misfire":
        truth.update(strength=1.0)
    channels = []
    for s in range(count):
        channel, details = _bearing_channel(data[s], s, install, scenario, rng)
        channels.append(channel)
        truth.update(details)
    channels.extend(_angle_channels(engine, install, run, pre, duration_s, rng))
    start = datetime(2026, 1, 1, tzinfo=UTC) + timedelta(minutes=engine_seed % 500_000)
    if twin:
        start -= timedelta(days=1, minutes=noise_seed % 1000)
    recording = Recording(
        engine_id=engine.ident,
        start_time=start.strftime("%Y-%m-%dT%H:%M:%SZ"),
        channels=tuple(channels),
        notes=f"validation simulator: engine seed {engine_seed}, noise seed {noise_seed}",
    )
    # what ran inside the recording: whole cycles that end in it
    ends = np.cumsum(engine.cycle_angle / run.cycle_speed)
    inside = (ends - engine.cycle_angle / run.cycle_speed >= pre) & (ends <= pre + duration_s)
    if not inside.any():
        inside = ends > pre
    imep = run.imep[:, inside]
    peak = np.interp(run.fuel[:, inside], table.fuel, table.peak_pressure)
    in_span = (run.time >= pre) & (run.time <= pre + duration_s)
    covered = run.time[in_span]
    mean_speed = run.step * (covered.size - 1) / float(covered[-1] - covered[0])
    true_load = float(imep.mean() / engine.rated_imep)
    truth.update(
        true_load=true_load,
        load_given_ratio=scenario.given_ratio,
        load_type=engine.load_type,
        mean_speed_rpm=mean_speed * 30 / math.pi,
        speed_rpm=mean_speed * 30 / math.pi,  # the same, under a shorter name
        rated_speed_rpm=engine.rated_speed * 30 / math.pi,
        cycle="two-stroke" if engine.cycle_revolutions == 1 else "four-stroke",
        cylinders=n,
        engine_class=engine.engine_class,
        firing_order=list(engine.firing_order),
        imep_bar=[float(v) / 1e5 for v in imep.mean(axis=1)],
        peak_pressure_bar=[float(v) / 1e5 for v in peak.mean(axis=1)],
        peak_pressure_scatter=[float(v) for v in peak.std(axis=1) / peak.mean(axis=1)],
        sensor_bearings=list(install.sensor_bearings),
        sample_rate_hz=fs,
        engine_seed=engine_seed,
        noise_seed=noise_seed,
        twin=twin,
        duration_s=duration_s,
        scenario_load=scenario.load,
    )
    return Case(
        seed=noise_seed if twin else engine_seed,
        engine_toml=toml_text,
        recording=recording,
        load_given=true_load * scenario.given_ratio,
        truth=truth,
    )


def random_case(seed: int, *, duration_s: float, fault: str | None = "random") -> Case:
    """Simulate one validation case.

    Parameters
    ----------
    seed : int
        Everything comes from it (>= 0).
    duration_s : float
        Length of the recording [s] (>= 1).
    fault : str or None, optional
        "random" (each of :data:`FAULT_CLASSES` equally likely; no misfire on a single-cylinder
        engine), None or "healthy", one class, or "sensor_fault:KIND" to choose the sensor fault
        (clipped, dead_flat, dead_noise, unit_x1000, unit_per_9.81).

    Returns
    -------
    Case
        ``truth`` holds ``class``, ``cylinder`` (misfire, weak), ``bearing`` and ``channel`` (worn
        bearing, sensor fault), ``strength`` (misfire 1, weak 1 - factor, worn bearing the burst
        amplitude over the noise, sensor fault the clip level over the peak, the unit factor, or 0
        for a dead channel), ``sensor_fault`` (clipped, dead_flat, dead_noise, unit_x1000,
        unit_per_9.81), ``true_load`` (mean IMEP of all cylinders over the rated IMEP), the mean
        speed (``mean_speed_rpm``, also ``speed_rpm``), ``cycle``, ``cylinders``, the IMEP and peak
        pressure of every cylinder, the reversal angles and bursts of a worn bearing, and the seeds.

    Raises
    ------
    ValueError
        For a negative seed, a duration under 1 s or an unknown fault.
    SimulationError
        For a misfire asked of a single-cylinder engine.
    """
    return _simulate(seed, seed, twin=False, duration_s=duration_s, fault=fault)


def healthy_twin(case: Case, *, seed: int) -> Case:
    """The same engine and installation, healthy, with another noise and cycle-variation seed.

    Parameters
    ----------
    case : Case
        A case from :func:`random_case` (or a twin).
    seed : int
        Seed of the twin's noise and cycle-to-cycle variation (>= 0).

    Returns
    -------
    Case
        Same description and engine id, same duration and load as ``case`` (a healthy engine at
        the case's operating point): the baseline a user would calibrate on.
    """
    truth = case.truth
    return _simulate(
        int(truth["engine_seed"]),
        seed,
        twin=True,
        duration_s=float(truth["duration_s"]),
        fault=None,
        load=float(truth["scenario_load"]),
    )


def population(
    n: int, *, durations: tuple[float, ...] = (10.0, 30.0, 60.0), first_seed: int = 0
) -> Iterator[Case]:
    """Random cases of seeds ``first_seed .. first_seed + n - 1``, durations in turn.

    Parameters
    ----------
    n : int
        Number of cases.
    durations : tuple of float, optional
        Recording lengths, used in turn [s].
    first_seed : int, optional
        Seed of the first case.

    Yields
    ------
    Case
    """
    if not durations:
        raise ValueError("durations: expected at least one duration [s]")
    for i in range(n):
        yield random_case(first_seed + i, duration_s=durations[i % len(durations)])
