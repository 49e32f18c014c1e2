"""A fixed sample rate from written times, within their rounding (see :mod:`monitor.io.imports`).

A least-squares line of time against sample index, whose deviations must stay within the rounding of
the written times; times with a gap or jitter beyond that are refused with the row named.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np

from monitor.errors import FormatError

__all__ = [
    "BLOCK_ROWS",
    "RATE_HINT",
    "Rounding",
    "fixed_rate",
    "grid_rounding",
    "printed_rounding",
    "significant_digits",
]

BLOCK_ROWS = 1 << 16  # rows per block, when reading text and when checking times


RATE_HINT = "give the rate (sample_rate_hz in the mapping, or --rate) if it is known"


@dataclass(frozen=True)
class Rounding:
    """How coarsely times were written, which bounds their deviation from the fixed-rate line.

    ``step`` [s] is the finest step of the written numbers (fixed decimals, a
    decimal grid); ``significant`` the significant digits of numbers written in
    exponent or ``%g`` style (0: none); ``stated`` [s] the mapping's bound,
    which replaces both.
    """

    step: float = 0.0
    significant: int = 0
    stated: float | None = None

    def half(self, t: np.ndarray) -> np.ndarray:
        """Half the step of the written numbers at times t [s]: how far rounding moved them [s]."""
        half = np.full(t.shape, 0.5 * self.step)
        if self.significant:
            magnitude = np.floor(np.log10(np.maximum(np.abs(t), np.finfo(np.float64).tiny)))
            half = np.maximum(half, 0.5 * 10.0 ** (magnitude - self.significant + 1))
        return half

    def slack(self, t: np.ndarray) -> float:
        """How far [s] the least-squares line through times t can be off the true one, by their rounding.

        Its standard deviation is at most about 1.2 h / sqrt(n), at the ends of a
        record of n times rounded by at most h; the slack is about four of those.
        """
        if self.stated is not None:
            return 0.0  # a stated bound is on the deviation from the fitted line
        largest = float(self.half(np.array([_largest(t)]))[0])
        return 5.0 * largest / math.sqrt(t.size)

    def limit(self, t: np.ndarray, slack: float) -> np.ndarray:
        """Largest deviation [s] from the fitted line that the rounding explains at times t; slack [s]."""
        floor = 8 * np.finfo(np.float64).eps * np.abs(t)  # parsing and arithmetic
        if self.stated is not None:
            return floor + self.stated
        return floor + self.half(t) + slack


def _largest(t: np.ndarray) -> float:
    """The largest magnitude of times t [s], without a temporary array."""
    return max(abs(float(t.min())), abs(float(t.max())))


_NUMBER = re.compile(r"[+-]?(\d*)(?:\.(\d*))?(?:[eE]([+-]?\d+))?")


def significant_digits(text: str) -> int:
    """Significant digits of a written number (0 if it is not one).

    Parameters
    ----------
    text : str
        A number as written in a file, e.g. ``"0.00125"`` or ``"1.25e-3"`` (surrounding blanks ignored).

    Returns
    -------
    int
        Its digits without leading zeros, the exponent left out: 3 for both examples.
    """
    match = _NUMBER.fullmatch(text.strip())
    return len((match.group(1) + (match.group(2) or "")).lstrip("0")) if match else 0


def printed_rounding(texts: Iterable[str]) -> Rounding:
    """The rounding of times written as text: the most decimals and the most significant digits seen.

    Parameters
    ----------
    texts : iterable of str
        Times as written in the file [the time column's unit], e.g. a sample of its rows; entries that
        are not numbers are skipped.

    Returns
    -------
    Rounding
        ``step`` the finest decimal step seen [the time column's unit] (0 if no number), ``significant``
        the most significant digits seen.
    """
    decimals: int | None = None
    significant = 0
    for text in texts:
        match = _NUMBER.fullmatch(text.strip())
        if not match or not (match.group(1) or match.group(2)):
            continue
        fraction = match.group(2) or ""
        significant = max(significant, significant_digits(text))
        places = len(fraction) - int(match.group(3) or 0)
        decimals = places if decimals is None else max(decimals, places)
    return Rounding(step=10.0**-decimals if decimals is not None else 0.0, significant=significant)


def grid_rounding(t: np.ndarray) -> Rounding:
    """Binary time stamps: the coarsest decimal grid, at most a tenth of the sample interval, they lie on.

    Parameters
    ----------
    t : ndarray
        Time stamps, shape (n,), increasing [s].

    Returns
    -------
    Rounding
        ``step`` the grid [s], but no finer than 2e-6 of the mean sample interval (that alone for
        stamps on no decimal grid); ``Rounding()`` for fewer than two times or times that do not increase.
    """
    interval = float(t[-1] - t[0]) / (t.size - 1) if t.size > 1 else 0.0
    if not (math.isfinite(interval) and interval > 0):
        return Rounding()
    largest = _largest(t)
    for exponent in range(math.floor(math.log10(interval / 10)), -13, -1):
        grid = 10.0**exponent
        if largest / grid > 1e12:  # float64 cannot tell a grid this fine
            break
        if all(_on_grid(t[s : s + BLOCK_ROWS], grid) for s in range(0, t.size, BLOCK_ROWS)):
            return Rounding(step=max(grid, 2e-6 * interval))
    return Rounding(step=2e-6 * interval)


def _on_grid(t: np.ndarray, grid: float) -> bool:
    steps = t / grid
    return bool(np.all(np.abs(steps - np.rint(steps)) <= 1e-3))


def _off_line(
    t: np.ndarray, period: float, centre: float, rounding: Rounding, row: Callable[[int], str]
) -> str | None:
    """Where times t [s] leave the line of the given period [s] through their centre, beyond the rounding."""
    n = t.size
    slack = rounding.slack(t)
    for s in range(0, n - 1, BLOCK_ROWS):
        seg = t[s : s + BLOCK_ROWS + 1]
        limit = rounding.limit(seg, slack)
        steps = np.diff(seg)
        allowed = limit[:-1] + limit[1:]
        bad = np.flatnonzero(np.abs(steps - period) > allowed)
        if bad.size:
            k = int(bad[0])
            return (
                f"at {row(s + k + 1)} the time steps by {steps[k]:.6g} s where {period:.6g} s is expected "
                f"(the rounding of the times allows {allowed[k]:.2g} s either way)"
            )
    middle = (n - 1) / 2
    for s in range(0, n, BLOCK_ROWS):
        seg = t[s : s + BLOCK_ROWS]
        limit = rounding.limit(seg, slack)
        residual = (seg - centre) - period * (np.arange(s, s + seg.size) - middle)
        bad = np.flatnonzero(np.abs(residual) > limit)
        if bad.size:
            k = int(bad[0])
            return (
                f"at {row(s + k)} the time {seg[k]:.9g} s is {residual[k]:.3g} s off the line of a fixed "
                f"rate ({1 / period:.9g} Hz), more than the rounding of the times allows ({limit[k]:.2g} s)"
            )
    return None


def fixed_rate(t: np.ndarray, rounding: Rounding, where: str, row: Callable[[int], str]) -> float:
    """The sample rate [Hz] of times t [s] written with a rounding; refuses gaps and jitter beyond it.

    Parameters
    ----------
    t : ndarray
        Time of each sample, shape (n,) [s].
    rounding : Rounding
        How coarsely the times were written (:func:`printed_rounding`, :func:`grid_rounding`, or the
        mapping's ``time_tolerance_s``), which bounds their deviation from a fixed rate.
    where : str
        The file and channel or time column, named in a refusal.
    row : callable
        Sample index -> where it is in the file (``"line 12"``, ``"sample 10"``), named in a refusal.

    Returns
    -------
    float
        The least-squares rate [Hz]; the nearest whole number of Hz where the times fit that as well.

    Raises
    ------
    FormatError
        For fewer than two samples, a time that is not finite, times that do not increase, or a gap or
        jitter beyond the rounding (naming the row).
    """
    n = t.size
    if n < 2:
        raise FormatError(f"{where}: fewer than two samples, so no rate can be derived; {RATE_HINT}")
    finite = np.isfinite(t)
    if not finite.all():
        k = int(np.argmin(finite))
        raise FormatError(f"{where}: the time at {row(k)} is {t[k]}; expected a finite time")
    middle = (n - 1) / 2
    centre = float(np.mean(t))
    covariance = 0.0
    for s in range(0, n, BLOCK_ROWS):
        seg = t[s : s + BLOCK_ROWS]
        covariance += float(np.dot(np.arange(s, s + seg.size) - middle, seg - centre))
    period = covariance / (n * (n * n - 1.0) / 12.0)
    if not (math.isfinite(period) and period > 0):
        raise FormatError(f"{where} is not sampled at a fixed rate: the time does not increase; {RATE_HINT}")
    off = _off_line(t, period, centre, rounding, row)
    if off is not None:
        raise FormatError(
            f"{where} is not sampled at a fixed rate: {off}; {RATE_HINT}, "
            "or time_tolerance_s if the times were written more coarsely"
        )
    whole = round(1.0 / period)
    if whole >= 1 and _off_line(t, 1.0 / whole, centre, rounding, row) is None:
        return float(whole)
    return 1.0 / period
