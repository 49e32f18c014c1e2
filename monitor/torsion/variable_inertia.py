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

Numerics.  The monodromy matrix is integrated by the fourth-order Magnus
method on Gauss-Legendre nodes; each step's exponential of a 2 x 2 matrix is
evaluated in closed form, so every step preserves the determinant exactly
(to round-off) and whole grids of ``(r, eps)`` are integrated at once.
``monodromy`` refines the step count until the trace converges to a requested
tolerance.  Charts and range searches instead take the step count from a
wanted accuracy of the stability boundaries in ``r``, by the measured relation
``BOUNDARY_ERROR`` (error ``C / steps^4``): a trace tolerance would be spent
where the trace grows exponentially, inside the unstable regions.  The range
search seeds a local search in every range, however narrow (see
``instability_ranges``).
Long time responses of the linear equation are propagated period by period
with the exact affine map of one period (no accumulation of integrator
error); direct integration with any SciPy integrator is available for both
forms.

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
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt
from scipy.integrate import solve_ivp

from monitor.errors import ModelError
from monitor.model.engine import Engine
from monitor.model.excitation import gas_torque_orders
from monitor.model.inertia import throw_inertia
from monitor.torsion.shaft_line import shaft_line_of
from monitor.types import FloatArray

__all__ = [
    "BOUNDARY_ERROR",
    "BOUNDARY_WINDOW",
    "UNSTABLE_MARGIN",
    "HarmonicExcitation",
    "Integrator",
    "Monodromy",
    "StabilityChart",
    "TimeResponse",
    "VariableInertiaCrank",
    "boundary_error",
    "boundary_steps",
    "crank_of_engine",
    "gas_excitation",
    "harmonic_content",
    "instability_ranges",
    "monodromy",
    "simulate",
    "stability_chart",
]

Form = Literal["linear", "full"]
Integrator = Literal["periodic", "RK45", "DOP853", "Radau", "BDF", "LSODA"]

#: Margin below which a point is reported on a stability boundary (see ``Monodromy.band``).
BOUNDARY_BAND = 1e-9
#: Response magnitude at which periodic propagation stops as unstable [rad].
_RUNAWAY = 1e100

#: Chart cells integrated together: big enough that numpy's per-call overhead is small, small
#: enough to stay in cache and to report progress every few hundred milliseconds.
_CHART_BLOCK = 2000

_SQRT3 = math.sqrt(3.0)
_GAUSS = (0.5 - _SQRT3 / 6.0, 0.5 + _SQRT3 / 6.0)


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
        _check(self.epsilon, self.r)
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
        ``epsilon = (m_rec R^2 / 2) / (I_throw + m_rot R^2 + m_rec R^2 / 2)`` and
        ``r = omega / omega_mode`` with the mean-inertia shaft line.
    """
    half = 0.5 * engine.reciprocating_mass * engine.crank_radius**2
    rotating = throw_inertia(engine)
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
    j0 = throw_inertia(engine) + 0.5 * engine.reciprocating_mass * r2
    orders, torque = gas_torque_orders(engine, crank_speed, load=load, max_order=max_order)
    scale = crank_speed**2 * j0
    return HarmonicExcitation(
        tuple(float(k) for k in orders),
        tuple(float(v) for v in np.abs(torque) / scale),
        tuple(float(v) for v in np.angle(torque)),
    )


def _check(epsilon: float, r: float) -> None:
    if not (math.isfinite(epsilon) and 0.0 <= epsilon < 1.0):
        raise ModelError(
            f"epsilon = {epsilon!r}: expected 0 <= epsilon < 1 (the reciprocating share of the "
            "mean inertia; at 1 the crank's inertia vanishes twice per revolution)"
        )
    if not (math.isfinite(r) and r > 0.0):
        raise ModelError(f"r = {r!r}: expected a positive speed ratio (crank speed / natural frequency)")


# ----------------------------------------------------------------------------------------- Floquet
@dataclass(frozen=True)
class Monodromy:
    """Monodromy matrix of the linearised homogeneous equation over one period ``pi``.

    Attributes
    ----------
    matrix : ndarray, shape (..., 2, 2)
        Maps ``(gamma, J gamma')`` at ``tau`` to ``tau + pi``.
    trace : ndarray, shape (...)
        Its trace; undamped motion is unstable where ``|trace| > 2``.
    multipliers : ndarray, shape (..., 2)
        Floquet multipliers (eigenvalues), complex.
    steps : int
        Magnus steps per period used.
    trace_error : ndarray, shape (...)
        Estimated error of the trace (difference from half the steps).
    """

    matrix: FloatArray
    trace: FloatArray
    multipliers: npt.NDArray[np.complex128]
    steps: int
    trace_error: FloatArray

    @property
    def determinant(self) -> FloatArray:
        """det of the monodromy matrix: 1 without damping, ``exp(-int damping)`` with it."""
        return np.asarray(np.linalg.det(self.matrix))

    @property
    def stability_margin(self) -> FloatArray:
        """Jury margin ``1 + det - |trace|``: positive stable, negative unstable (with ``det < 1``)."""
        return 1.0 + self.determinant - np.abs(self.trace)

    @property
    def largest_multiplier(self) -> FloatArray:
        """Largest multiplier modulus, from trace and determinant (robust at double multipliers)."""
        return _largest_multiplier(self.trace, self.determinant)

    @property
    def growth_rate(self) -> FloatArray:
        """Largest Floquet exponent: ``ln max|multiplier| / pi`` per unit tau [-]."""
        return np.log(self.largest_multiplier) / math.pi

    @property
    def band(self) -> FloatArray:
        """Half-width of the margin reported as a boundary [-].

        Ten times the trace's estimated error plus ``BOUNDARY_BAND``: a point
        that close to a boundary either does not grow or grows slower than one
        e-folding in about 10^4 revolutions, and no speed known to ten digits
        can place it on either side.
        """
        return 10.0 * self.trace_error + BOUNDARY_BAND

    @property
    def unstable(self) -> npt.NDArray[np.bool_]:
        """True where the motion grows: the margin is negative beyond its error band."""
        return np.asarray(self.stability_margin < -self.band)

    @property
    def on_boundary(self) -> npt.NDArray[np.bool_]:
        """True where the margin is within its error band of zero (a stability boundary)."""
        return np.asarray(np.abs(self.stability_margin) <= self.band)


def _largest_multiplier(trace: FloatArray, det: FloatArray) -> FloatArray:
    """Largest modulus of the eigenvalues of 2 x 2 matrices with these traces and determinants."""
    disc = trace * trace - 4.0 * det
    real = 0.5 * (np.abs(trace) + np.sqrt(np.maximum(disc, 0.0)))
    return np.asarray(np.where(disc >= 0.0, real, np.sqrt(np.maximum(det, 0.0))))


def _magnus_monodromy(epsilon: FloatArray, r: FloatArray, zeta: FloatArray, steps: int) -> FloatArray:
    """Monodromy over [0, pi] for arrays of parameters (broadcast), 4th-order Magnus."""
    eps, inv_r2, damp = np.broadcast_arrays(epsilon, 1.0 / (r * r), 2.0 * zeta / r)
    shape = eps.shape
    h = math.pi / steps
    phi = np.zeros((*shape, 2, 2))
    phi[..., 0, 0] = 1.0
    phi[..., 1, 1] = 1.0

    def system(tau: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        c = math.cos(2.0 * tau)
        j = 1.0 - eps * c
        # d/dtau [gamma, p] = [[0, 1/J], [-(1/r^2 + 2 eps cos 2tau), -damp/J]] [gamma, p]
        return 1.0 / j, -(inv_r2 + 2.0 * eps * c), -damp / j

    for n in range(steps):
        t0 = n * h
        b1, c1, d1 = system(t0 + _GAUSS[0] * h)
        b2, c2, d2 = system(t0 + _GAUSS[1] * h)
        # Omega = h/2 (A1 + A2) + sqrt(3) h^2 / 12 [A2, A1]; A = [[0, b], [c, d]]
        k = _SQRT3 * h * h / 12.0
        # [A2, A1] = A2 A1 - A1 A2 for A = [[0,b],[c,d]]
        com00 = b2 * c1 - b1 * c2
        com01 = b2 * d1 - b1 * d2
        com10 = d2 * c1 - d1 * c2
        com11 = c2 * b1 - c1 * b2
        o00 = k * com00
        o01 = 0.5 * h * (b1 + b2) + k * com01
        o10 = 0.5 * h * (c1 + c2) + k * com10
        o11 = 0.5 * h * (d1 + d2) + k * com11
        half_trace = 0.5 * (o00 + o11)
        m00 = o00 - half_trace
        m11 = o11 - half_trace
        s2 = m00 * m00 + o01 * o10  # M^2 = s2 I for the traceless part M
        s = np.sqrt(np.abs(s2))
        small = s < 1e-8
        safe = np.where(small, 1.0, s)
        cosh_like = np.where(s2 >= 0, np.cosh(s), np.cos(s))
        sinh_like = np.where(small, 1.0 + s2 / 6.0, np.where(s2 >= 0, np.sinh(s), np.sin(s)) / safe)
        scale = np.exp(half_trace)
        e00 = scale * (cosh_like + sinh_like * m00)
        e01 = scale * sinh_like * o01
        e10 = scale * sinh_like * o10
        e11 = scale * (cosh_like + sinh_like * m11)
        p00, p01, p10, p11 = (
            phi[..., 0, 0].copy(),
            phi[..., 0, 1].copy(),
            phi[..., 1, 0].copy(),
            phi[..., 1, 1].copy(),
        )
        phi[..., 0, 0] = e00 * p00 + e01 * p10
        phi[..., 0, 1] = e00 * p01 + e01 * p11
        phi[..., 1, 0] = e10 * p00 + e11 * p10
        phi[..., 1, 1] = e10 * p01 + e11 * p11
    return phi


def _steps_for(r: FloatArray, epsilon: FloatArray, base: int) -> int:
    """A starting step count that resolves the fastest oscillation and the inertia dip."""
    fastest = float(np.max(1.0 / (np.asarray(r) * np.sqrt(1.0 - np.asarray(epsilon)))))
    return max(base, math.ceil(4.0 * fastest))


def monodromy(
    epsilon: npt.ArrayLike,
    r: npt.ArrayLike,
    *,
    zeta: npt.ArrayLike = 0.0,
    tolerance: float = 1e-10,
    steps: int | None = None,
    max_steps: int = 1 << 16,
) -> Monodromy:
    """Monodromy matrix of the linearised equation (002 eq. 6) over one period ``pi``.

    Parameters
    ----------
    epsilon : array_like
        Inertia ratio, ``0 <= epsilon < 1`` [-].
    r : array_like
        Speed ratio, > 0; broadcast against ``epsilon`` [-].
    zeta : array_like, optional
        Damping ratio [-].
    tolerance : float, optional
        Wanted absolute accuracy of the trace [-]; the step count doubles until met.
    steps : int, optional
        Fix the number of Magnus steps per period instead (no refinement).
    max_steps : int, optional
        Refuse to refine beyond this.

    Returns
    -------
    Monodromy

    Raises
    ------
    ModelError
        On parameters out of range, or a tolerance not reached within ``max_steps``.
    """
    eps = np.asarray(epsilon, dtype=np.float64)
    rr = np.asarray(r, dtype=np.float64)
    z = np.asarray(zeta, dtype=np.float64)
    for e_value, r_value in zip(
        np.broadcast_to(eps, np.broadcast(eps, rr).shape).ravel(),
        np.broadcast_to(rr, np.broadcast(eps, rr).shape).ravel(),
        strict=True,
    ):
        _check(float(e_value), float(r_value))
    if np.any(~np.isfinite(z)) or np.any(z < 0):
        raise ModelError("zeta: expected non-negative damping ratios")
    if steps is not None:
        phi = _magnus_monodromy(eps, rr, z, steps)
        coarse = _magnus_monodromy(eps, rr, z, max(1, steps // 2))
        return _result(phi, coarse, steps)
    n = _steps_for(rr, eps, 32)
    coarse = _magnus_monodromy(eps, rr, z, n)
    while True:
        phi = _magnus_monodromy(eps, rr, z, 2 * n)
        error = np.abs(np.trace(phi, axis1=-2, axis2=-1) - np.trace(coarse, axis1=-2, axis2=-1))
        if float(np.max(error, initial=0.0)) <= tolerance:
            return _result(phi, coarse, 2 * n)
        if 4 * n > max_steps:
            raise ModelError(
                f"monodromy: trace tolerance {tolerance:g} not reached with {2 * n} steps per period "
                f"(max_steps = {max_steps}); largest change {float(np.max(error)):.3g}"
            )
        coarse, n = phi, 2 * n


def _result(phi: FloatArray, coarse: FloatArray, steps: int) -> Monodromy:
    trace = np.trace(phi, axis1=-2, axis2=-1)
    error = np.abs(trace - np.trace(coarse, axis1=-2, axis2=-1)) / 15.0  # Richardson, order 4
    multipliers = np.linalg.eigvals(phi).astype(np.complex128)
    return Monodromy(phi, trace, multipliers, steps, error)


# ------------------------------------------------------------------ boundary accuracy and step count
#: The Magnus error against the step count, as boundary error in ``r``: rows ``(epsilon_max, C)``:
#: every boundary of every range in ``BOUNDARY_WINDOW`` at the measured inertia ratios up to
#: ``epsilon_max``, with every step count ``N`` from 16 to 128 (no fewer than
#: ``_resolution_steps``), lay within ``C / N^4`` of a 2048-step reference.  Measured, not derived:
#: the constants of the table "boundary error against step count" that ``python -m benchmarks.torsion``
#: writes into docs/accuracy-vs-time.md, rounded up; the fourth power is the Magnus method's order,
#: which that table confirms.  A run flags any row measured above the constant held here.
BOUNDARY_ERROR: tuple[tuple[float, float], ...] = (
    (0.1, 0.0987),
    (0.2, 0.217),
    (0.3, 0.31),
    (0.4, 0.655),
    (0.5, 1.33),
    (0.6, 4.08),
    (0.7, 29.3),
    (0.8, 29.3),
    (0.9, 184.0),
    (0.95, 2450.0),
)
#: The speed ratios over which ``BOUNDARY_ERROR`` was measured.
BOUNDARY_WINDOW = (0.1, 3.0)
#: Margin below which a point counts as unstable in the range search and the chart: a few hundred
#: times the round-off of ``1 + det - |trace|`` (about 1e-15 with traces near 2), and far above it
#: for a range 1e-5 wide (about -5e-11 at r = 1.5, deeper at lower r: the margin is close to
#: ``-(pi w / 2 r^2)^2`` at the middle of a narrow range of width ``w``).  A narrower range
#: (below about ``2e-7 r^2``) is indistinguishable from a boundary and not reported.
UNSTABLE_MARGIN = 1e-13
#: Scan points per unit of ``1/r`` (ranges lie near ``1/r = k`` at small epsilon), stretched by
#: ``1 / sqrt(1 - epsilon)`` as the inertia dip quickens the motion.
_SCAN_PER_UNIT = 32
_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


def _resolution_steps(r_min: float, epsilon_max: float) -> int:
    """Least step count: eight steps per cycle of the fastest free oscillation."""
    return max(8, math.ceil(4.0 / (r_min * math.sqrt(1.0 - epsilon_max))))


def boundary_error(steps: int, *, epsilon_max: float) -> float:
    """Largest error in ``r`` of a stability boundary computed with ``steps`` Magnus steps per period.

    Parameters
    ----------
    steps : int
        Magnus steps per period.
    epsilon_max : float
        Largest inertia ratio of the chart or range search [-].

    Returns
    -------
    float
        ``C / steps^4`` with ``C`` from the first row of ``BOUNDARY_ERROR`` at or above
        ``epsilon_max`` [-].

    Raises
    ------
    ModelError
        Beyond the measured inertia ratios.
    """
    for top, constant in BOUNDARY_ERROR:
        if epsilon_max <= top:
            return constant / float(steps) ** 4
    top = BOUNDARY_ERROR[-1][0] if BOUNDARY_ERROR else 0.0
    raise ModelError(
        f"epsilon = {epsilon_max!r}: the boundary accuracy against step count is measured up to "
        f"epsilon {top:g} only; give the Magnus steps per period explicitly"
    )


def boundary_steps(tolerance: float, *, r_min: float, epsilon_max: float) -> int:
    """Magnus steps per period that put the stability boundaries within ``tolerance`` of the truth.

    The step count makes ``boundary_error`` at most half of ``tolerance`` (the other half is left
    for the bisection of the range search, and as margin for inertia ratios between the measured
    ones), and is never below eight steps per cycle of the fastest free oscillation.  Below
    ``r = 0.1`` (not measured) the count is raised in proportion to ``0.1 / r_min``, keeping the
    steps per oscillation of the measured speed ratios.

    Parameters
    ----------
    tolerance : float
        Wanted accuracy of every boundary in ``r``, positive and finite [-].
    r_min : float
        Smallest speed ratio of the chart or range search [-].
    epsilon_max : float
        Largest inertia ratio [-].

    Returns
    -------
    int

    Raises
    ------
    ModelError
        On a tolerance that is not positive and finite, or ``epsilon_max`` beyond the measured ones.
    """
    if not (math.isfinite(tolerance) and tolerance > 0):
        raise ModelError(f"tolerance = {tolerance!r}: expected a positive, finite boundary accuracy in r")
    _check(epsilon_max, r_min)
    constant = boundary_error(1, epsilon_max=epsilon_max)
    steps = math.ceil((2.0 * constant / tolerance) ** 0.25)
    if r_min < BOUNDARY_WINDOW[0]:
        steps = math.ceil(steps * BOUNDARY_WINDOW[0] / r_min)
    return max(steps, _resolution_steps(r_min, epsilon_max))


def _margin(epsilon: npt.ArrayLike, r: npt.ArrayLike, zeta: float, steps: int) -> FloatArray:
    """Jury margin ``1 + det - |trace|`` with a fixed step count, without an error estimate."""
    phi = _magnus_monodromy(
        np.asarray(epsilon, dtype=np.float64), np.asarray(r, dtype=np.float64), np.asarray(zeta), steps
    )
    trace = phi[..., 0, 0] + phi[..., 1, 1]
    det = phi[..., 0, 0] * phi[..., 1, 1] - phi[..., 0, 1] * phi[..., 1, 0]
    return np.asarray(1.0 + det - np.abs(trace))


def _golden_minimum(
    function: Callable[[FloatArray], FloatArray], low: FloatArray, high: FloatArray, width: float
) -> tuple[FloatArray, FloatArray]:
    """Golden-section search for a minimum in every bracket at once: (where, value)."""
    a, b = low.copy(), high.copy()
    x1, x2 = b - _GOLDEN * (b - a), a + _GOLDEN * (b - a)
    f1, f2 = function(x1), function(x2)
    while a.size and float(np.max(b - a)) > width:
        left = f1 < f2  # the minimum is in [a, x2]
        b = np.where(left, x2, b)
        a = np.where(left, a, x1)
        new = np.where(left, b - _GOLDEN * (b - a), a + _GOLDEN * (b - a))
        f_new = function(new)
        x1, x2, f1, f2 = (
            np.where(left, new, x2),
            np.where(left, x1, new),
            np.where(left, f_new, f2),
            np.where(left, f1, f_new),
        )
    first = f1 <= f2
    return np.where(first, x1, x2), np.where(first, f1, f2)


def instability_ranges(
    epsilon: float,
    r_min: float,
    r_max: float,
    *,
    zeta: float = 0.0,
    tolerance: float = 1e-6,
    steps: int | None = None,
) -> list[tuple[float, float]]:
    """Ranges of ``r`` in which the linearised motion is unstable, every boundary within ``tolerance``.

    Parameters
    ----------
    epsilon : float
        Inertia ratio [-].
    r_min, r_max : float
        Speed-ratio interval searched, ``0 < r_min < r_max`` [-].
    zeta : float, optional
        Damping ratio [-].
    tolerance : float, optional
        Accuracy of every boundary in ``r``: Magnus error (``boundary_steps``) and bisection
        together [-].
    steps : int, optional
        Magnus steps per period instead of those ``tolerance`` asks for.

    Returns
    -------
    list of (float, float)
        Unstable intervals ``(r_low, r_high)``, increasing; a range cut by the window ends at
        ``r_min`` or ``r_max``.

    Notes
    -----
    Without damping the equation is a periodic Sturm-Liouville problem in ``lambda = 1/r^2``,
    ``-(J gamma')' - 2 eps cos(2 tau) gamma = lambda gamma``, and its discriminant (the trace) has
    one extremum in every instability range (gap) and none in the stable bands, where it runs
    monotonically from +-2 to -+2 (Magnus and Winkler, Hill's equation, ch. 2).  So every range
    holds exactly one local minimum of the Jury margin ``1 + det - |trace|``, however narrow the
    range: the ranges emanating from ``r = 1/k`` at ``epsilon = 0`` have widths of order
    ``epsilon^k`` but their minima are broad (about ``1/k^2`` apart).  The search scans the margin
    on a grid uniform in ``1/r`` fine enough to separate neighbouring minima, refines every local
    minimum by golden section, and where the refined margin is below ``-UNSTABLE_MARGIN`` bisects
    each side between the minimum and the most stable scan point before the neighbouring minimum
    (the margin is monotonic in between).  With damping the same search is used; the ranges then
    shrink and the narrow ones close.
    """
    _check(epsilon, r_min)
    _check(epsilon, r_max)
    if not r_min < r_max:
        raise ModelError(f"expected r_min < r_max, got {r_min!r} and {r_max!r}")
    if not (math.isfinite(zeta) and zeta >= 0):
        raise ModelError(f"zeta = {zeta!r}: expected a non-negative damping ratio")
    n = steps if steps is not None else boundary_steps(tolerance, r_min=r_min, epsilon_max=epsilon)
    if n < 1:
        raise ModelError(f"steps = {n!r}: expected a positive number of Magnus steps per period")

    def margin(r: FloatArray) -> FloatArray:
        return _margin(epsilon, r, zeta, n)

    count = max(16, math.ceil((1.0 / r_min - 1.0 / r_max) * _SCAN_PER_UNIT / math.sqrt(1.0 - epsilon)) + 1)
    grid = 1.0 / np.linspace(1.0 / r_min, 1.0 / r_max, count)  # increasing r
    grid[0], grid[-1] = r_min, r_max
    scan = margin(grid)
    padded = np.concatenate([[np.inf], scan, [np.inf]])
    minima = np.flatnonzero((padded[1:-1] < padded[:-2]) & (padded[1:-1] <= padded[2:]))
    where, value = _golden_minimum(
        margin, grid[np.maximum(minima - 1, 0)], grid[np.minimum(minima + 1, count - 1)], 1e-9 * r_max
    )
    sampled = scan[minima] < value  # at a window edge the scan point itself may be the lowest
    where, value = np.where(sampled, grid[minima], where), np.where(sampled, scan[minima], value)

    # for each unstable minimum, each side: a stable anchor to bisect from, or the window edge
    unstable_scan = scan < -UNSTABLE_MARGIN
    sides: list[list[float | None]] = []
    low, high, low_unstable = [], [], []
    for i in np.flatnonzero(value < -UNSTABLE_MARGIN):
        pair: list[float | None] = []
        for before, after, edge in (
            (where[i - 1] if i > 0 else -np.inf, where[i], 0),
            (where[i], where[i + 1] if i + 1 < where.size else np.inf, count - 1),
        ):
            inside = np.flatnonzero((grid > before) & (grid < after))
            anchor = int(inside[np.argmax(scan[inside])]) if inside.size else edge
            if unstable_scan[anchor]:  # unstable up to the window edge (or merged with a neighbour)
                pair.append(float(grid[anchor]))
                continue
            pair.append(None)
            lo, hi = sorted((float(grid[anchor]), float(where[i])))
            low.append(lo)
            high.append(hi)
            low_unstable.append(lo == float(where[i]))
        sides.append(pair)
    lo_arr, hi_arr, lo_unstable = np.array(low), np.array(high), np.array(low_unstable, dtype=bool)
    width = max(0.5 * tolerance, 1e-14 * r_max)  # not below the resolution of doubles
    while lo_arr.size and float(np.max(hi_arr - lo_arr)) > width:  # all brackets at once
        mid = 0.5 * (lo_arr + hi_arr)
        same = (margin(mid) < -UNSTABLE_MARGIN) == lo_unstable
        lo_arr, hi_arr = np.where(same, mid, lo_arr), np.where(same, hi_arr, mid)
    edges = iter(0.5 * (lo_arr + hi_arr))
    found = sorted(
        (a if a is not None else float(next(edges)), b if b is not None else float(next(edges)))
        for a, b in sides
    )
    ranges: list[tuple[float, float]] = []
    for a, b in found:  # ranges sharing an unresolved stable band are reported as one
        if ranges and a <= ranges[-1][1]:
            ranges[-1] = (ranges[-1][0], max(b, ranges[-1][1]))
        else:
            ranges.append((a, b))
    return ranges


@dataclass(frozen=True)
class StabilityChart:
    """Stability of the linearised motion over a grid of ``(r, epsilon)``.

    Attributes
    ----------
    r : ndarray, shape (n_r,)
    epsilon : ndarray, shape (n_eps,)
    trace : ndarray, shape (n_eps, n_r)
        Trace of the monodromy matrix.
    growth_rate : ndarray, shape (n_eps, n_r)
        Largest Floquet exponent per unit tau (0 where stable) [-].
    unstable : ndarray of bool, shape (n_eps, n_r)
        Jury margin below ``-UNSTABLE_MARGIN``.
    steps : int
        Magnus steps per period.
    boundary_error : float
        Largest error of the boundaries in ``r`` at that step count (``boundary_error``);
        NaN when the steps were given beyond the measured inertia ratios [-].
    """

    r: FloatArray
    epsilon: FloatArray
    trace: FloatArray
    growth_rate: FloatArray
    unstable: npt.NDArray[np.bool_]
    steps: int
    boundary_error: float


def stability_chart(
    r: npt.ArrayLike,
    epsilon: npt.ArrayLike,
    *,
    zeta: float = 0.0,
    tolerance: float = 1e-6,
    steps: int | None = None,
    progress: Callable[[float], None] | None = None,
) -> StabilityChart:
    """Floquet stability over the grid ``r x epsilon``, vectorised over blocks of rows.

    Parameters
    ----------
    r : array_like, shape (n_r,)
        Speed ratios, > 0 [-].
    epsilon : array_like, shape (n_eps,)
        Inertia ratios in ``[0, 1)`` [-].
    zeta : float, optional
        Damping ratio [-].
    tolerance : float, optional
        Accuracy of the stability boundaries in ``r``; sets the Magnus step count through
        ``boundary_steps`` [-].
    steps : int, optional
        Magnus steps per period instead.
    progress : callable, optional
        Told the number of rows (epsilon values) done after every block [rows].

    Returns
    -------
    StabilityChart
    """
    rr = np.asarray(r, dtype=np.float64)
    ee = np.asarray(epsilon, dtype=np.float64)
    if rr.ndim != 1 or ee.ndim != 1 or rr.size == 0 or ee.size == 0:
        raise ModelError("stability_chart: expected non-empty 1-D arrays of r and epsilon")
    for e_value in (float(ee.min()), float(ee.max())):
        for r_value in (float(rr.min()), float(rr.max())):
            _check(e_value, r_value)
    if not (math.isfinite(zeta) and zeta >= 0):
        raise ModelError(f"zeta = {zeta!r}: expected a non-negative damping ratio")
    r_min, e_max = float(rr.min()), float(ee.max())
    if steps is None:
        n = boundary_steps(tolerance, r_min=r_min, epsilon_max=e_max)
    elif steps < 1:
        raise ModelError(f"steps = {steps!r}: expected a positive number of Magnus steps per period")
    else:
        n = steps
    try:
        error = boundary_error(n, epsilon_max=e_max)
    except ModelError:
        error = math.nan
    trace = np.empty((ee.size, rr.size))
    det = np.empty((ee.size, rr.size))
    block = max(1, _CHART_BLOCK // rr.size)
    for start in range(0, ee.size, block):
        rows = slice(start, min(start + block, ee.size))
        phi = _magnus_monodromy(ee[rows, None], rr[None, :], np.asarray(zeta), n)
        trace[rows] = phi[..., 0, 0] + phi[..., 1, 1]
        det[rows] = phi[..., 0, 0] * phi[..., 1, 1] - phi[..., 0, 1] * phi[..., 1, 0]
        if progress is not None:
            progress(float(rows.stop))
    unstable = 1.0 + det - np.abs(trace) < -UNSTABLE_MARGIN
    growth = np.where(unstable, np.log(_largest_multiplier(trace, det)) / math.pi, 0.0)
    return StabilityChart(rr, ee, trace, np.maximum(growth, 0.0), unstable, n, error)


# ----------------------------------------------------------------------------------- time response
@dataclass(frozen=True)
class TimeResponse:
    """Torsional response of the crank relative to the flywheel.

    Attributes
    ----------
    tau : ndarray
        Non-dimensional time ``omega t`` (crank angle of the flywheel) [rad].
    gamma : ndarray
        Twist of the crank relative to the flywheel [rad].
    gamma_prime : ndarray
        d gamma / d tau [-].
    form : str
        "linear" or "full".
    integrator : str
        Method used.
    """

    tau: FloatArray
    gamma: FloatArray
    gamma_prime: FloatArray
    form: str
    integrator: str


def _rhs(crank: VariableInertiaCrank, form: Form):  # type: ignore[no-untyped-def]
    eps, inv_r2, damp = crank.epsilon, 1.0 / crank.r**2, 2.0 * crank.zeta / crank.r
    excite = crank.excitation

    def linear(tau: float, y: FloatArray) -> FloatArray:
        s, c = math.sin(2 * tau), math.cos(2 * tau)
        g, gp = y[0], y[1]
        force = -eps * s + float(excite(tau)) if excite.orders else -eps * s
        gpp = (force - 2 * eps * s * gp - (inv_r2 + 2 * eps * c) * g - damp * gp) / (1 - eps * c)
        return np.array([gp, gpp])

    def full(tau: float, y: FloatArray) -> FloatArray:
        g, gp = y[0], y[1]
        angle = 2 * (tau + g)
        force = float(excite(tau)) if excite.orders else 0.0
        gpp = (force - eps * math.sin(angle) * (1 + gp) ** 2 - inv_r2 * g - damp * gp) / (
            1 - eps * math.cos(angle)
        )
        return np.array([gp, gpp])

    return linear if form == "linear" else full


def simulate(
    crank: VariableInertiaCrank,
    tau: npt.ArrayLike,
    *,
    initial: tuple[float, float] = (1.0, 0.0),
    form: Form = "linear",
    integrator: Integrator = "periodic",
    rtol: float = 1e-10,
    atol: float = 1e-12,
) -> TimeResponse:
    """Time response of the crank (the waveforms of paper 002 Fig. 2-5).

    Parameters
    ----------
    crank : VariableInertiaCrank
        Parameters.
    tau : array_like
        Increasing output times, starting at 0 [rad].
    initial : (float, float), optional
        gamma and gamma' at tau = 0 (paper 002: 1 and 0) [rad], [-].
    form : {"linear", "full"}
        Linearised equation (002 eq. 6) or the full one (eq. 4).
    integrator : {"periodic", "RK45", "DOP853", "Radau", "BDF", "LSODA"}
        "periodic" (linear form only): integrate one period once (DOP853 at the
        given tolerances) and propagate by its exact affine map; long runs cost
        no more than one period.  Otherwise a SciPy integrator over the whole run.
    rtol, atol : float, optional
        Integrator tolerances [-].

    Returns
    -------
    TimeResponse

    Raises
    ------
    ModelError
        For an empty or decreasing time grid, or ``periodic`` with the full form.
    """
    t = np.asarray(tau, dtype=np.float64)
    if t.ndim != 1 or t.size == 0 or t[0] != 0.0 or np.any(np.diff(t) <= 0) or not np.all(np.isfinite(t)):
        raise ModelError("tau: expected a finite, strictly increasing 1-D grid starting at 0")
    y0 = np.array(initial, dtype=np.float64)
    if integrator == "periodic":
        if form != "linear":
            raise ModelError(
                "integrator 'periodic' propagates the linear equation only; use a SciPy integrator"
            )
        gamma, gamma_prime = _periodic_response(crank, t, y0, rtol, atol)
        return TimeResponse(t, gamma, gamma_prime, form, integrator)
    if integrator not in ("RK45", "DOP853", "Radau", "BDF", "LSODA"):
        raise ModelError(f"integrator = {integrator!r}: expected periodic, RK45, DOP853, Radau, BDF or LSODA")
    solution = solve_ivp(
        _rhs(crank, form), (0.0, float(t[-1])), y0, method=integrator, t_eval=t, rtol=rtol, atol=atol
    )
    if not solution.success:
        raise ModelError(f"{integrator} failed: {solution.message}")
    if not np.all(np.isfinite(solution.y)):
        raise ModelError(f"{integrator} produced non-finite values: the motion overflowed")
    return TimeResponse(t, solution.y[0], solution.y[1], form, integrator)


def _periodic_response(
    crank: VariableInertiaCrank, t: FloatArray, y0: FloatArray, rtol: float, atol: float
) -> tuple[FloatArray, FloatArray]:
    period = math.pi * crank.excitation.period_factor
    rhs = _rhs(crank, "linear")

    def homogeneous(tau: float, y: FloatArray) -> FloatArray:
        forced = rhs(tau, np.zeros(2))
        return rhs(tau, y) - forced

    phase = np.mod(t, period)
    index = np.floor_divide(t, period).astype(np.int64)
    sols = [
        solve_ivp(homogeneous, (0.0, period), e, method="DOP853", rtol=rtol, atol=atol, dense_output=True)
        for e in (np.array([1.0, 0.0]), np.array([0.0, 1.0]))
    ]
    particular = solve_ivp(
        rhs, (0.0, period), np.zeros(2), method="DOP853", rtol=rtol, atol=atol, dense_output=True
    )
    phi = np.column_stack([s.y[:, -1] for s in sols])
    b = particular.y[:, -1]
    # state at the start of each period n: s_n = phi s_{n-1} + b
    n_periods = int(index.max()) + 1
    starts = np.empty((n_periods, 2))
    state = y0.copy()
    for n in range(n_periods):
        starts[n] = state
        state = phi @ state + b
        if not float(np.max(np.abs(state))) < _RUNAWAY:
            raise ModelError(
                f"the response overflowed after {n + 1} periods: the motion is unstable "
                "(see monodromy()); shorten the run"
            )
    basis = np.stack([s.sol(phase) for s in sols])  # (2 solutions, 2 components, n_t)
    part = particular.sol(phase)
    s_n = starts[index]  # (n_t, 2)
    out = basis[0] * s_n[:, 0] + basis[1] * s_n[:, 1] + part
    return out[0], out[1]


# -------------------------------------------------------------------------------- harmonic content
def harmonic_content(
    crank: VariableInertiaCrank,
    *,
    sidebands: Sequence[int] = (-4, -2, 0, 2, 4),
    revolutions: int = 400,
    samples_per_revolution: int = 256,
    initial: tuple[float, float] = (1.0, 0.0),
) -> dict[str, FloatArray]:
    """Orders present in the free response of the linearised crank (paper 002 Table 2).

    The homogeneous solution is a Floquet mode ``exp(j nu tau) P(tau)`` with
    ``P`` of period ``pi``: it contains the orders ``nu + 2m``.  ``nu``, the
    principal order, is found from the monodromy matrix; the amplitude of
    every order is then read from the spectrum of a long response (periodic
    propagation, Hann window) at the orders ``nu + m`` for ``m`` in ``sidebands``.

    Parameters
    ----------
    crank : VariableInertiaCrank
        Parameters (a stable point).
    sidebands : sequence of int, optional
        Offsets from the principal order to report [-].
    revolutions : int, optional
        Length of the analysed response [revolutions].
    samples_per_revolution : int, optional
        Sampling of the response.
    initial : (float, float), optional
        gamma and gamma' at tau = 0 [rad], [-].

    Returns
    -------
    dict
        ``principal_order`` (float), ``orders`` and ``amplitudes`` [rad] of the
        principal and sideband orders, and the spectrum ``spectrum_orders``,
        ``spectrum`` of the whole response [rad].
    """
    m = monodromy(crank.epsilon, crank.r, zeta=crank.zeta)
    if bool(m.unstable) or crank.zeta > 0:
        raise ModelError(
            f"harmonic_content: epsilon = {crank.epsilon!r}, r = {crank.r!r}, zeta = {crank.zeta!r}: "
            "expected an undamped, stable point (the free motion must persist for its orders to be read)"
        )
    # the multipliers exp(+-j nu pi) fix nu modulo 2: candidates +-base + 2k
    base = math.acos(max(-1.0, min(1.0, 0.5 * float(m.trace)))) / math.pi
    top = int(4 / crank.r) + 4
    candidates = sorted({c for k in range(top) for c in (base + 2 * k, 2 * k - base) if 0 < c < top})
    n = revolutions * samples_per_revolution
    tau = 2 * math.pi * np.arange(n) / samples_per_revolution
    response = simulate(crank, tau, initial=initial)
    window = np.hanning(n)
    spectrum = np.abs(np.fft.rfft(response.gamma * window)) * 2 / window.sum()
    orders = np.fft.rfftfreq(n, d=1 / samples_per_revolution)

    def peak(order: float) -> float:
        centre = round(order * revolutions)
        return float(spectrum[max(0, centre - 3) : centre + 4].max())

    nu = max(candidates, key=peak)  # the principal order carries the largest free component
    wanted = np.array([nu + s for s in sidebands])
    picks = np.array([peak(o) for o in wanted])
    return {
        "principal_order": np.array(nu),
        "orders": wanted,
        "amplitudes": picks,
        "spectrum_orders": orders,
        "spectrum": spectrum,
    }
