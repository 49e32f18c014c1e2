"""Pulse edges with hysteresis and sub-sample timing, and keyphasor repair.

Edges.  Every pulse gets its own threshold: pulses are found as peaks
rising at least a minimum prominence above their surroundings (the
hysteresis), and each is timed where it crosses the mid level between its
own trough and its own peak, interpolated between the two samples around
the crossing (sub-sample timing).  A variable-reluctance sensor whose
amplitude falls with speed, and a single weak tooth beside strong ones
(the tooth after a tooth wheel's gap), both keep their edges.

Keyphasor.  One pulse per revolution; a missing pulse leaves an interval
of about two revolutions, an extra pulse splits one.  Repair works on the
intervals against a running median: extra pulses are removed, missing ones
inserted by interpolation, and every repair is reported.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt
from scipy.ndimage import median_filter

from monitor.errors import MonitorError
from monitor.types import FloatArray

__all__ = [
    "EdgeDetection",
    "KeyphasorRepair",
    "SignalError",
    "detect_edges",
    "repair_keyphasor",
]


class SignalError(MonitorError, ValueError):
    """A signal cannot be decoded as asked (no pulses, no gap, inconsistent pulse train)."""


@dataclass(frozen=True)
class EdgeDetection:
    """Edges found in a pulse signal.

    Attributes
    ----------
    times : ndarray
        Edge times, sub-sample [s].
    levels : ndarray
        The level each edge was timed at (its own pulse's mid level), in the signal's unit.
    swings : ndarray
        Each pulse's height above its trough, in the signal's unit.
    """

    times: FloatArray
    levels: FloatArray
    swings: FloatArray


def detect_edges(
    signal: npt.ArrayLike,
    sample_rate: float,
    *,
    start_time: float = 0.0,
    direction: Literal["rising", "falling"] = "rising",
    level: float = 0.5,
    min_prominence: float | None = None,
) -> EdgeDetection:
    """Edges of a pulse train, each timed at its own pulse's mid level.

    Parameters
    ----------
    signal : array_like, shape (n,)
        Sensor waveform [V or the channel's unit].
    sample_rate : float
        [Hz].
    start_time : float, optional
        Time of the first sample [s].
    direction : {"rising", "falling"}
        Which edge of each pulse to time.
    level : float, optional
        Where on the pulse the edge is timed, as a fraction from its trough to its peak [-].
    min_prominence : float, optional
        Smallest rise of a pulse above its surroundings [signal unit]; it acts as
        the hysteresis. Default: 5 % of the signal's peak-to-peak range.

    Returns
    -------
    EdgeDetection

    Raises
    ------
    SignalError
        If the signal is empty, not finite, flat, or has fewer than two pulses.

    Notes
    -----
    Candidate peaks are those whose prominence exceeds ``min_prominence``
    (``scipy.signal.find_peaks``). A candidate starts a new pulse only if the
    signal fell below the level of the pulse before it (hysteresis, measured
    from the lowest of the preceding valleys); otherwise it belongs to it, so
    a notched or noisy flat top stays one pulse. All of it is vectorised
    (``reduceat`` over the stretches between candidates): a long recording
    costs a few array passes. A pulse's level is ``valley + level (top - valley)`` with the valley
    before it (after it, for falling edges); the edge is where the signal
    crosses that level on the way up (down), interpolated linearly between
    the two samples around the crossing. A pulse with its own threshold keeps
    a weak tooth beside strong ones (the tooth after a tooth wheel's gap) and
    follows an amplitude that falls with speed.
    """
    from scipy.signal import find_peaks

    x = np.asarray(signal, dtype=np.float64)
    if x.ndim != 1 or x.size < 8:
        raise SignalError(f"signal has shape {x.shape}: expected a 1-D waveform of at least 8 samples")
    if not np.all(np.isfinite(x)):
        bad = int(np.count_nonzero(~np.isfinite(x)))
        raise SignalError(f"signal has {bad} NaN or Inf samples: mask or repair them before edge detection")
    if not sample_rate > 0:
        raise SignalError(f"sample_rate = {sample_rate!r}: expected a positive rate [Hz]")
    if not 0 < level < 1:
        raise SignalError(f"level = {level!r}: expected a fraction between 0 and 1")
    # the whole swing: a keyphasor's pulses can fill well under 1 % of the samples
    low_p, high_p = float(np.min(x)), float(np.max(x))
    if not high_p > low_p:
        raise SignalError("signal is flat: no pulses to detect")
    prominence = 0.05 * (high_p - low_p) if min_prominence is None else float(min_prominence)
    # the prominence search walks from each peak to a higher sample: with equal flat tops (a clipped
    # or quantised pulse train) that is the whole record each time. Bound it to a few pulse spacings,
    # estimated from the rising passages through a band around the middle of the swing.
    spacing = _pulse_spacing(x, low_p, high_p)
    window = int(min(x.size, max(8.0, 6.0 * spacing))) | 1
    candidates, _ = find_peaks(x, prominence=prominence, wlen=window)
    if candidates.size < 2:
        raise SignalError(f"fewer than two pulses with prominence {prominence:.4g} found: check the channel")
    times, levels, swings = _time_pulses(x, candidates, level, direction)
    whole = np.isfinite(times)
    if np.count_nonzero(whole) < 2:
        raise SignalError("fewer than two whole pulses in the record")
    return EdgeDetection(start_time + times[whole] / sample_rate, levels[whole], swings[whole])


def _pulse_spacing(x: FloatArray, low: float, high: float) -> float:
    """Median samples between rising passages through the band 40-60 % of the swing (noise-immune)."""
    marks = np.zeros(x.size, dtype=np.int8)
    marks[x > low + 0.6 * (high - low)] = 1
    marks[x < low + 0.4 * (high - low)] = -1
    last = np.where(marks != 0, np.arange(x.size), 0)
    np.maximum.accumulate(last, out=last)
    state = marks[last]
    rising = np.flatnonzero((state[1:] == 1) & (state[:-1] == -1))
    return float(np.median(np.diff(rising))) if rising.size >= 2 else float(x.size)


def _segment_starts(lengths: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    return np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(np.int64)


def _time_pulses(
    x: FloatArray, candidates: npt.NDArray[np.int64], level: float, direction: str, window: int = 8
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Group candidate peaks into pulses (hysteresis) and time each pulse's edge, without Python loops.

    The lowest sample between consecutive candidates is each candidate's valley. Candidate ``k``
    joins the pulse before it unless the valley between them fell below that pulse's level,
    measured from the lowest of the ``window`` preceding valleys (a notched or noisy top stays one
    pulse). Each pulse's edge is the last sample below its level before its first candidate
    (rising) or the first sample below it after its top (falling), interpolated between samples.
    Returns edge times in samples (NaN where the record cuts the edge off), levels and swings.
    """
    n, m = x.size, candidates.size
    bounds = np.concatenate([[0], candidates, [n - 1]]).astype(np.int64)
    valley = np.minimum.reduceat(x, bounds[:-1])
    stretch = np.diff(np.concatenate([bounds[:-1], [n]]))
    owner = np.repeat(np.arange(m + 1), stretch)
    index = np.arange(n)
    valley_index = np.minimum.reduceat(np.where(x == valley[owner], index, n), bounds[:-1])
    height = x[candidates]
    base = valley[:-1].copy()
    for shift in range(1, window):
        base[shift:] = np.minimum(base[shift:], valley[:-1][:-shift])
    previous_top = np.concatenate([[np.inf], height[:-1]])
    mid = base + level * (np.minimum(previous_top, height) - base)
    merged = np.zeros(m, dtype=bool)
    merged[1:] = valley[1:m] >= mid[1:]
    group = np.cumsum(~merged) - 1
    first = np.flatnonzero(~merged)
    last = np.concatenate([first[1:] - 1, [m - 1]])
    top_height = np.maximum.reduceat(height, first)
    top = np.minimum.reduceat(np.where(height == top_height[group], np.arange(m), m), first)
    trough = valley_index[first] if direction == "rising" else valley_index[last + 1]
    levels = x[trough] + level * (x[candidates[top]] - x[trough])
    swings = x[candidates[top]] - x[trough]
    if direction == "rising":
        start, stop = trough, candidates[first]
    else:
        start, stop = candidates[top], valley_index[last + 1]
    lengths = (stop - start + 1).astype(np.int64)
    starts = _segment_starts(lengths)
    pulse = np.repeat(np.arange(first.size), lengths)
    positions = np.repeat(start - starts, lengths) + np.arange(int(lengths.sum()))
    below = x[positions] < levels[pulse]
    if direction == "rising":
        j = np.maximum.reduceat(np.where(below, positions, -1), starts)
        whole = j >= 0
    else:
        after = np.minimum.reduceat(np.where(below, positions, n + 1), starts)
        whole = after <= n - 1
        j = after - 1
    j = np.where(whole, j, 0)
    a = x[j] - levels
    b = x[np.minimum(j + 1, n - 1)] - levels
    fraction = np.where(a != b, a / np.where(a != b, a - b, 1.0), 0.0)
    return np.where(whole, j + fraction, np.nan), levels, swings


@dataclass(frozen=True)
class KeyphasorRepair:
    """Once-per-revolution pulse times after repair, and what was repaired.

    Attributes
    ----------
    times : ndarray
        Pulse times, one per revolution [s].
    inserted : ndarray
        Times of pulses inserted for missing ones [s].
    removed : ndarray
        Times of extra pulses removed [s].
    """

    times: FloatArray
    inserted: FloatArray = field(default_factory=lambda: np.empty(0))
    removed: FloatArray = field(default_factory=lambda: np.empty(0))

    @property
    def repaired(self) -> bool:
        """True if any pulse was inserted or removed."""
        return bool(self.inserted.size or self.removed.size)


def repair_keyphasor(times: npt.ArrayLike, *, window: int = 9, max_missing: int = 3) -> KeyphasorRepair:
    """Remove extra and insert missing once-per-revolution pulses.

    Parameters
    ----------
    times : array_like
        Detected pulse times, increasing [s].
    window : int, optional
        Pulses in the running median of the revolution period.
    max_missing : int, optional
        Most consecutive missing pulses that are filled in; a longer gap is an error.

    Returns
    -------
    KeyphasorRepair

    Raises
    ------
    SignalError
        With fewer than 4 pulses, non-increasing times, or a gap longer than ``max_missing``.

    Notes
    -----
    An interval shorter than 0.6 of the local median period marks an extra
    pulse: of the two pulses bounding it, the one whose removal leaves the
    interval nearest the median is dropped.  An interval of about ``m + 1``
    median periods (within +-0.3 of a period) has ``m`` missing pulses, inserted
    evenly.  The speed may vary; the median follows it.
    """
    t = np.asarray(times, dtype=np.float64)
    if t.ndim != 1 or t.size < 4:
        raise SignalError(f"keyphasor has {t.size} pulses: expected at least 4")
    if np.any(np.diff(t) <= 0):
        first = int(np.flatnonzero(np.diff(t) <= 0)[0])
        raise SignalError(
            f"keyphasor: pulse {first + 1} at {t[first + 1]:.9g} s does not follow pulse "
            f"{first} at {t[first]:.9g} s: expected increasing times"
        )
    removed: list[float] = []
    kept = list(t)
    changed = True
    while changed:  # remove extra pulses one at a time, worst first
        changed = False
        arr = np.asarray(kept)
        dt = np.diff(arr)
        ref = median_filter(dt, size=min(window, dt.size), mode="nearest")
        short = np.flatnonzero(dt < 0.6 * ref)
        if short.size:
            i = int(short[np.argmin(dt[short] / ref[short])])
            # candidates: drop arr[i] or arr[i + 1]; keep the one whose neighbours' interval fits best
            options = []
            for drop in (i, i + 1):
                if 0 < drop < arr.size - 1:
                    options.append(
                        (abs((arr[drop + 1] - arr[drop - 1]) / ref[min(i, ref.size - 1)] - 1), drop)
                    )
            drop = min(options)[1] if options else (i + 1 if i + 1 < arr.size else i)
            removed.append(float(arr[drop]))
            del kept[drop]
            changed = True
    arr = np.asarray(kept)
    dt = np.diff(arr)
    ref = median_filter(dt, size=min(window, dt.size), mode="nearest")
    inserted: list[float] = []
    out: list[float] = [float(arr[0])]
    for i, interval in enumerate(dt):
        ratio = interval / ref[i]
        m = round(ratio) - 1
        if m >= 1 and abs(ratio - (m + 1)) < 0.3:
            if m > max_missing:
                raise SignalError(
                    f"keyphasor: {m} consecutive pulses missing after t = {arr[i]:.6g} s "
                    f"(more than max_missing = {max_missing})"
                )
            for j in range(1, m + 1):
                inserted.append(float(arr[i] + interval * j / (m + 1)))
                out.append(inserted[-1])
        elif ratio > 1.5:
            raise SignalError(
                f"keyphasor: interval of {ratio:.2f} revolutions after t = {arr[i]:.6g} s "
                "is not a whole number of missing pulses"
            )
        out.append(float(arr[i + 1]))
    return KeyphasorRepair(np.asarray(out), np.asarray(inserted), np.asarray(removed))
