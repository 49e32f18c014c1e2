"""One crank with reciprocating parts: variable inertia and parametric instability.

A crank of rotating inertia ``I`` with a reciprocating mass ``M`` on crank
radius ``a``, coupled by a shaft of torsional stiffness ``mu`` to a heavy
flywheel turning uniformly, ``theta_1 = omega t`` (paper 002, Fig. 1).  With
the reciprocating mass in simple harmonic motion its kinetic energy is
``1/2 M a^2 sin^2(theta) theta'^2``, so the crank's inertia
``J(theta) = I + M a^2 / 2 - (M a^2 / 2) cos 2 theta`` varies twice per
revolution.  Lagrange's equation (002 eq. 4, rederived)::

    J(theta) theta'' + (M a^2 / 2) sin(2 theta) theta'^2 + mu (theta - theta_1) = T_ext

Non-dimensional form.  With ``tau = omega t``, ``theta = tau + gamma``,
``J_0 = I + M a^2 / 2``, ``epsilon = (M a^2 / 2) / J_0`` and
``1 / r^2 = mu / (omega^2 J_0)`` (``r`` is the speed over the natural
frequency without the variation of inertia), dashes meaning d/dtau:

full (exact) form::

    (1 - eps cos(2 tau + 2 gamma)) gamma'' + eps sin(2 tau + 2 gamma) (1 + gamma')^2
        + gamma / r^2 + (2 zeta / r) gamma' = q(tau)

linearised in gamma (002 eq. 6)::

    (1 - eps cos 2 tau) gamma'' + 2 eps sin 2 tau gamma' + (1/r^2 + 2 eps cos 2 tau) gamma
        + (2 zeta / r) gamma' = -eps sin 2 tau + q(tau)

``zeta`` is the damping ratio of a viscous damper across the shaft, and
``q = T_ext / (omega^2 J_0)`` an external torque.  The homogeneous linear
equation is the Hill equation ``(J gamma')' + (1/r^2 + 2 eps cos 2 tau) gamma = 0``
with ``J = 1 - eps cos 2 tau``: in the variables ``(gamma, p = J gamma')`` its
system matrix is traceless without damping, so the monodromy matrix over one
period ``pi`` has determinant 1 and the motion is unstable exactly when
``|trace| > 2``.  The instability ranges lie near ``r = 1/k`` (``k = 1, 2, ...``):
the principal one at ``r ~ 1`` where the multipliers pass through -1,
the next at ``r ~ 1/2`` through +1 (paper 002 Table 1).

The crank (:class:`VariableInertiaCrank`) and its excitation are here; the
analysis is in three modules:

- :mod:`monitor.torsion.floquet`: the monodromy matrix over one period and its
  Floquet multipliers (:func:`~monitor.torsion.floquet.monodromy`);
- :mod:`monitor.torsion.stability`: the instability ranges in ``r`` and the
  stability chart over ``(r, epsilon)``, with the step count a wanted accuracy
  of the boundaries needs;
- :mod:`monitor.torsion.time_response`: the time response and its harmonic
  content (paper 002 Fig. 2-5, Table 2).

References
----------
002: Pasricha and Hashim, Effect of the reciprocating mass of slider-crank
     mechanism on torsional vibrations of diesel engine systems, eq. 1-6,
     Table 1, Table 2.
Blanes, Casas, Oteo, Ros, The Magnus expansion and some of its
     applications, Physics Reports 470 (2009), doi:10.1016/j.physrep.2008.11.001.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from monitor.errors import ModelError
from monitor.model.engine import Engine
from monitor.model.excitation import gas_torque_orders
from monitor.model.inertia import throw_inertia
from monitor.torsion.shaft_line import shaft_line_of
from monitor.types import FloatArray

__all__ = [
    "HarmonicExcitation",
    "VariableInertiaCrank",
    "check_ratios",
    "crank_of_engine",
    "gas_excitation",
]


@dataclass(frozen=True)
class HarmonicExcitation:
    """External torque ``q(tau) = sum_k amplitude_k cos(order_k tau + phase_k)``, non-dimensional.

    Attributes
    ----------
    orders : tuple of float
        Orders (multiples of the crank speed); integers or half integers [-].
    amplitudes : tuple of float
        ``T_k / (omega^2 J_0)`` [-].
    phases : tuple of float
        [rad].
    """

    orders: tuple[float, ...] = ()
    amplitudes: tuple[float, ...] = ()
    phases: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        if not len(self.orders) == len(self.amplitudes) == len(self.phases):
            raise ModelError(
                f"HarmonicExcitation: {len(self.orders)} orders, {len(self.amplitudes)} amplitudes and "
                f"{len(self.phases)} phases: expected equal lengths"
            )
        for k in self.orders:
            if not (k > 0 and abs(2 * k - round(2 * k)) < 1e-12):
                raise ModelError(f"excitation order {k!r}: expected a positive multiple of 0.5")

    def __call__(self, tau: npt.ArrayLike) -> FloatArray:
        """The torque at ``tau`` [-]."""
        t = np.asarray(tau, dtype=np.float64)
        out = np.zeros_like(t)
        for k, amp, phase in zip(self.orders, self.amplitudes, self.phases, strict=True):
            out += amp * np.cos(k * t + phase)
        return out

    @property
    def period_factor(self) -> int:
        """The common period of the excitation and the inertia variation, in units of pi."""
        factor = 1
        for k in self.orders:
            twice = round(2 * k)
            if twice % 4:  # k not an even integer
                factor = max(factor, 4 if twice % 2 else 2)
        return factor


@dataclass(frozen=True)
class VariableInertiaCrank:
    """Non-dimensional parameters of the variable-inertia crank.

    Attributes
    ----------
    epsilon : float
        Inertia ratio ``(M a^2 / 2) / (I + M a^2 / 2)``, ``0 <= epsilon < 1`` [-].
    r : float
        Crank speed over the natural frequency without inertia variation, > 0 [-].
    zeta : float
        Damping ratio of the shaft damper [-].
    excitation : HarmonicExcitation
        External torque, non-dimensional.
    """

    epsilon: float
    r: float
    zeta: float = 0.0
    excitation: HarmonicExcitation = field(default_factory=HarmonicExcitation)

    def __post_init__(self) -> None:
        check_ratios(self.epsilon, self.r)
        if not (math.isfinite(self.zeta) and self.zeta >= 0):
            raise ModelError(f"zeta = {self.zeta!r}: expected a non-negative damping ratio")

    @classmethod
    def from_physical(
        cls,
        *,
        rotating_inertia: float,
        reciprocating_mass: float,
        crank_radius: float,
        stiffness: float,
        crank_speed: float,
        damping: float = 0.0,
    ) -> VariableInertiaCrank:
        """Parameters from physical values (paper 002 eq. 5).

        Parameters
        ----------
        rotating_inertia : float
            I, the crank's rotating parts [kg m^2].
        reciprocating_mass : float
            M [kg].
        crank_radius : float
            a [m].
        stiffness : float
            mu, torsional stiffness between crank and flywheel [N m/rad].
        crank_speed : float
            omega [rad/s].
        damping : float, optional
            Viscous damping across the shaft [N m s/rad].

        Returns
        -------
        VariableInertiaCrank
        """
        for name, value in (
            ("rotating_inertia", rotating_inertia),
            ("reciprocating_mass", reciprocating_mass),
            ("crank_radius", crank_radius),
            ("stiffness", stiffness),
            ("crank_speed", crank_speed),
        ):
            if not (math.isfinite(value) and value > 0):
                raise ModelError(f"{name} = {value!r}: expected a positive, finite value")
        half = 0.5 * reciprocating_mass * crank_radius**2
        j0 = rotating_inertia + half
        natural = math.sqrt(stiffness / j0)
        return cls(epsilon=half / j0, r=crank_speed / natural, zeta=damping / (2 * j0 * natural))


def _cylinder_share(engine: Engine) -> float:
    """One cylinder's share of its throw's rotating inertia: the whole throw in line, half on a V [kg m^2]."""
    return throw_inertia(engine) * engine.throws / engine.cylinders


def crank_of_engine(engine: Engine, crank_speed: float, *, mode: int = 1) -> VariableInertiaCrank:
    """The equivalent single crank of an engine at a speed (one throw's inertia ratio, one mode's frequency).

    Parameters
    ----------
    engine : Engine
        With ``[shaft_line]``.
    crank_speed : float
        omega [rad/s].
    mode : int, optional
        Which natural mode of the shaft line (1 = lowest) sets ``omega_n``.

    Returns
    -------
    VariableInertiaCrank
        ``epsilon = (m_rec R^2 / 2) / (I_throw + m_rot R^2 + m_rec R^2 / 2)`` (on a V, ``I_throw`` is
        half the throw's: one cylinder's share) and
        ``r = omega / omega_mode`` with the mean-inertia shaft line.
    """
    half = 0.5 * engine.reciprocating_mass * engine.crank_radius**2
    rotating = _cylinder_share(engine)
    frequencies = shaft_line_of(engine).modes().frequencies
    if not 1 <= mode <= frequencies.size:
        raise ModelError(f"mode = {mode!r}: the shaft line has modes 1..{frequencies.size}")
    return VariableInertiaCrank(half / (rotating + half), crank_speed / float(frequencies[mode - 1]))


def gas_excitation(
    engine: Engine, crank_speed: float, *, load: float = 1.0, max_order: float = 12
) -> HarmonicExcitation:
    """A cylinder's gas-torque orders as the non-dimensional external torque of its equivalent crank.

    Only the gas torque: the reciprocating parts' inertia torque is what the
    variable-inertia equation itself describes.  The phases are in the
    crank's own angle (0 at its own TDC), the angle its inertia varies with;
    every cylinder's crank is alike in that angle.

    Parameters
    ----------
    engine : Engine
        With ``[shaft_line]`` (for the throw inertia).
    crank_speed : float
        omega [rad/s].
    load : float, optional
        Fraction of rated IMEP [-].
    max_order : float, optional
        Highest order kept [-].

    Returns
    -------
    HarmonicExcitation
        ``amplitude_k = |T_k| / (omega^2 J_0)``, ``J_0 = I_throw + m_rot R^2 + m_rec R^2 / 2``.
    """
    r2 = engine.crank_radius**2
    j0 = _cylinder_share(engine) + 0.5 * engine.reciprocating_mass * r2
    orders, torque = gas_torque_orders(engine, crank_speed, load=load, max_order=max_order)
    scale = crank_speed**2 * j0
    return HarmonicExcitation(
        tuple(float(k) for k in orders),
        tuple(float(v) for v in np.abs(torque) / scale),
        tuple(float(v) for v in np.angle(torque)),
    )


def check_ratios(epsilon: float, r: float) -> None:
    """Refuse an inertia ratio outside ``[0, 1)`` or a speed ratio that is not positive.

    Parameters
    ----------
    epsilon : float
        Inertia ratio [-].
    r : float
        Speed ratio [-].

    Raises
    ------
    ModelError
        For either out of range.
    """
    if not (math.isfinite(epsilon) and 0.0 <= epsilon < 1.0):
        raise ModelError(
            f"epsilon = {epsilon!r}: expected 0 <= epsilon < 1 (the reciprocating share of the "
            "mean inertia; at 1 the crank's inertia vanishes twice per revolution)"
        )
    if not (math.isfinite(r) and r > 0.0):
        raise ModelError(f"r = {r!r}: expected a positive speed ratio (crank speed / natural frequency)")
