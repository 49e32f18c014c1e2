"""An engine's condition over time: the quantities of each diagnosis, and the rule that finds drift.

Quantities.  Every stored diagnosis (the ``compare --json`` document) gives,
at the recording's time (its start, not its upload):

- ``speed`` [rpm] and ``load`` [-]: the operating point, shown beside the
  others and not judged;
- ``cylinder N strength`` [-]: each cylinder's strength relative to the
  cylinders that fire alike (1 healthy, 0 misfiring), with its standard error;
- ``<sensor> order deviation`` [-]: the largest over the orders compared of
  ``|measured - predicted| / |largest predicted|`` of a bearing sensor (and
  ``<sensor> order K deviation``, each order's, kept and shown, not judged:
  the largest stands for them, so that a sensor's two dozen orders do not
  multiply the false findings);
- ``<sensor> impact`` [-]: the largest of the sensor's impact scores over the
  bearings it hears, with its standard error;
- ``<sensor> rms velocity`` [mm/s]: with its standard error.

Drift.  Each judged quantity is followed with a two-sided CUSUM on values
standardised by the quantity's own history, a lagged form of the
self-starting CUSUM (Hawkins, "Self-starting CUSUM charts for location and
scale", The Statistician 36, 1987; Hawkins & Olwell, *Cumulative Sum Charts
and Charting for Quality Improvement*, 1998, §7.2). Its choices are measured
(``python -m benchmarks.trends``, docs/trends.md), because the obvious ones
fail:

- against a baseline period's mean and spread estimated from ten recordings,
  a CUSUM finds drift where there is none in 28 % of series within 30 nights
  (the estimates are off by a third of a sigma and more);
- standardised by all the values before it (Hawkins' form, exact in
  control), it absorbs a shift into its estimates and misses most shifts of
  two sigmas;
- with the plain mean and spread of that history, one misfire among an
  engine's first ten recordings widens the spread twentyfold (a strength of
  0 against 1.00 +- 0.015), and a cylinder falling by a third is then a
  one-sigma change, not found.

So value ``n`` is standardised by the mean ``m`` and spread ``s`` of the
values up to :data:`LAG` recordings before it (at least the
:data:`BASELINE_RECORDINGS` of the baseline period, the engine's first),
those farther than :data:`ROBUST_SIGMAS` robust sigmas (the median absolute
deviation, see :func:`reference`) from their median left out,

    t = (x_n - m) / (s sqrt(1 + 1/c)),   u = Phi^-1(F_{t, c-1}(t)),

``c`` the values kept in ``m`` and ``s``, ``F_{t, c-1}`` Student's t distribution
(for Gaussian values in control each ``u`` is standard normal whatever the
unknown mean and spread); ``s`` is at least :data:`RELATIVE_FLOOR` of
``|m|`` (a quantity that hardly moved does not make every wobble a shift).
After the baseline period the sums

    S+ = max(0, S+ + u - K),   S- = max(0, S- - u - K)

make a trend finding when either exceeds ``H``; ``K`` = :data:`REFERENCE`
(0.5) tunes the rule to shifts of one sigma, ``H`` = :data:`DECISION` (9).
With the mean and spread known, ``H`` = 9 would give one false finding per
quantity in some 26 000 recordings (Siegmund's approximation, below); the
estimates' own error brings that down to what docs/trends.md measures (about
5 % of quantities a year of nightly recordings, as with the plain mean and
spread of the history), while a shift of two sigmas is found after about 8
nights and one of three after 5, with or without a misfire among the first
recordings; a band of 8 robust sigmas is the narrowest measured that keeps
that false-finding rate. Siegmund's
approximation of a side's average run length after a shift of ``d`` sigmas
(``d = 0``: in control), with the mean and spread known, which
tests/diagnosis/test_trends.py checks the sums against by simulation:

    ARL(d) = (exp(-2 D b) + 2 D b - 1) / (2 D^2),   D = d - K,  b = H + 1.166.

"""

from __future__ import annotations

import bisect
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from datetime import datetime
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.special import ndtri, stdtr

from monitor.types import FloatArray

__all__ = [
    "BASELINE_RECORDINGS",
    "DECISION",
    "JUDGED",
    "LAG",
    "REFERENCE",
    "RELATIVE_FLOOR",
    "ROBUST_SIGMAS",
    "Drift",
    "Reference",
    "TrendPoint",
    "cusum",
    "drift",
    "reference",
    "standardised",
    "trend_points",
]

BASELINE_RECORDINGS = 10  # recordings of the baseline period, the engine's first [-]
REFERENCE = 0.5  # K: half the shift, in sigmas, the CUSUM is tuned to [-]
DECISION = 9.0  # H: the decision interval, in sigmas [-]
LAG = 10  # recordings between a value and the newest of those it is standardised by [-]
RELATIVE_FLOOR = 0.01  # sigma at least this share of the baseline's mean magnitude [-]
ROBUST_SIGMAS = 8.0  # values farther than this from their median are left out of the estimates [-]
JUDGED = ("strength", "order deviation", "impact", "rms velocity")  # quantity endings followed for drift


@dataclass(frozen=True)
class TrendPoint:
    """One quantity of one diagnosis.

    Attributes
    ----------
    quantity : str
        Its name (see the module docstring).
    value : float
    standard_error : float or None
        Where the diagnosis gives one.
    unit : str
    """

    quantity: str
    value: float
    standard_error: float | None
    unit: str


def _number(value: Any) -> float | None:
    try:
        number = float(value)
    except (TypeError, ValueError):
        return None
    return number if math.isfinite(number) else None


def trend_points(document: dict[str, Any]) -> list[TrendPoint]:
    """The quantities a diagnosis document gives (see the module docstring).

    Parameters
    ----------
    document : dict
        A diagnosis document (``compare --json``; the service's and the batch's stored result).

    Returns
    -------
    list of TrendPoint
        Missing or non-finite values are left out.
    """
    points: list[TrendPoint] = []

    def add(quantity: str, value: Any, error: Any, unit: str) -> None:
        number = _number(value)
        if number is not None:
            points.append(TrendPoint(quantity, number, _number(error), unit))

    add("speed", document.get("speed_rpm"), None, "rpm")
    add("load", document.get("load"), None, "-")
    balance = document.get("cylinder_balance") or {}
    relative = balance.get("relative") or []
    errors = balance.get("relative_standard_error") or [None] * len(relative)
    names = balance.get("names") or [str(c) for c in range(1, len(relative) + 1)]
    for name, value, error in zip(names, relative, errors, strict=False):
        add(f"cylinder {name} strength", value, error, "-")
    for sensor, channel in sorted((document.get("channels") or {}).items()):
        if sensor == "crank speed":  # the cylinders' strengths are its summary
            continue
        orders = channel.get("orders") or []
        deviations = [_number(d) for d in channel.get("deviation_of_largest") or []]
        known = [v for v in deviations if v is not None]
        if known:
            add(f"{sensor} order deviation", max(known), None, "-")
        for order, value in zip(orders, deviations, strict=False):  # each order's, kept, not judged
            if value is not None and _number(order) is not None:
                add(f"{sensor} order {float(order):g} deviation", value, None, "-")
    for sensor, scores in sorted((document.get("impacts") or {}).items()):
        scored = [s for s in scores if _number(s.get("score")) is not None]
        if scored:
            top = max(scored, key=lambda s: float(s["score"]))
            add(f"{sensor} impact", top["score"], top.get("standard_error"), "-")
    for sensor, rms in sorted((document.get("velocity_rms") or {}).items()):
        add(f"{sensor} rms velocity", rms.get("value_mm_s"), rms.get("standard_error_mm_s"), "mm/s")
    return points


def judged(quantity: str) -> bool:
    """Whether a quantity is followed for drift (the operating point is not)."""
    return quantity.endswith(JUDGED)


def cusum(z: npt.ArrayLike, *, reference: float = REFERENCE) -> tuple[FloatArray, FloatArray]:
    """The two one-sided CUSUM sums after each standardised value.

    Parameters
    ----------
    z : array_like
        ``(x - mu) / sigma`` of each value, in order [-].
    reference : float, optional
        K [-].

    Returns
    -------
    upper, lower : ndarray
        ``S+`` and ``S-`` after each value (both start at 0) [-].
    """
    standardised = np.asarray(z, dtype=np.float64)
    upper, lower = np.zeros(standardised.size), np.zeros(standardised.size)
    high = low = 0.0
    for n, value in enumerate(standardised.tolist()):
        high = max(0.0, high + value - reference)
        low = max(0.0, low - value - reference)
        upper[n], lower[n] = high, low
    return upper, lower


@dataclass(frozen=True)
class Drift:
    """A quantity that left its baseline period.

    Attributes
    ----------
    quantity : str
    unit : str
    direction : str
        "up" or "down".
    found_at : datetime
        The recording at which the CUSUM crossed the decision interval.
    since : datetime
        The first recording of the change (the one after the sum was last zero).
    shift : float
        Mean of the values from ``since`` to ``found_at`` less the baseline's mean [unit].
    shift_sigmas : float
        The same in the baseline's sigmas [-].
    baseline_mean, baseline_sigma : float
        Mean and spread of the values before ``since``, those far from their median left out as the
        rule leaves them out (:func:`reference`) [unit].
    """

    quantity: str
    unit: str
    direction: str
    found_at: datetime
    since: datetime
    shift: float
    shift_sigmas: float
    baseline_mean: float
    baseline_sigma: float

    @property
    def summary(self) -> str:
        """In words: what moved, since when, by how much."""
        return (
            f"{self.quantity} {'rose' if self.direction == 'up' else 'fell'} by {abs(self.shift):.3g} "
            f"{self.unit} ({abs(self.shift_sigmas):.1f} sigma of its earlier {self.baseline_mean:.3g} "
            f"+- {self.baseline_sigma:.2g}) since {self.since:%Y-%m-%d %H:%M}, "
            f"found on {self.found_at:%Y-%m-%d %H:%M}"
        )


@dataclass(frozen=True)
class Reference:
    """The location and spread values are standardised by, from the values before them.

    Attributes
    ----------
    location : ndarray
        Mean of the values kept [unit].
    spread : ndarray
        Their standard deviation, at least :data:`RELATIVE_FLOOR` of ``|location|`` [unit].
    count : ndarray
        The values kept: the location's error is ``spread / sqrt(count)``, the spread's has
        ``count - 1`` degrees of freedom [-].
    """

    location: FloatArray
    spread: FloatArray
    count: FloatArray


def reference(history: npt.ArrayLike, *, robust_sigmas: float = ROBUST_SIGMAS) -> Reference:
    """Mean and spread of values, those beyond ``robust_sigmas`` robust sigmas of their median left out.

    Parameters
    ----------
    history : array_like
        Values on the last axis (at least 3), any leading axes are series of their own [unit].
    robust_sigmas : float, optional
        The band kept about the median, in robust sigmas; ``inf`` keeps every value (the plain mean
        and standard deviation) [-].

    Returns
    -------
    Reference
        Of the leading axes' shape.

    Notes
    -----
    The robust sigma is the median absolute deviation from the median made consistent for the
    normal distribution, with Croux and Rousseeuw's small-sample factor,

        sigma_r = 1.4826 b_c median|x - median(x)|,   b_c = c / (c - 0.8),

    ``c`` the number of values. Values with ``|x - median(x)| > k sigma_r`` are left out and the
    mean and standard deviation are those of the rest. The median and the MAD are moved by one value,
    however far, by at most one step of the order statistics (their breakdown point is a half), so a
    misfire or a knock among the values cannot widen the band that decides what is kept, and when
    kept a value lies within the band, which bounds the spread (tests/diagnosis/test_trends.py). When more
    than half the values are equal the MAD is zero and says nothing of the spread: all are kept.

    References
    ----------
    Croux, C. and Rousseeuw, P. J., "Time-efficient algorithms for two highly robust estimators of
    scale", Computational Statistics 1, 1992 (the factor ``b_c``, for ``c > 9``).
    Hampel, F. R., "The influence curve and its role in robust estimation", JASA 69, 1974,
    doi:10.1080/01621459.1974.10482962 (the MAD, and rejecting values beyond it).
    """
    h = np.asarray(history, dtype=np.float64)
    c = h.shape[-1] if h.ndim else 0
    if c < 3:
        raise ValueError(f"history: {c} values; a reference needs at least 3")
    _check_band(robust_sigmas)
    median = np.median(h, axis=-1, keepdims=True)
    deviation = np.abs(h - median)
    robust = 1.4826 * c / (c - 0.8) * np.median(deviation, axis=-1, keepdims=True)
    keep = (deviation <= robust_sigmas * robust) | (robust == 0.0)
    count = keep.sum(axis=-1)
    centred = np.where(keep, h - median, 0.0)  # about the median: no cancellation in the spread
    offset = centred.sum(axis=-1) / count
    variance = np.maximum((np.square(centred).sum(axis=-1) - count * offset * offset) / (count - 1), 0.0)
    location = median[..., 0] + offset
    spread = np.maximum(np.maximum(np.sqrt(variance), RELATIVE_FLOOR * np.abs(location)), 1e-300)
    return Reference(location, spread, count.astype(np.float64))


def _check_band(robust_sigmas: float) -> None:
    if not robust_sigmas >= 1.0:  # NaN too
        raise ValueError(
            f"robust_sigmas: {robust_sigmas!r}; expected at least 1 (the band then keeps at least the half "
            "of the values within one MAD of their median), or inf to keep them all"
        )


def standardised(
    values: npt.ArrayLike,
    *,
    first: int = BASELINE_RECORDINGS,
    lag: int = LAG,
    robust_sigmas: float = ROBUST_SIGMAS,
) -> FloatArray:
    """Each value from ``first`` on standardised by the values up to ``lag`` before it (module docstring).

    Parameters
    ----------
    values : array_like
        In order on the last axis; any leading axes are series of their own [any unit].
    first : int, optional
        The first value standardised; the ones before it are the baseline period (at least 3).
    lag : int, optional
        Recordings between a value and the newest value of its estimates.
    robust_sigmas : float, optional
        Values of the history farther than this from its median are left out of the estimates
        (:func:`reference`); ``inf``: none [-].

    Returns
    -------
    ndarray
        ``u`` of each value, of the values' shape; NaN before ``first`` [-].
    """
    _check_band(robust_sigmas)
    x = np.asarray(values, dtype=np.float64)
    u = np.full(x.shape, np.nan)
    size = x.shape[-1] if x.ndim else 0
    if size <= first:
        return u
    location, spread, count = (np.empty((*x.shape[:-1], size - first)) for _ in range(3))
    if x.ndim == 1:  # one series, its history kept in order as it grows: no sort per value
        for n, grown in enumerate(_growing(x, first=first, lag=lag, robust_sigmas=robust_sigmas)):
            location[n], spread[n], count[n] = grown
    else:
        for n in range(first, size):
            ref = reference(x[..., : max(first, n - lag)], robust_sigmas=robust_sigmas)
            location[..., n - first], spread[..., n - first] = ref.location, ref.spread
            count[..., n - first] = ref.count
    t = (x[..., first:] - location) / (spread * np.sqrt(1.0 + 1.0 / count))
    u[..., first:] = np.clip(ndtri(stdtr(count - 1.0, t)), -_FAR, _FAR)
    return u


def _growing(
    x: FloatArray, *, first: int, lag: int, robust_sigmas: float
) -> Iterator[tuple[float, float, float]]:
    """:func:`reference` of ``x[:max(first, n - lag)]`` for each ``n`` from ``first`` on, as its
    ``(location, spread, count)``: the history kept sorted as values join it, its median and MAD read
    from the middle outwards, the values left out walked off its ends."""
    origin = float(x[0])  # sums of values near the first: no cancellation in the spread
    ordered: list[float] = []
    total = squares = 0.0
    for n in range(first, x.size):
        c = max(first, n - lag)
        for value in x[len(ordered) : c].tolist():
            bisect.insort(ordered, value)
            total, squares = total + (value - origin), squares + (value - origin) ** 2
        half = c // 2
        median = ordered[half] if c % 2 else 0.5 * (ordered[half - 1] + ordered[half])
        deviations: list[float] = []  # from the median, increasing: the two sides merged
        low, high = half - 1, half
        while len(deviations) <= half:
            left = median - ordered[low] if low >= 0 else math.inf
            right = ordered[high] - median if high < c else math.inf
            if left <= right:
                deviations.append(left)
                low -= 1
            else:
                deviations.append(right)
                high += 1
        mad = deviations[half] if c % 2 else 0.5 * (deviations[half - 1] + deviations[half])
        band = robust_sigmas * 1.4826 * c / (c - 0.8) * mad if mad > 0.0 else math.inf
        start, stop = 0, c
        while abs(ordered[start] - median) > band:
            start += 1
        while abs(ordered[stop - 1] - median) > band:
            stop -= 1
        left_out = ordered[:start] + ordered[stop:]
        kept = stop - start
        offset = (total - sum(v - origin for v in left_out)) / kept
        variance = (squares - sum((v - origin) ** 2 for v in left_out) - kept * offset * offset) / (kept - 1)
        mean = origin + offset
        yield mean, max(math.sqrt(max(variance, 0.0)), RELATIVE_FLOOR * abs(mean), 1e-300), float(kept)


_FAR = 8.0  # |u| at most this: a value the t distribution puts beyond double precision stays finite


def drift(
    times: Sequence[datetime],
    values: Sequence[float],
    *,
    quantity: str = "",
    unit: str = "",
    baseline: int = BASELINE_RECORDINGS,
    decision: float = DECISION,
    robust_sigmas: float = ROBUST_SIGMAS,
) -> Drift | None:
    """The first drift of a quantity after its baseline period, or None.

    Parameters
    ----------
    times : sequence of datetime
        Recording times, in order.
    values : sequence of float
        The quantity at each [unit].
    quantity, unit : str, optional
        For the finding.
    baseline : int, optional
        Recordings of the baseline period (the first ones; at least 3).
    decision : float, optional
        H [-].
    robust_sigmas : float, optional
        The band of the history kept for its estimates (:func:`reference`); ``inf``: all of it [-].

    Returns
    -------
    Drift or None
        None when there are no more recordings than the baseline period's, or no drift.
    """
    x = np.asarray(values, dtype=np.float64)
    baseline = max(baseline, 3)
    if x.size <= baseline:
        return None
    upper, lower = cusum(standardised(x, first=baseline, robust_sigmas=robust_sigmas)[baseline:])
    found = [
        (int(np.flatnonzero(sums > decision)[0]), sums, direction)
        for sums, direction in ((upper, "up"), (lower, "down"))
        if np.any(sums > decision)
    ]
    if not found:
        return None
    at, sums, direction = min(found, key=lambda f: f[0])
    zeros = np.flatnonzero(sums[:at] == 0.0)
    start = baseline + (int(zeros[-1]) + 1 if zeros.size else 0)  # the change's first recording
    before = reference(x[:start], robust_sigmas=robust_sigmas)  # its faults left out, as in the rule
    mu, sigma = float(before.location), float(before.spread)
    shift = float(x[start : baseline + at + 1].mean() - mu)
    return Drift(
        quantity, unit, direction, times[baseline + at], times[start], shift, shift / sigma, mu, sigma
    )
