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
propulsion 1/150-1/70).  V engines come from :func:`random_vee_engine` (a stream of their own, so
the in-line population is unchanged): medium-speed (45-60 deg V, 500-1000 rpm) and high-speed
(60-90 deg V, 1200-1900 rpm) four-strokes of 12-20 cylinders, banks A and B named ``A1..Am``,
``B1..Bm``, ``Ak`` and ``Bk`` on throw ``k``, side-by-side (B a bank offset further along the shaft),
fork-and-blade or articulated rods; each bank fires as an in-line engine and the trailing bank's
cylinder the bank angle after its partner (an articulated slave at its own TDC).  Articulated rods
(:mod:`validation.simulator.linkage`) are solved apart from the product's closed form: the linkage
by Newton's method on its loop equations, its forces by Lagrange multipliers on rigid bodies (the
slave rod with its own moment of inertia, where the product splits it as a two-mass rod), and a
slave's pressure on its own volume.

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
net unbalance.  Across the cylinder axis (:func:`throw_across_force`) Newton-Euler on the piston
and on the rod as a rigid body (its centre of gravity and moment of inertia) gives the rod's
force on the crank pin, the liner's side force on the piston staying in the frame; on a V engine
each cylinder's along- and across-axis forces are turned into the engine's vertical by its bank's
lean (:func:`cylinder_vertical_forces`), a throw's unbalance shared by its two cylinders.  A
cylinder's force is shared by its throw's two main bearings by the lever rule at the true (slightly
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
(where it never does, at the prominent minima of its magnitude; on a V engine, whose bearing loads
turn in the plane with horizontal parts as large as the vertical, at the prominent minima of the
load's planar magnitude, where the journal crosses its clearance), 3-6 times that sensor's noise,
and on the other sensors with that ratio times 0.15-0.35 per bearing of distance.
``sensor_fault``: one bearing channel clipped (its range lowered until the peaks are cut),
dead (flat, or noise only), or in the wrong unit (data x 1000 or / 9.81, range with them).
A generator engine keeps its speed through a misfire or a weak cylinder by giving the others
more fuel; a propeller engine at a fixed fuel slows down.

Operating points (:mod:`validation.simulator.operating`).  A case runs at its healthy twin's load
(the baseline's point), or off it: a propeller engine anywhere on its curve at 60-100 % of rated
speed, a generator at 25-100 % load at rated speed, a step from one such load to another inside
the recording (:class:`LoadStep`: the load, the fuel and the cycle table change at once, the
governor or the propeller's curve taking the crank to the new speed), or an engine with its angle
sensors alone.  Off the baseline's point the charge pressure falls with the load
(turbocharged) or is held at its rated value, drawn per engine.

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

from validation.simulator.cases import Case, healthy_twin, law_loads, population, random_case
from validation.simulator.crank import CrankRun, Load, LoadStep, operating_load, run_crank
from validation.simulator.description import description_engine, engine_description
from validation.simulator.engine import DoubleWiebe, SimEngine, random_engine
from validation.simulator.gas import (
    GAMMA_300,
    GAMMA_SLOPE,
    GAS_CONSTANT,
    HEAT_LEVELS,
    HEAT_STEP,
    ClosedCycle,
    CycleTable,
    burned_fraction,
    closed_cycle,
    cycle_table,
    gamma,
    internal_energy,
    rated_heat,
    wall_heat_transfer_coefficient,
)
from validation.simulator.installation import Installation, random_installation
from validation.simulator.kinematics import (
    SliderCrank,
    bearing_split,
    cylinder_vertical_forces,
    equivalent_inertia,
    slider_crank,
    throw_across_force,
    throw_vertical_force,
)
from validation.simulator.operating import OPERATING_CLASSES, OperatingPoint
from validation.simulator.scenario import FAULT_CLASSES
from validation.simulator.shared import AMBIENT_PRESSURE, SimulationError
from validation.simulator.vee_engine import engine_of_seed, random_vee_engine

__all__ = [
    "AMBIENT_PRESSURE",
    "FAULT_CLASSES",
    "GAMMA_300",
    "GAMMA_SLOPE",
    "GAS_CONSTANT",
    "HEAT_LEVELS",
    "HEAT_STEP",
    "OPERATING_CLASSES",
    "Case",
    "ClosedCycle",
    "CrankRun",
    "CycleTable",
    "DoubleWiebe",
    "Installation",
    "Load",
    "LoadStep",
    "OperatingPoint",
    "SimEngine",
    "SimulationError",
    "SliderCrank",
    "bearing_split",
    "burned_fraction",
    "closed_cycle",
    "cycle_table",
    "cylinder_vertical_forces",
    "description_engine",
    "engine_description",
    "engine_of_seed",
    "equivalent_inertia",
    "gamma",
    "healthy_twin",
    "internal_energy",
    "law_loads",
    "operating_load",
    "population",
    "random_case",
    "random_engine",
    "random_installation",
    "random_vee_engine",
    "rated_heat",
    "run_crank",
    "slider_crank",
    "throw_across_force",
    "throw_vertical_force",
    "wall_heat_transfer_coefficient",
]
