"""Time response of the variable-inertia crank and the orders in it (paper 002 Fig. 2-5, Table 2).

Long time responses of the linear equation are propagated period by period
with the exact affine map of one period (no accumulation of integrator
error); direct integration with any SciPy integrator is available for both
forms.  The orders of the free response
(:func:`harmonic_content`) follow from the Floquet multipliers of
:mod:`monitor.torsion.floquet` and the spectrum of a long response.

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
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt
from scipy.integrate import solve_ivp

from monitor.errors import ModelError
from monitor.torsion.floquet import monodromy
from monitor.torsion.variable_inertia import VariableInertiaCrank
from monitor.types import FloatArray

__all__ = ["Form", "Integrator", "TimeResponse", "harmonic_content", "simulate"]

Form = Literal["linear", "full"]
Integrator = Literal["periodic", "RK45", "DOP853", "Radau", "BDF", "LSODA"]

#: Response magnitude at which periodic propagation stops as unstable [rad].
_RUNAWAY = 1e100


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
