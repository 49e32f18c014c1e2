"""Floquet analysis of the variable-inertia crank: the monodromy matrix over one period ``pi``.

The linearised homogeneous equation of :mod:`monitor.torsion.variable_inertia`
is a Hill equation; in the variables ``(gamma, p = J gamma')`` the monodromy
matrix maps the state at ``tau`` to ``tau + pi``, and the motion is unstable
where its multipliers leave the unit circle (undamped: ``|trace| > 2``).

Numerics.  The monodromy matrix is integrated by the fourth-order Magnus
method on Gauss-Legendre nodes; each step's exponential of a 2 x 2 matrix is
evaluated in closed form, so every step preserves the determinant exactly
(to round-off) and whole grids of ``(r, eps)`` are integrated at once.
``monodromy`` refines the step count until the trace converges to a requested
tolerance.

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
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from monitor.errors import ModelError
from monitor.torsion.variable_inertia import check_ratios
from monitor.types import FloatArray

__all__ = ["BOUNDARY_BAND", "Monodromy", "largest_multiplier", "magnus_monodromy", "monodromy"]

#: Margin below which a point is reported on a stability boundary (see ``Monodromy.band``).
BOUNDARY_BAND = 1e-9

_SQRT3 = math.sqrt(3.0)
_GAUSS = (0.5 - _SQRT3 / 6.0, 0.5 + _SQRT3 / 6.0)


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
        return largest_multiplier(self.trace, self.determinant)

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


def largest_multiplier(trace: FloatArray, det: FloatArray) -> FloatArray:
    """Largest modulus of the eigenvalues of 2 x 2 matrices with these traces and determinants.

    Parameters
    ----------
    trace, det : ndarray
        [-].

    Returns
    -------
    ndarray
        [-].
    """
    disc = trace * trace - 4.0 * det
    real = 0.5 * (np.abs(trace) + np.sqrt(np.maximum(disc, 0.0)))
    return np.asarray(np.where(disc >= 0.0, real, np.sqrt(np.maximum(det, 0.0))))


def magnus_monodromy(epsilon: FloatArray, r: FloatArray, zeta: FloatArray, steps: int) -> FloatArray:
    """Monodromy over [0, pi] for arrays of parameters (broadcast), 4th-order Magnus.

    Parameters
    ----------
    epsilon, r, zeta : ndarray
        Inertia ratio, speed ratio, damping ratio, broadcast together [-].
    steps : int
        Magnus steps per period.

    Returns
    -------
    ndarray, shape (..., 2, 2)
        Maps ``(gamma, J gamma')`` at 0 to ``pi``.
    """
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
        check_ratios(float(e_value), float(r_value))
    if np.any(~np.isfinite(z)) or np.any(z < 0):
        raise ModelError("zeta: expected non-negative damping ratios")
    if steps is not None:
        phi = magnus_monodromy(eps, rr, z, steps)
        coarse = magnus_monodromy(eps, rr, z, max(1, steps // 2))
        return _result(phi, coarse, steps)
    n = _steps_for(rr, eps, 32)
    coarse = magnus_monodromy(eps, rr, z, n)
    while True:
        phi = magnus_monodromy(eps, rr, z, 2 * n)
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
    """The monodromy with its trace's error estimated from the matrix at half the steps."""
    trace = np.trace(phi, axis1=-2, axis2=-1)
    error = np.abs(trace - np.trace(coarse, axis1=-2, axis2=-1)) / 15.0  # Richardson, order 4
    multipliers = np.linalg.eigvals(phi).astype(np.complex128)
    return Monodromy(phi, trace, multipliers, steps, error)
