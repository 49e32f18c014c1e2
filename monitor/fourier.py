"""Order (Fourier) coefficients of periodic functions of crank angle.

Convention (shared by the model and the measured spectra): a quantity
``q(alpha)`` periodic over one cycle is written

    q(alpha) = q_0 + sum_k |Q_k| cos(k alpha + arg Q_k)

with ``alpha`` the crank angle from TDC of cylinder 1 [rad] and ``k`` the order
(revolutions of the crankshaft per period of the component).  ``Q_k`` is the
complex coefficient, amplitude as peak.  A two-stroke cycle is one revolution
(integer orders); a four-stroke cycle is two (half orders).

On a uniform grid of ``N`` points over the cycle the coefficients are the
scaled real FFT.  For the smooth functions the model produces, the error of
coefficient ``k`` on that grid is the aliased sum of the coefficients at
``N - k, N + k, ...``; it is estimated from the same samples by comparing with
the grid of every second point (cheap and conservative).  The truncation error
of keeping orders up to ``K`` is bounded by the sum of the magnitudes of the
orders above ``K`` (sup norm of the dropped tail).

References
----------
000: Murawski (orders 1, 2, 4, 6, 8 of the exact piston acceleration).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from monitor.errors import ModelError
from monitor.types import ComplexArray, FloatArray

__all__ = [
    "OrderCoefficients",
    "cycle_grid",
    "order_coefficients",
    "order_coefficients_of",
    "scaled_rfft",
    "synthesize",
]


@dataclass(frozen=True)
class OrderCoefficients:
    """Complex order coefficients of one or more periodic quantities.

    Attributes
    ----------
    orders : ndarray, shape (n_orders,)
        Orders k, starting at 0 (the mean) in steps of ``1 / cycle_revolutions`` [-].
    coefficients : ndarray, shape (..., n_orders)
        Complex Q_k in the quantity's unit (peak amplitude; ``Q_0`` is the mean).
    aliasing_error : ndarray, shape (..., n_orders)
        Estimated error of each coefficient from the finite angular grid.
    truncation_error : ndarray, shape (...)
        Bound on the sup-norm error of the series truncated at ``orders[-1]``:
        the sum of the magnitudes of the higher orders on the evaluation grid.
    grid_size : int
        Samples per cycle used.
    cycle_revolutions : int
        Revolutions per cycle (1 two-stroke, 2 four-stroke).
    """

    orders: FloatArray
    coefficients: ComplexArray
    aliasing_error: FloatArray
    truncation_error: FloatArray
    grid_size: int
    cycle_revolutions: int

    @property
    def amplitude(self) -> FloatArray:
        """Peak amplitude |Q_k| in the quantity's unit."""
        return np.abs(self.coefficients)

    @property
    def phase(self) -> FloatArray:
        """Phase arg Q_k [rad], relative to TDC of cylinder 1."""
        return np.angle(self.coefficients)


def cycle_grid(grid_size: int, cycle_revolutions: int = 1) -> FloatArray:
    """Uniform crank-angle grid over one cycle, endpoint excluded.

    Parameters
    ----------
    grid_size : int
        Samples per cycle, >= 2.
    cycle_revolutions : int
        1 for a two-stroke cycle, 2 for a four-stroke cycle.

    Returns
    -------
    ndarray
        Crank angles ``2 pi cycle_revolutions n / grid_size`` [rad].
    """
    _check_grid(grid_size, cycle_revolutions)
    return (2.0 * np.pi * cycle_revolutions / grid_size) * np.arange(grid_size, dtype=np.float64)


def _check_grid(grid_size: int, cycle_revolutions: int) -> None:
    if int(grid_size) != grid_size or grid_size < 2:
        raise ModelError(f"grid_size = {grid_size!r}: expected an integer >= 2 samples per cycle")
    if cycle_revolutions not in (1, 2):
        raise ModelError(
            f"cycle_revolutions = {cycle_revolutions!r}: expected 1 (two-stroke) or 2 (four-stroke)"
        )


def scaled_rfft(samples: FloatArray) -> ComplexArray:
    """Real FFT along the last axis scaled to peak order amplitudes (order 0 and Nyquist: the value itself).

    Parameters
    ----------
    samples : ndarray, shape (..., N)
        One period on a uniform grid [the quantity's unit].

    Returns
    -------
    ndarray, shape (..., N // 2 + 1)
    """
    n = samples.shape[-1]
    spectrum = np.fft.rfft(samples, axis=-1) * (2.0 / n)
    spectrum[..., 0] *= 0.5
    if n % 2 == 0:
        spectrum[..., -1] *= 0.5
    return spectrum


def order_coefficients(
    samples: npt.ArrayLike, *, cycle_revolutions: int = 1, max_order: float | None = None
) -> OrderCoefficients:
    """Order coefficients of samples on a uniform grid over one cycle.

    Parameters
    ----------
    samples : array_like, shape (..., N)
        Values at ``cycle_grid(N, cycle_revolutions)``; samples on the last axis.
        N should be even (the error estimate uses every second point) [the quantity's unit].
    cycle_revolutions : int, optional
        1 for a two-stroke cycle (integer orders), 2 for four-stroke (half orders).
    max_order : float, optional
        Highest order to return; default: everything the grid resolves
        (``N / 4 / cycle_revolutions``, the highest order the half grid also resolves) [-].

    Returns
    -------
    OrderCoefficients

    Raises
    ------
    ModelError
        On an empty, non-finite or odd-length grid, or a ``max_order`` the grid cannot resolve.
    """
    values = np.asarray(samples, dtype=np.float64)
    if values.ndim == 0 or values.shape[-1] < 4:
        raise ModelError(
            f"samples has shape {values.shape}: expected at least 4 samples per cycle on the last axis"
        )
    n = values.shape[-1]
    _check_grid(n, cycle_revolutions)
    if n % 2:
        raise ModelError(f"samples has {n} points per cycle: expected an even number")
    if not np.all(np.isfinite(values)):
        raise ModelError("samples contain NaN or Inf: the model produced a non-finite value")
    full = scaled_rfft(values)
    half = scaled_rfft(values[..., ::2])
    n_resolved = half.shape[-1] - 2  # highest bin of the half grid below its Nyquist bin
    top_bin = n_resolved
    if max_order is not None:
        top_bin = round(max_order * cycle_revolutions)
        if top_bin < 0 or abs(top_bin - max_order * cycle_revolutions) > 1e-9:
            raise ModelError(
                f"max_order = {max_order!r}: expected a non-negative multiple of "
                f"{1 / cycle_revolutions:g} for a {cycle_revolutions}-revolution cycle"
            )
        if top_bin > n_resolved:
            raise ModelError(
                f"max_order = {max_order!r} needs more than {n} samples per cycle; "
                f"this grid resolves orders up to {n_resolved / cycle_revolutions:g}"
            )
    kept = full[..., : top_bin + 1]
    alias = np.abs(kept - half[..., : top_bin + 1])
    tail = np.sum(np.abs(full[..., top_bin + 1 :]), axis=-1)
    orders = np.arange(top_bin + 1, dtype=np.float64) / cycle_revolutions
    return OrderCoefficients(
        orders=orders,
        coefficients=kept,
        aliasing_error=alias,
        truncation_error=np.asarray(tail, dtype=np.float64),
        grid_size=n,
        cycle_revolutions=cycle_revolutions,
    )


def order_coefficients_of(
    function: Callable[[FloatArray], npt.ArrayLike],
    *,
    max_order: float,
    cycle_revolutions: int = 1,
    tolerance: float = 1e-12,
    max_grid_size: int = 1 << 20,
) -> OrderCoefficients:
    """Order coefficients of a function of crank angle, refining the grid to a tolerance.

    The grid is doubled, starting from the smallest power of two that resolves
    ``max_order``, until the estimated aliasing error of every returned
    coefficient is below ``tolerance`` times the largest coefficient magnitude.

    Parameters
    ----------
    function : callable
        ``function(crank_angle) -> values`` with crank angle [rad] on the last axis.
    max_order : float
        Highest order to return [-].
    cycle_revolutions : int, optional
        1 (two-stroke cycle) or 2 (four-stroke cycle).
    tolerance : float, optional
        Relative accuracy wanted for the coefficients [-].
    max_grid_size : int, optional
        Refuse to refine beyond this many samples per cycle.

    Returns
    -------
    OrderCoefficients

    Raises
    ------
    ModelError
        If the tolerance is not reached within ``max_grid_size`` (the function is
        not smooth enough for it) or the function returns non-finite values.
    """
    if not tolerance > 0:
        raise ModelError(f"tolerance = {tolerance!r}: expected a positive relative tolerance")
    n = 16
    while n < 8 * max_order * cycle_revolutions:
        n *= 2
    while True:
        result = order_coefficients(
            function(cycle_grid(n, cycle_revolutions)),
            cycle_revolutions=cycle_revolutions,
            max_order=max_order,
        )
        scale = max(float(np.max(np.abs(result.coefficients), initial=0.0)), np.finfo(float).tiny)
        if float(np.max(result.aliasing_error, initial=0.0)) <= tolerance * scale:
            return result
        if 2 * n > max_grid_size:
            raise ModelError(
                f"order coefficients did not reach tolerance {tolerance:g} with "
                f"{n} samples per cycle (max_grid_size = {max_grid_size})"
            )
        n *= 2


def synthesize(coefficients: OrderCoefficients, crank_angle: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Evaluate the truncated order series at the given crank angles.

    Parameters
    ----------
    coefficients : OrderCoefficients
        Coefficients with shape (..., n_orders).
    crank_angle : array_like, shape (M,)
        Crank angle [rad].

    Returns
    -------
    ndarray, shape (..., M)
        ``q_0 + sum_k Re(Q_k exp(j k alpha))`` in the quantity's unit.
    """
    alpha = np.asarray(crank_angle, dtype=np.float64)
    basis = np.exp(1j * np.multiply.outer(coefficients.orders, alpha))
    return np.real(coefficients.coefficients @ basis)
