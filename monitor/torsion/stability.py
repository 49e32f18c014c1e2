"""Stability of the variable-inertia crank: instability ranges in ``r`` and the chart over ``(r, epsilon)``.

Both rest on the monodromy matrix of :mod:`monitor.torsion.floquet`, integrated with a
fixed step count for whole grids at once.  Charts and range searches take the step count from a
wanted accuracy of the stability boundaries in ``r``, by the measured relation
``BOUNDARY_ERROR`` (error ``C / steps^4``): a trace tolerance would be spent
where the trace grows exponentially, inside the unstable regions.  The range
search seeds a local search in every range, however narrow (see
``instability_ranges``).

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
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from monitor.errors import ModelError
from monitor.torsion.floquet import largest_multiplier, magnus_monodromy
from monitor.torsion.variable_inertia import check_ratios
from monitor.types import FloatArray

__all__ = [
    "BOUNDARY_ERROR",
    "BOUNDARY_WINDOW",
    "UNSTABLE_MARGIN",
    "StabilityChart",
    "boundary_error",
    "boundary_steps",
    "instability_ranges",
    "stability_chart",
]

#: Chart cells integrated together: big enough that numpy's per-call overhead is small, small
#: enough to stay in cache and to report progress every few hundred milliseconds.
_CHART_BLOCK = 2000

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
    check_ratios(epsilon_max, r_min)
    constant = boundary_error(1, epsilon_max=epsilon_max)
    steps = math.ceil((2.0 * constant / tolerance) ** 0.25)
    if r_min < BOUNDARY_WINDOW[0]:
        steps = math.ceil(steps * BOUNDARY_WINDOW[0] / r_min)
    return max(steps, _resolution_steps(r_min, epsilon_max))


def _margin(epsilon: npt.ArrayLike, r: npt.ArrayLike, zeta: float, steps: int) -> FloatArray:
    """Jury margin ``1 + det - |trace|`` with a fixed step count, without an error estimate."""
    phi = magnus_monodromy(
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
    check_ratios(epsilon, r_min)
    check_ratios(epsilon, r_max)
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
            check_ratios(e_value, r_value)
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
        phi = magnus_monodromy(ee[rows, None], rr[None, :], np.asarray(zeta), n)
        trace[rows] = phi[..., 0, 0] + phi[..., 1, 1]
        det[rows] = phi[..., 0, 0] * phi[..., 1, 1] - phi[..., 0, 1] * phi[..., 1, 0]
        if progress is not None:
            progress(float(rows.stop))
    unstable = 1.0 + det - np.abs(trace) < -UNSTABLE_MARGIN
    growth = np.where(unstable, np.log(largest_multiplier(trace, det)) / math.pi, 0.0)
    return StabilityChart(rr, ee, trace, np.maximum(growth, 0.0), unstable, n, error)
