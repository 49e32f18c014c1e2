"""Cylinder pressure: the single-zone closed cycle, the open cycle and the cycle tables over fuel."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import numpy.typing as npt
from scipy.integrate import solve_ivp

from validation.simulator.engine import DoubleWiebe, SimEngine, random_engine
from validation.simulator.kinematics import engine_kinematics
from validation.simulator.linkage import slave_travel
from validation.simulator.shared import AMBIENT_PRESSURE, FloatArray, SimulationError
from validation.simulator.vee_engine import random_vee_engine

#: Specific gas constant of the cylinder charge [J/(kg K)].
GAS_CONSTANT = 287.0
#: Ratio of specific heats at 300 K [-] and its fall per kelvin [1/K] (linear fit for air/burned gas).
GAMMA_300 = 1.39
GAMMA_SLOPE = 6.5e-5

#: Fuel (heat release) levels of a cycle table, in units of the engine's rated heat [-].
HEAT_STEP = 0.05
HEAT_LEVELS = 33  # 0 .. 1.6


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


def wiebe(
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
    xp, rp = wiebe(theta, law.start, law.premixed_duration, law.premixed_shape, law.a)
    xd, rd = wiebe(theta, law.start + law.diffusion_delay, law.diffusion_duration, law.diffusion_shape, law.a)
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


def _volume(engine: SimEngine, psi: npt.ArrayLike, slave: bool = False) -> tuple[FloatArray, FloatArray]:
    """Cylinder volume [m^3] and dV/dpsi [m^3/rad]: ``V = V_c + A (R + L - y_p)``.

    An articulated slave's (``slave``): ``V = V_c + A (s_TDC - s)``, ``s`` its piston pin's distance
    from the crankshaft axis (:mod:`validation.simulator.linkage`), ``psi`` from its own TDC; the
    clearance volume is the master's (the same head and piston).
    """
    if slave:
        travel, rate = slave_travel(engine.linkage, psi)
        return engine.clearance_volume + engine.piston_area * travel, engine.piston_area * rate
    k = engine_kinematics(engine, psi)
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
    slave: bool = False,
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
    slave : bool, optional
        On an articulated slave's volume (:func:`_volume`).

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
    v0, _ = _volume(engine, theta[0], slave)
    t0 = engine.charge_temperature
    mass = float(charge_pressure * v0 / (GAS_CONSTANT * t0))
    mean_piston_speed = 2 * engine.crank_radius * speed / math.pi
    law = engine.combustion
    tw = engine.wall_temperature
    loss = 1.0 if heat_loss else 0.0

    def rhs(angle: float, y: FloatArray) -> FloatArray:
        temperature = np.maximum(y[:rows], 50.0)
        v, dv = _volume(engine, angle, slave)
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
    volume, _ = _volume(engine, theta, slave)
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
    slave_pressure : ndarray, shape (L, N), optional
        An articulated slave's, on its own volume from its own TDC (the same fuel) [Pa].
    """

    crank_angle: FloatArray
    fuel: FloatArray
    heat: FloatArray
    pressure: FloatArray
    imep: FloatArray
    peak_pressure: FloatArray
    speed: float
    charge_pressure: float
    slave_pressure: FloatArray | None = None

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
    open_angle = np.where(theta <= engine.inlet_closing, theta + cycle, theta)[~closed]

    def trace(slave: bool) -> FloatArray:
        part = closed_cycle(
            engine, heat=heat, speed=speed, charge_pressure=charge_pressure, crank_angle=angles, slave=slave
        )
        p = np.empty((levels.size, n))
        p[:, closed] = part.pressure[:, 1:-1]
        p[:, ~closed] = _open_pressure(engine, open_angle, part.pressure[:, -1], charge_pressure)
        return p

    pressure = trace(slave=False)
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
        slave_pressure=trace(slave=True) if engine.rods == "articulated" else None,
    )


def load_charge_pressure(engine: SimEngine, load: float) -> float:
    """Charge pressure at a load (turbocharger boost about proportional to load) [Pa]."""
    return AMBIENT_PRESSURE + max(load, 0.0) * (engine.rated_charge_pressure - AMBIENT_PRESSURE)


def held_charge_pressure(engine: SimEngine, load: float) -> float:
    """Charge pressure held at its rated value at every load (a blower or a held boost) [Pa].

    Parameters
    ----------
    engine : SimEngine
    load : float
        Engine load [-] (the charge pressure does not depend on it).

    Returns
    -------
    float
        [Pa].
    """
    del load
    return engine.rated_charge_pressure


#: The charge-pressure laws a case's engine may follow, by name.
CHARGE_LAWS = {"turbocharged": load_charge_pressure, "held": held_charge_pressure}


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
def rated_of_seed(seed: int, vee: bool = False) -> tuple[float, FloatArray, FloatArray]:
    """Rated heat [J], and the crank angle [rad] and pressure [Pa] of the rated cycle, of a seed's engine.

    ``vee`` takes the seed's V engine (:func:`~validation.simulator.vee_engine.random_vee_engine`).
    """
    engine = random_vee_engine(seed) if vee else random_engine(seed)
    heat, table = _rated_table(engine)
    pressure = np.array([np.interp(heat / table.heat[1], table.fuel, column) for column in table.pressure.T])
    return heat, table.crank_angle, pressure
