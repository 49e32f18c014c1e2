"""Cylinder pressure and gas force.

Two sources of the pressure trace ``p(theta)``, ``theta`` the crank angle from
the cylinder's own firing TDC:

- a measured indicator diagram on any angular grid (read from the engine
  description or its CSV file by :func:`read_pressure_trace`), resampled by monotone
  (PCHIP) interpolation of its periodic extension (:func:`resample_trace`);
- a parametric cycle where none is measured (:class:`ParametricCycle`):
  polytropic compression from inlet closing (two-stroke: exhaust valve or
  port closing), heat release by a Wiebe law with polytropic expansion until
  exhaust opening, a cosine blowdown to the charge-air pressure, and the
  gas exchange at charge-air pressure (pumping work neglected).

Closed-cycle equation.  With a constant polytropic exponent ``n`` the first
law gives ``dp/dtheta = -n p V'/V + (n - 1) Q'/V`` whose exact solution is

    p V^n = p_0 V_0^n + (n - 1) Q_tot  int V^(n-1) dx_b ,

``x_b(theta) = (1 - exp(-a u^(m+1))) / (1 - exp(-a))`` the Wiebe burnt
fraction, ``u = (theta - theta_soc) / duration``.  The pressure is therefore
linear in the charge pressure ``p_ic`` and the heat ``Q_tot``:
``p = p_ic A(theta) + Q_tot B(theta)``, and the basis curves A, B are computed
once per engine (:meth:`ParametricCycle.basis`).  Load enters through
``imep = load * rated_imep``, which fixes ``Q_tot`` by one linear solve, and
through the charge pressure, by the law the engine description states
(``charge_pressure_law``, :meth:`ParametricCycle.charge_pressure`):

- ``"turbocharged"`` (the default): ``p_ic = p_amb + load (p_ic,rated -
  p_amb)``.  The turbine's power, and with it the compressor's boost, rises
  with the exhaust energy, which at constant speed grows about linearly with
  the fuel per cycle, hence with the load (Watson and Janota, Turbocharging
  the Internal Combustion Engine, Macmillan 1982); kept linear, without an
  exponent, because no source at hand gives one for the bundled engines;
- ``"held"``: ``p_ic = p_ic,rated`` at every load (boost held by a waste gate
  or an external blower, or a simulator that scales only the combustion);
- ``"naturally-aspirated"``: ``p_ic = p_amb`` at every load (unthrottled; the
  description's intake pressure must then be about ambient).

Speed does not enter the pressure: the cycle is a function of crank angle and
load only (no heat loss per unit time, no speed-dependent boost), so the gas
torque depends on speed only through the load the operating point gives
(e.g. the propeller law ``load = (speed / rated speed)^2``).

Gas force on the piston: ``F_g = (p - p_amb) A_piston``, positive pushing the
piston towards the crank (paper 004: ``P = p A``).

References
----------
004: Kluczyk, eq. 5-15 and Fig. 4 (gas force from the indicator diagram).
Heywood, Internal Combustion Engine Fundamentals, 2nd ed., McGraw-Hill 2018,
sec. 9.2 (Wiebe function), 4.2 (polytropic processes).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np
import numpy.typing as npt

from monitor.errors import EngineDescriptionError, ModelError
from monitor.model.engine import Combustion, Engine
from monitor.model.kinematics import piston_displacement
from monitor.types import FloatArray

__all__ = [
    "ParametricCycle",
    "cylinder_volume",
    "gas_force",
    "indicated_mean_effective_pressure",
    "read_pressure_trace",
    "resample_trace",
]


#: Gauss-Legendre nodes for the heat-release integral (accurate to ~1e-12 for m >= 1).
_GAUSS_NODES, _GAUSS_WEIGHTS = np.polynomial.legendre.leggauss(48)


def cylinder_volume(
    crank_angle: npt.ArrayLike,
    *,
    bore: float,
    crank_radius: float,
    rod_ratio: float,
    compression_ratio: float,
) -> FloatArray:
    """Cylinder volume above the piston.

    Parameters
    ----------
    crank_angle : array_like
        Crank angle from TDC [rad].
    bore : float
        Cylinder bore [m].
    crank_radius : float
        R [m].
    rod_ratio : float
        lambda [-].
    compression_ratio : float
        Geometric compression ratio (V_c + V_d) / V_c, > 1 [-].

    Returns
    -------
    ndarray
        V = V_c + A x(theta) [m^3], with the exact piston displacement x.
    """
    if not compression_ratio > 1:
        raise ModelError(f"compression_ratio = {compression_ratio!r}: expected > 1")
    area = math.pi * bore**2 / 4
    clearance = area * 2 * crank_radius / (compression_ratio - 1)
    return clearance + area * piston_displacement(crank_angle, crank_radius, rod_ratio)


def gas_force(pressure: npt.ArrayLike, piston_area: float, ambient_pressure: float) -> FloatArray:
    """Gas force on the piston, positive towards the crank.

    Parameters
    ----------
    pressure : array_like
        Absolute cylinder pressure [Pa].
    piston_area : float
        Piston crown area [m^2].
    ambient_pressure : float
        Pressure under the piston (crankcase) [Pa].

    Returns
    -------
    ndarray
        F_g = (p - p_amb) A [N].
    """
    return (np.asarray(pressure, dtype=np.float64) - ambient_pressure) * piston_area


def indicated_mean_effective_pressure(pressure: npt.ArrayLike, volume: npt.ArrayLike) -> float:
    """IMEP from one cycle sampled on a uniform periodic crank-angle grid.

    Parameters
    ----------
    pressure : array_like
        Absolute pressure over one cycle, endpoint excluded [Pa].
    volume : array_like
        Cylinder volume at the same angles [m^3].

    Returns
    -------
    float
        ``oint p dV / V_d`` [Pa], by the periodic trapezoidal rule on ``dV``
        taken as the central difference of the periodic volume.
    """
    p = np.asarray(pressure, dtype=np.float64)
    v = np.asarray(volume, dtype=np.float64)
    dv = 0.5 * (np.roll(v, -1) - np.roll(v, 1))
    return float(np.sum(p * dv) / (v.max() - v.min()))


def read_pressure_trace(engine: Engine) -> tuple[FloatArray, FloatArray]:
    """The measured pressure trace of an engine, in SI.

    Parameters
    ----------
    engine : Engine
        An engine whose description has a ``[pressure_trace]``.

    Returns
    -------
    crank_angle, pressure : ndarray
        Crank angle from firing TDC [rad] and absolute cylinder pressure [Pa].

    Raises
    ------
    EngineDescriptionError
        If the trace is absent, unreadable, or its arrays are inconsistent.
    """
    trace = engine.pressure_trace
    if trace is None:
        raise EngineDescriptionError(f"engine {engine.id!r} has no [pressure_trace]")
    if trace.file is not None:
        path = Path(trace.file)
        if not path.is_absolute() and engine.source_dir is not None:
            path = engine.source_dir / path
        try:
            with path.open(newline="", encoding="utf-8") as handle:
                rows = list(csv.DictReader(handle))
        except OSError as error:
            raise EngineDescriptionError(f"pressure_trace.file = {trace.file!r}: {error}") from None
        try:
            angle_deg = [float(r["crank_angle_deg"]) for r in rows]
            p_bar = [float(r["pressure_bar"]) for r in rows]
        except (KeyError, TypeError, ValueError) as error:
            raise EngineDescriptionError(
                f"pressure_trace.file = {trace.file!r}: expected numeric columns crank_angle_deg "
                f"and pressure_bar ({error})"
            ) from None
    else:
        angle_deg, p_bar = trace.crank_angle_deg or [], trace.pressure_bar or []
    angle = np.radians(np.asarray(angle_deg, dtype=np.float64))
    pressure = np.asarray(p_bar, dtype=np.float64) * 1e5
    if angle.shape != pressure.shape or angle.size < 8:
        raise EngineDescriptionError(
            f"pressure_trace: {angle.size} angles and {pressure.size} pressures: expected equal "
            "lengths of at least 8 points"
        )
    if not (np.all(np.isfinite(angle)) and np.all(np.isfinite(pressure))):
        bad = int(np.count_nonzero(~np.isfinite(angle)) + np.count_nonzero(~np.isfinite(pressure)))
        raise EngineDescriptionError(
            f"pressure_trace: {bad} value(s) are NaN or Inf: expected finite numbers"
        )
    if not trace.absolute:
        pressure = pressure + (engine.combustion.ambient_pressure_bar if engine.combustion else 1.013) * 1e5
    if np.any(pressure <= 0):
        first = int(np.flatnonzero(pressure <= 0)[0])
        raise EngineDescriptionError(
            f"pressure_trace: absolute pressure {pressure[first] / 1e5:.6g} bar at "
            f"{math.degrees(angle[first]):.6g} deg: expected positive pressures everywhere"
            + ("" if trace.absolute else " (the trace is gauge; ambient was added)")
        )
    return angle, pressure


def resample_trace(
    trace_angle: npt.ArrayLike,
    trace_pressure: npt.ArrayLike,
    crank_angle: npt.ArrayLike,
    *,
    cycle_revolutions: int,
    max_gap: float = math.radians(30.0),
) -> FloatArray:
    """Resample a measured pressure trace to other crank angles.

    Parameters
    ----------
    trace_angle : array_like
        Crank angles of the measured points from firing TDC, any order and grid [rad].
    trace_pressure : array_like
        Pressures at those angles [Pa].
    crank_angle : array_like
        Where the pressure is wanted [rad].
    cycle_revolutions : int
        1 (two-stroke) or 2 (four-stroke): the period of the trace.
    max_gap : float, optional
        Largest angular gap allowed between measured points [rad].

    Returns
    -------
    ndarray
        Pressure at ``crank_angle`` [Pa], by PCHIP (monotone, no overshoot at
        the peak) on the periodic extension of the trace.  Points whose angles
        coincide modulo the cycle (a trace given from 0 to 720 deg inclusive)
        are averaged.

    Raises
    ------
    ModelError
        If the trace does not cover the cycle (a gap above ``max_gap``).
    """
    period = 2 * np.pi * cycle_revolutions
    angle = np.mod(np.asarray(trace_angle, dtype=np.float64), period)
    angle[period - angle <= 1e-12] = 0.0  # an angle a hair below the period is the start
    pressure = np.asarray(trace_pressure, dtype=np.float64)
    order = np.argsort(angle, kind="stable")
    angle, pressure = angle[order], pressure[order]
    # points that coincide once wrapped (e.g. 0 and 720 deg) are averaged
    group = np.concatenate([[0], np.cumsum(np.diff(angle) > 1e-12)])
    counts = np.bincount(group)
    angle = np.bincount(group, weights=angle) / counts
    pressure = np.bincount(group, weights=pressure) / counts
    gaps = np.diff(np.concatenate([angle, [angle[0] + period]]))
    if gaps.max() > max_gap:
        where = math.degrees(angle[int(np.argmax(gaps))])
        raise ModelError(
            f"pressure trace leaves {math.degrees(gaps.max()):.1f} deg uncovered after "
            f"{where:.1f} deg: expected points at most {math.degrees(max_gap):.0f} deg apart over the "
            f"whole {360 * cycle_revolutions} deg cycle"
        )
    extended_angle = np.concatenate([angle - period, angle, angle + period])
    extended_pressure = np.tile(pressure, 3)
    from scipy.interpolate import PchipInterpolator  # here: half a second to import, for measured traces only

    interpolant = PchipInterpolator(extended_angle, extended_pressure)
    return np.asarray(interpolant(np.mod(np.asarray(crank_angle, dtype=np.float64), period)))


@dataclass(frozen=True)
class ParametricCycle:
    """Parametric cylinder-pressure cycle of one engine (see the module docstring).

    Attributes
    ----------
    combustion : Combustion
        Cycle parameters from the engine description.
    bore, crank_radius, rod_ratio : float
        Geometry [m], [m], [-].
    cycle_revolutions : int
        1 two-stroke, 2 four-stroke.
    displacement : callable or None
        The piston's displacement from its TDC [m] at crank angles from its firing TDC [rad], where it
        is not the slider-crank's of ``crank_radius`` and ``rod_ratio`` (an articulated rod's slave,
        :mod:`monitor.model.articulated`); its clearance volume is the slider-crank's (the same head
        and piston), so its compression ratio follows from its own stroke.
    """

    combustion: Combustion
    bore: float
    crank_radius: float
    rod_ratio: float
    cycle_revolutions: int
    displacement: Callable[[FloatArray], FloatArray] | None = None

    @classmethod
    def of(cls, engine: Engine) -> ParametricCycle:
        """The cycle of an engine that has a ``[combustion]`` description."""
        if engine.combustion is None:
            raise ModelError(f"engine {engine.id!r} has no [combustion] parameters for a parametric cycle")
        return cls(
            engine.combustion,
            engine.geometry.bore_m,
            engine.crank_radius,
            engine.rod_ratio,
            engine.cycle_revolutions,
        )

    def volume(self, crank_angle: npt.ArrayLike) -> FloatArray:
        """Cylinder volume [m^3] at crank angles from firing TDC [rad]."""
        if self.displacement is not None:
            area = math.pi * self.bore**2 / 4
            clearance = area * 2 * self.crank_radius / (self.combustion.compression_ratio - 1)
            return clearance + area * self.displacement(np.asarray(crank_angle, dtype=np.float64))
        return cylinder_volume(
            crank_angle,
            bore=self.bore,
            crank_radius=self.crank_radius,
            rod_ratio=self.rod_ratio,
            compression_ratio=self.combustion.compression_ratio,
        )

    def _burn_rate(self, theta: FloatArray) -> FloatArray:
        """Wiebe d x_b / d theta [1/rad], normalised to a total of 1."""
        c = self.combustion
        duration = math.radians(c.combustion_duration_deg)
        u = (theta - math.radians(c.combustion_start_deg)) / duration
        inside = (u >= 0.0) & (u <= 1.0)
        u = np.clip(u, 0.0, 1.0)
        shape = c.wiebe_m + 1
        rate = c.wiebe_a * shape * u**c.wiebe_m * np.exp(-c.wiebe_a * u**shape) / duration
        return np.where(inside, rate / (1 - math.exp(-c.wiebe_a)), 0.0)

    def basis(self, crank_angle: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Basis curves A [-] and B [Pa/J] with ``p = p_ic A + Q_tot B``.

        Parameters
        ----------
        crank_angle : array_like
            Crank angle from this cylinder's firing TDC [rad]; any value, wrapped
            into the cycle.

        Returns
        -------
        A, B : ndarray
            Pressure per unit charge pressure [-] and per joule of heat released [Pa/J].
        """
        c = self.combustion
        period = 2 * np.pi * self.cycle_revolutions
        ic = math.radians(c.inlet_closing_deg)
        soc = math.radians(c.combustion_start_deg)
        eoc = soc + math.radians(c.combustion_duration_deg)
        eo = math.radians(c.exhaust_opening_deg)
        blowdown = math.radians(c.blowdown_deg)
        if eo + blowdown > ic + period:
            end = c.exhaust_opening_deg + c.blowdown_deg
            raise ModelError(
                f"exhaust_opening_deg + blowdown_deg = {end:g} deg reaches past the next inlet closing "
                f"at {c.inlet_closing_deg + 360 * self.cycle_revolutions:g} deg"
            )
        theta = np.mod(np.asarray(crank_angle, dtype=np.float64) - ic, period) + ic
        n_c, n_e = c.polytropic_compression, c.polytropic_expansion
        v = self.volume(theta)
        v_ic = float(self.volume(ic))
        v_soc = float(self.volume(soc))
        # heat-release integral I(theta) = int_soc^min(theta, eoc) V^(n_e - 1) dx_b
        upper = np.clip(theta, soc, eoc)
        half = 0.5 * (upper - soc)
        nodes = soc + half[..., None] * (_GAUSS_NODES + 1.0)
        integrand = self.volume(nodes) ** (n_e - 1) * self._burn_rate(nodes)
        heat_integral = half * (integrand @ _GAUSS_WEIGHTS)
        a_closed = np.where(
            theta < soc,
            (v_ic / v) ** n_c,
            (v_ic / v_soc) ** n_c * (v_soc / v) ** n_e,
        )
        b_closed = np.where(theta < soc, 0.0, (n_e - 1) * heat_integral / v**n_e)
        s = np.clip((theta - eo) / blowdown, 0.0, 1.0)
        weight = np.where(theta <= eo, 1.0, 0.5 * (1 + np.cos(np.pi * s)))
        a = 1.0 + weight * (a_closed - 1.0)
        b = weight * b_closed
        return a, b

    def charge_pressure(self, load: float) -> float:
        """Charge (scavenge) air pressure at inlet closing for a load.

        Parameters
        ----------
        load : float
            Fraction of rated IMEP, 0 to 1.1 [-].

        Returns
        -------
        float
            [Pa], by the description's ``charge_pressure_law``: ambient plus
            ``load`` times the rated boost (turbocharged), the rated charge
            pressure (held), or ambient (naturally aspirated).
        """
        c = self.combustion
        _check_load(load)
        if c.charge_pressure_law == "held":
            return c.intake_pressure_bar * 1e5
        if c.charge_pressure_law == "naturally-aspirated":
            return c.ambient_pressure_bar * 1e5
        return (c.ambient_pressure_bar + load * (c.intake_pressure_bar - c.ambient_pressure_bar)) * 1e5

    @cached_property
    def _imep_basis(self) -> tuple[float, float]:
        grid = np.linspace(
            0, 2 * np.pi * self.cycle_revolutions, 2880 * self.cycle_revolutions, endpoint=False
        )
        a, b = self.basis(grid)
        v = self.volume(grid)
        return indicated_mean_effective_pressure(a, v), indicated_mean_effective_pressure(b, v)

    def heat_release(self, load: float) -> float:
        """Heat released per cycle so that IMEP = load x rated IMEP [J] (never negative)."""
        imep_a, imep_b = self._imep_basis
        target = load * self.combustion.rated_imep_bar * 1e5
        return max(0.0, (target - self.charge_pressure(load) * imep_a) / imep_b)

    def pressure(self, crank_angle: npt.ArrayLike, load: float) -> FloatArray:
        """Absolute cylinder pressure [Pa] at crank angles from firing TDC [rad] and a load [-]."""
        a, b = self.basis(crank_angle)
        return self.charge_pressure(load) * a + self.heat_release(load) * b


def _check_load(load: float) -> None:
    if not (math.isfinite(load) and 0.0 <= load <= 1.1):
        raise ModelError(f"load = {load!r}: expected 0 <= load <= 1.1 (fraction of rated IMEP)")
