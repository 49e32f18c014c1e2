"""Crank dynamics: the rigid crank integrated over angle under gas, friction and load torques."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

from validation.simulator.engine import SimEngine
from validation.simulator.gas import HEAT_LEVELS, HEAT_STEP, CycleTable
from validation.simulator.kinematics import (
    equivalent_inertia,
    inertia_force_coefficients,
    piston_arm,
    vertical_force_coefficients,
)
from validation.simulator.shared import AMBIENT_PRESSURE, FloatArray, SimulationError


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
class LoadStep:
    """A change of load inside a run: from ``time`` on, another load, fuel and cycle table.

    Attributes
    ----------
    time : float
        When the load changes [s].
    load : Load
        What the crank drives after it (a generator's torque changes at once).
    fuel : float
        Healthy cylinders' fuel level after it (a propeller's fixed fuel, a governor's feed-forward)
        [-]; it takes effect at the first firing not yet begun, about a cycle later.
    table : CycleTable
        Cylinder pressure against fuel level at the new operating point (charge pressure, speed).
    """

    time: float
    load: Load
    fuel: float
    table: CycleTable


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
    step_firing : int
        The first firing at the load after a :class:`LoadStep` (F if the run has none).
    """

    step: float
    time: FloatArray
    speed: FloatArray
    acceleration: FloatArray
    forces: npt.NDArray[np.float32]
    fuel: FloatArray
    imep: FloatArray
    cycle_speed: FloatArray
    step_firing: int = -1


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
    horizontal_mixes: npt.ArrayLike | None = None,
    points_per_revolution: int = 720,
    settle_start: bool = True,
    step: LoadStep | None = None,
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
        ``variation(firing)``: the cylinders' fuel multipliers of that firing, shape (n,), called in order.
    mixes : array_like, shape (R, n), optional
        Rows of throw-force weights whose sums to keep (bearing sensors' views) [-].
    horizontal_mixes : array_like, shape (H, n), optional
        On a V engine, rows of weights of the cylinders' horizontal forces to keep after those [-].
    points_per_revolution : int, optional
        Grid points per revolution.
    settle_start : bool, optional
        Start on the periodic orbit (the first cycle's energy scaled to mean ``initial_speed``).
    step : LoadStep, optional
        A change of load during the run; default none.

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
    crank = _AngleWindows(
        engine,
        table,
        load,
        fuel=fuel,
        end_time=end_time,
        initial_speed=initial_speed,
        fault_factors=fault_factors,
        variation=variation,
        mixes=mixes,
        points_per_revolution=points_per_revolution,
        horizontal_mixes=horizontal_mixes,
    )
    cycle = engine.cycle_angle
    energy0 = 0.5 * float(crank.inertia[0]) * initial_speed**2
    for _ in range(4 if settle_start else 0):
        energy0 *= (initial_speed * crank.window(0, energy0, 0.0, False)[3][-1] / cycle) ** 2
    times: list[FloatArray] = []
    speeds: list[FloatArray] = []
    accels: list[FloatArray] = []
    force_parts: list[FloatArray] = []
    cycle_speed: list[float] = []
    t0, k, integral = 0.0, 0, 0.0
    (kp, ki), base = load.governor_gains, fuel
    while t0 < end_time:
        if step is not None and crank.switch_column < 0 and t0 >= step.time:
            base, (kp, ki) = step.fuel, step.load.governor_gains
            crank.switch(step, k + 3)
        energy, omega, accel, time, forces = crank.window(k, energy0, t0, True)
        times.append(time[:-1])
        speeds.append(omega[:-1])
        accels.append(accel[:-1])
        force_parts.append(forces[:, :-1].astype(np.float32))
        cycle_speed.append(mean := cycle / (time[-1] - time[0]))
        if crank.load.kind == "generator":
            error = (crank.load.speed_reference - mean) / crank.load.speed_reference
            integral += error
            crank.draw_until(k + 3)
            crank.sigma[k + 3] = float(np.clip(base * (1 + kp * error + ki * integral), 0.0, load.fuel_limit))
        energy0, t0 = float(energy[-1]), float(time[-1])
        k += 1
        if k > 10_000_000:  # pragma: no cover - a guard, not a case
            raise SimulationError("the crank simulation does not advance")
    fired, imep, step_firing = _firings(crank, table, step, k)
    return CrankRun(
        step=crank.step,
        time=np.concatenate(times),
        speed=np.concatenate(speeds),
        acceleration=np.concatenate(accels),
        forces=np.concatenate(force_parts, axis=1) if force_parts else np.zeros((0, 0), np.float32),
        fuel=fired,
        imep=imep,
        cycle_speed=np.asarray(cycle_speed),
        step_firing=step_firing,
    )


def _firings(
    crank: _AngleWindows, table: CycleTable, step: LoadStep | None, windows: int
) -> tuple[FloatArray, FloatArray, int]:
    """Each cylinder's fuel and IMEP of the run's firings, and the first firing after a load step."""
    columns = np.arange(1, windows + 1)  # firings 0 .. windows - 1
    fired = crank.sigma[columns][None, :] * crank.factors[:, None] * crank.multiplier[:, columns]
    imep = table.imep_at(fired)
    step_firing = windows
    if step is not None and crank.switch_column >= 0:
        step_firing = min(crank.switch_column - 1, windows)
        imep[:, step_firing:] = step.table.imep_at(fired[:, step_firing:])
    return fired, imep, step_firing


class _AngleWindows:
    """The crank integrated one cycle window at a time (the constants of :func:`run_crank` per window).

    A window is one cycle of cylinder 1's crank angle; each cylinder's grid points belong to the
    firing before or after its own firing TDC, whose fuel (``sigma``, per firing, firing ``f`` at
    column ``f + 1``) times its fault factor and cycle-to-cycle multiplier sets its pressure.
    """

    def __init__(
        self,
        engine: SimEngine,
        table: CycleTable,
        load: Load,
        *,
        fuel: float,
        end_time: float,
        initial_speed: float,
        fault_factors: npt.ArrayLike | None,
        variation: Callable[[int], FloatArray] | None,
        mixes: npt.ArrayLike | None,
        points_per_revolution: int,
        horizontal_mixes: npt.ArrayLike | None = None,
    ) -> None:
        n = engine.cylinders
        self.engine, self.load, self.variation = engine, load, variation
        cycle = engine.cycle_angle
        m = points_per_revolution * engine.cycle_revolutions
        self.m = m
        step = cycle / m
        self.step = step
        alpha = step * np.arange(m + 1)
        phase = engine.firing_angles
        psi = alpha[None, :] - phase[:, None]
        self.factors = np.ones(n) if fault_factors is None else np.asarray(fault_factors, dtype=np.float64)
        weights = np.zeros((0, n)) if mixes is None else np.atleast_2d(np.asarray(mixes, dtype=np.float64))
        self.weights = weights
        # per-window constants
        inertia_c, derivative_c = equivalent_inertia(engine, psi)
        self.inertia = engine.rigid_inertia + inertia_c.sum(axis=0)
        self.inertia_1 = derivative_c.sum(axis=0)
        self.arm = piston_arm(engine, psi)  # dx/dpsi, piston travel from TDC
        if engine.is_vee:  # each cylinder's vertical force: along and across its leaning axis
            g, k2, k1 = vertical_force_coefficients(engine, psi)
            across = (
                np.zeros((0, n))
                if horizontal_mixes is None
                else np.atleast_2d(np.asarray(horizontal_mixes, float))
            )
            gh, k2h, k1h = vertical_force_coefficients(engine, psi, horizontal=True)
            self.gas_rows = np.concatenate([weights[:, :, None] * g[None], across[:, :, None] * gh[None]])
            self.k2_rows = -np.vstack([weights @ k2, across @ k2h])
            self.k1_rows = -np.vstack([weights @ k1, across @ k1h])
        else:
            k2, k1 = inertia_force_coefficients(engine, psi)
            self.k2_rows, self.k1_rows = weights @ k2, weights @ k1
            self.gas_rows = np.zeros((0, n, 0))
        self.area = engine.piston_area
        # firing index of each grid point of each cylinder, relative to the window (-1, 0 or 1)
        part = np.floor((psi + cycle / 2) / cycle).astype(int)
        self.low = part.min(axis=1)
        self.high = part == self.low[:, None] + 1
        self.wrapped = np.mod(psi + cycle / 2, cycle) - cycle / 2
        self.tab = self._tabulate(table)
        self.tab_after = self.tab
        self.switch_column = -1  # the first firing column at the load after a step (none: -1)
        fuel_step = float(table.fuel[1] - table.fuel[0]) if table.fuel.size >= 2 else 0.0
        if not (fuel_step > 0 and table.fuel[0] == 0 and np.allclose(np.diff(table.fuel), fuel_step)):
            raise ValueError("table: expected fuel levels 0, d, 2 d, ... (uniform, from zero) [-]")
        self.fuel_step = fuel_step
        self.tab_fuel = table.fuel
        self.top = table.fuel.size - 2
        self.rows = np.arange(n)
        self.k_prop = load.propeller_coefficient
        self.beta = 2 * self.k_prop / self.inertia
        growth = _cumtrapz(self.beta, step)
        self.grow, self.shrink = np.exp(growth), np.exp(-growth)
        # fuel of every firing; firing f is stored at column f + 1
        estimate = int(end_time * initial_speed / cycle * 1.3) + 8
        self.sigma = np.full(estimate + 4, fuel)
        self.multiplier = np.ones((n, estimate + 4))
        self.drawn = 0

    def _tabulate(self, table: CycleTable) -> FloatArray:
        """Each cylinder's pressure at each fuel level over the window's grid [Pa] (a slave's its own)."""
        n, m = self.wrapped.shape
        cycle = self.engine.cycle_angle
        tab = np.empty((n, table.fuel.size, m))
        slaves = self.engine.slaves
        slave_pressure = table.slave_pressure
        if slave_pressure is None:
            if slaves.any():
                raise ValueError("table: expected the slaves' pressure of an engine on articulated rods")
            slave_pressure = table.pressure
        for c in range(n):
            trace = slave_pressure if slaves[c] else table.pressure
            for level in range(table.fuel.size):
                tab[c, level] = np.interp(self.wrapped[c], table.crank_angle, trace[level], period=cycle)
        return tab

    def switch(self, step: LoadStep, column: int) -> None:
        """Drive ``step.load`` from now on and fire ``step.fuel`` from firing column ``column``."""
        if not np.array_equal(step.table.fuel, self.tab_fuel):
            raise ValueError("step.table: expected the fuel levels of the run's table")
        self.load = step.load
        self.k_prop = step.load.propeller_coefficient
        self.beta = 2 * self.k_prop / self.inertia
        growth = _cumtrapz(self.beta, self.step)
        self.grow, self.shrink = np.exp(growth), np.exp(-growth)
        self.tab_after = self._tabulate(step.table)
        self.draw_until(column)
        self.sigma[column:] = step.fuel
        self.switch_column = column

    def pressure_of(self, levels: FloatArray, columns: npt.NDArray[np.int_]) -> FloatArray:
        pos = np.clip(levels / self.fuel_step, 0.0, self.top + 1.0)
        i = np.minimum(pos.astype(int), self.top)
        w = (pos - i)[:, None]
        before = (1 - w) * self.tab[self.rows, i] + w * self.tab[self.rows, i + 1]
        if self.switch_column < 0 or not (columns >= self.switch_column).any():
            return np.asarray(before)
        after = (1 - w) * self.tab_after[self.rows, i] + w * self.tab_after[self.rows, i + 1]
        return np.asarray(np.where((columns >= self.switch_column)[:, None], after, before))

    def draw_until(self, column: int) -> None:
        while column >= self.sigma.size:
            self.sigma = np.concatenate([self.sigma, np.full(self.sigma.size, self.sigma[-1])])
            self.multiplier = np.concatenate([self.multiplier, np.ones_like(self.multiplier)], axis=1)
        while self.drawn <= column:
            if self.variation is not None:
                self.multiplier[:, self.drawn] = self.variation(self.drawn - 1)
            self.drawn += 1

    def window(self, k: int, energy0: float, time0: float, keep: bool) -> tuple[FloatArray, ...]:
        """Energy, speed, acceleration, time and (if ``keep``) the kept force rows over window ``k``."""
        self.draw_until(k + 2)
        rows, factors, multiplier = self.rows, self.factors, self.multiplier
        col0 = k + self.low + 1
        q0 = self.sigma[col0] * factors * multiplier[rows, col0]
        q1 = self.sigma[col0 + 1] * factors * multiplier[rows, col0 + 1]
        p = np.where(self.high, self.pressure_of(q1, col0 + 1), self.pressure_of(q0, col0))
        gas = (p - AMBIENT_PRESSURE) * self.area
        source = (gas * self.arm).sum(axis=0) - self.load.torque
        if self.k_prop > 0:
            energy = self.shrink * (energy0 + _cumtrapz(self.grow * source, self.step))
        else:
            energy = energy0 + _cumtrapz(source, self.step)
        if energy.min() <= 0:
            raise SimulationError(
                f"engine {self.engine.ident}: the crank stalled in cycle {k} (load torque above the drive)"
            )
        inertia = self.inertia
        omega = np.sqrt(2 * energy / inertia)
        rate = source - self.beta * energy
        accel = (rate - 0.5 * self.inertia_1 * omega**2) / inertia
        time = time0 + _cumtrapz(1.0 / omega, self.step)
        if not keep:
            forces = np.zeros((0, self.m + 1))
        elif self.engine.is_vee:
            on_rows = np.einsum("rnm,nm->rm", self.gas_rows, gas)
            forces = on_rows - self.k2_rows * omega**2 - self.k1_rows * accel
        else:
            forces = -(self.weights @ gas) - self.k2_rows * omega**2 - self.k1_rows * accel
        return energy, omega, accel, time, forces


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
    n = engine.cylinders
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
    turn = np.tile(np.linspace(0, 2 * math.pi, 64, endpoint=False), (n, 1))  # each cylinder's revolution
    inertia = engine.rigid_inertia + float(equivalent_inertia(engine, turn)[0].mean()) * n
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
