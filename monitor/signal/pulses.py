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

__all__ = [
    "EdgeDetection",
    "KeyphasorRepair",
    "SignalError",
    "detect_edges",
    "repair_keyphasor",
]

FloatArray = npt.NDArray[np.float64]


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
    signal fell below the current pulse's level since its top (hysteresis);
    otherwise it belongs to it, so a notched or noisy flat top stays one
    pulse. A pulse's level is ``valley + level (top - valley)`` with the valley
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
    candidates, _ = find_peaks(x, prominence=prominence)
    if candidates.size < 2:
        raise SignalError(f"fewer than two pulses with prominence {prominence:.4g} found: check the channel")
    # lowest sample before each candidate (from the previous one, or the record start) and after the last
    valley_index = np.empty(candidates.size + 1, dtype=np.int64)
    bounds = np.concatenate([[0], candidates, [x.size - 1]])
    for k in range(bounds.size - 1):
        valley_index[k] = bounds[k] + int(np.argmin(x[bounds[k] : bounds[k + 1] + 1]))
    # hysteresis: a candidate starts a new pulse only if the signal fell below the current pulse's
    # mid level since its top; otherwise it is part of it (a notched or noisy top)
    groups: list[list[int]] = []  # [first candidate, top candidate, valley before, valley after]
    for k, peak in enumerate(candidates):
        if groups:
            first, top, before, _ = groups[-1]
            base = x[before]
            mid = base + level * (min(x[candidates[top]], x[peak]) - base)
            if x[valley_index[k]] >= mid:  # never went below the level: same pulse
                if x[peak] > x[candidates[top]]:
                    groups[-1][1] = k
                groups[-1][3] = int(valley_index[k + 1])
                continue
        groups.append([k, k, int(valley_index[k]), int(valley_index[k + 1])])
    times = np.full(len(groups), np.nan)
    levels = np.empty(len(groups))
    swings = np.empty(len(groups))
    for g, (first, top, before, after) in enumerate(groups):
        peak = int(candidates[top])
        trough = before if direction == "rising" else after
        levels[g] = x[trough] + level * (x[peak] - x[trough])
        swings[g] = x[peak] - x[trough]
        lev = levels[g]
        if direction == "rising":
            below = np.flatnonzero(x[trough : int(candidates[first]) + 1] < lev)
            if below.size == 0:
                continue  # cut by the start of the record: its edge is not in it
            j = trough + int(below[-1])  # last sample below the level before the pulse's top
        else:
            last = int(candidates[groups[g][1]])
            tail = x[last : after + 1]
            crossing = np.flatnonzero(tail < lev)
            if crossing.size == 0:
                continue  # cut by the end of the record
            j = last + int(crossing[0]) - 1  # last sample at or above the level
        a, b = x[j] - lev, x[j + 1] - lev
        times[g] = j + (a / (a - b) if a != b else 0.0)
    whole = np.isfinite(times)
    if np.count_nonzero(whole) < 2:
        raise SignalError("fewer than two whole pulses in the record")
    return EdgeDetection(start_time + times[whole] / sample_rate, levels[whole], swings[whole])


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
