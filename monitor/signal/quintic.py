"""The interpolating quintic spline of a crank's pulses, compiled.

The angle map's speed is the derivative of the quintic spline that passes
through every pulse (time, angle) (see :meth:`monitor.signal.anglemap.AngleMap.speed_at`).
This is the spline :func:`scipy.interpolate.make_interp_spline` makes with
``k=5`` and its default ("not-a-knot") knots: a B-spline of degree 5 whose
interior knots are the data sites but the first three and the last three,
and whose end knots are repeated six times (de Boor, *A Practical Guide to
Splines*, rev. ed., 2001, ch. XIII). Its coefficients solve the collocation
system ``sum_j c_j B_j(x_i) = y_i``, a band matrix with at most six
non-zeros a row. B-spline collocation matrices are totally positive, so
Gaussian elimination without pivoting is stable on them (de Boor and
Pinkus, "Backward error analysis for totally positive linear systems",
Numer. Math. 27, 1977): the band is solved in place, in time and memory
linear in the number of pulses, where scipy's general banded solver with
pivoting and its checks cost several times more on a recording's hour of
pulses. Values and slopes are evaluated by the Cox-de Boor recurrence.
"""

from __future__ import annotations

import math
from functools import cached_property

import numba
import numpy as np

from monitor.errors import SignalError
from monitor.types import FloatArray

__all__ = ["QuinticSpline"]

_K = 5  # the degree


class QuinticSpline:
    """The interpolating quintic spline through ``(x[i], y[i])``, not-a-knot knots.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Strictly increasing sites, at least six.
    y : ndarray, shape (n,)
        Values at the sites.

    Raises
    ------
    SignalError
        For fewer than six sites, sites that do not increase, or values that are not finite.
    """

    def __init__(self, x: FloatArray, y: FloatArray) -> None:
        x = np.ascontiguousarray(x, dtype=np.float64)
        y = np.ascontiguousarray(y, dtype=np.float64)
        if x.ndim != 1 or x.shape != y.shape or x.size <= _K:
            raise SignalError(
                f"a quintic spline needs at least {_K + 1} sites and as many values: got {x.shape}"
            )
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
            raise SignalError("a quintic spline's sites and values must be finite")
        if not np.all(np.diff(x) > 0):
            raise SignalError("a quintic spline's sites must increase strictly")
        self.knots = np.concatenate([np.full(_K + 1, x[0]), x[3:-3], np.full(_K + 1, x[-1])])
        self.coefficients = y.copy()
        _solve_collocation(x, self.knots, self.coefficients)

    def __call__(self, at: FloatArray) -> FloatArray:
        """Values at ``at`` inside the sites' span [the values' unit]."""
        out = np.empty(np.shape(at))
        _evaluate(
            self.knots, self.coefficients, np.ascontiguousarray(at, dtype=np.float64).ravel(), 0, out.ravel()
        )
        return out

    def slope(self, at: FloatArray) -> FloatArray:
        """First derivatives at ``at`` inside the sites' span [values' unit per site unit]."""
        out = np.empty(np.shape(at))
        flat = np.ascontiguousarray(at, dtype=np.float64).ravel()
        _evaluate(self.knots, self._slope_coefficients, flat, 1, out.ravel())
        return out

    @cached_property
    def _slope_coefficients(self) -> FloatArray:
        """The derivative's B-spline coefficients, degree 4 on the same knots (index j: B_{j,4}).

        s' = sum_j K (c_j - c_{j-1}) / (t_{j+K} - t_j) B_{j,K-1} (de Boor, ch. X, eq. (15)); entry 0 is
        never used on the sites' span.
        """
        c, t = self.coefficients, self.knots
        slope = np.zeros(c.size)
        slope[1:] = _K * np.diff(c) / (t[_K + 1 : c.size + _K] - t[1 : c.size])
        return slope


@numba.njit(cache=True, nogil=True)
def _span(t: FloatArray, n: int, value: float, guess: int) -> int:  # pragma: no cover - compiled
    """The knot interval ``span`` (``K <= span < n``) with ``t[span] <= value < t[span + 1]``."""
    lo, hi = _K, n - 1
    if value >= t[n - 1]:
        return n - 1
    if lo <= guess <= hi and t[guess] <= value < t[guess + 1]:
        return guess
    if lo <= guess + 1 <= hi and t[guess + 1] <= value < t[guess + 2]:
        return guess + 1
    while hi - lo > 1:  # t[lo] <= value < t[hi]
        middle = (lo + hi) // 2
        if t[middle] <= value:
            lo = middle
        else:
            hi = middle
    return lo


@numba.njit(cache=True, nogil=True)
def _basis(
    t: FloatArray, span: int, value: float, degree: int, out: FloatArray, left: FloatArray, right: FloatArray
) -> None:  # pragma: no cover - compiled
    """The ``degree + 1`` B-splines of ``degree`` non-zero on interval ``span`` at ``value`` (Cox-de Boor).

    ``left`` and ``right`` are work space of ``degree + 1`` each.
    """
    out[0] = 1.0
    for j in range(1, degree + 1):
        left[j] = value - t[span + 1 - j]
        right[j] = t[span + j] - value
        saved = 0.0
        for r in range(j):
            term = out[r] / (right[r + 1] + left[j - r])
            out[r] = saved + right[r + 1] * term
            saved = left[j - r] * term
        out[j] = saved


@numba.njit(cache=True, nogil=True)
def _solve_collocation(x: FloatArray, t: FloatArray, c: FloatArray) -> None:  # pragma: no cover - compiled
    """Overwrite the values ``c`` with the coefficients: band elimination without pivoting."""
    n = x.size
    width = 2 * _K + 1  # columns i - K .. i + K of row i, at band[i, j - i + K]
    band = np.zeros((n, width))
    values, left, right = np.empty(_K + 1), np.empty(_K + 1), np.empty(_K + 1)
    span = _K
    for i in range(n):
        span = _span(t, n, x[i], span)
        _basis(t, span, x[i], _K, values, left, right)
        for r in range(_K + 1):
            band[i, span - _K + r - i + _K] = values[r]
    for p in range(n):  # forward elimination: the rows below the pivot within the band
        pivot = band[p, _K]
        for r in range(p + 1, min(n, p + _K + 1)):
            factor = band[r, p - r + _K]
            if factor == 0.0:
                continue
            factor /= pivot
            for q in range(p + 1, min(n, p + _K + 1)):
                band[r, q - r + _K] -= factor * band[p, q - p + _K]
            c[r] -= factor * c[p]
    for p in range(n - 1, -1, -1):  # back substitution
        total = c[p]
        for q in range(p + 1, min(n, p + _K + 1)):
            total -= band[p, q - p + _K] * c[q]
        c[p] = total / band[p, _K]


@numba.njit(cache=True, nogil=True)
def _evaluate(
    t: FloatArray, c: FloatArray, at: FloatArray, derivative: int, out: FloatArray
) -> None:  # pragma: no cover - compiled
    """The spline (``derivative`` 0, ``c`` its coefficients) or its slope (1, ``c`` the slope's)."""
    n = c.size
    values, left, right = np.empty(_K + 1), np.empty(_K + 1), np.empty(_K + 1)
    span = _K
    for p in range(at.size):
        value = at[p]
        if math.isnan(value):
            out[p] = math.nan
            continue
        span = _span(t, n, value, span)
        if derivative == 0:
            _basis(t, span, value, _K, values, left, right)
            total = 0.0
            for r in range(_K + 1):
                total += values[r] * c[span - _K + r]
        else:  # c holds the derivative's coefficients: B_{j,K-1}, j = span - K + 1 .. span
            _basis(t, span, value, _K - 1, values, left, right)
            total = 0.0
            for r in range(_K):
                total += values[r] * c[span - _K + 1 + r]
        out[p] = total
