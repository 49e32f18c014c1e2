"""Pulse edges with hysteresis and sub-sample timing, and keyphasor repair.

Two timing points, for the two kinds of pulse sensor:

- ``"mid-level"`` (Hall sensors, optical pick-ups, square pulses): each
  pulse is timed where it crosses the level halfway between its own trough
  and its own top (below);
- ``"zero-crossing"`` (variable-reluctance sensors: a zero-mean voltage,
  sine-like per tooth, its amplitude proportional to speed): each tooth is
  timed where the signal crosses its baseline on the flank named by
  ``direction``, once the lobe before that flank has risen above an arming
  threshold.  The threshold follows the local amplitude (``arm`` times the
  median of the last five lobes' peaks, never below ``NOISE_MARGIN`` times
  the noise's rms), the way engine controllers' VR interfaces arm
  themselves; the baseline (the block's mean: the flux's rate of change
  averages to the channel's offset) is the same for every tooth, so the tooth
  after a wheel's gap is timed like the others even though the gap sits at
  another level.

Mid-level edges.  Every pulse gets its own threshold: pulses are found as tops
rising at least a minimum prominence above the trough before them and
falling as much after them (the hysteresis), and each is timed where it crosses the mid level between its
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

import math
import os
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Literal

import numba
import numpy as np
import numpy.typing as npt
from scipy.ndimage import median_filter

from monitor.errors import SignalError
from monitor.types import FloatArray

__all__ = [
    "EXTRA_BELOW",
    "EdgeDetection",
    "KeyphasorRepair",
    "detect_edges",
    "detect_pulses",
    "repair_keyphasor",
]


@dataclass(frozen=True)
class EdgeDetection:
    """Edges found in a pulse signal.

    Attributes
    ----------
    times : ndarray
        Edge times, sub-sample [s].
    levels : ndarray
        The level each edge was timed at (its own pulse's mid level, or the baseline), in the
        signal's unit.
    swings : ndarray
        Each pulse's height above its trough (zero-crossing timing: its lobe's peak above the
        baseline), in the signal's unit.
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
    timing: Literal["mid-level", "zero-crossing"] = "mid-level",
    arm: float = 0.3,
) -> EdgeDetection:
    """Edges of a pulse train, each timed at its own pulse's mid level or at a baseline crossing.

    Parameters
    ----------
    signal : array_like or sliceable, shape (n,)
        Sensor waveform [V or the channel's unit]; float32 is used as it is (no
        copy). A long waveform (an array or anything with ``shape`` and slicing,
        such as an h5py dataset) is read in blocks of 2^20 samples.
    sample_rate : float
        [Hz].
    start_time : float, optional
        Time of the first sample [s].
    direction : {"rising", "falling"}
        Which edge of each pulse to time (zero-crossing timing: the flank crossing the baseline
        upwards or downwards).
    level : float, optional
        Mid-level timing: where on the pulse the edge is timed, as a fraction from its trough to
        its peak [-].
    min_prominence : float, optional
        Smallest rise of a pulse above its trough, and fall after its top [signal
        unit]; it acts as the hysteresis. Default: 5 % of the signal's peak-to-peak range
        (of each block's, on a long waveform: it follows a slowly changing amplitude), or
        ``NOISE_MARGIN`` (8) times the noise's rms if that is more, up to a quarter of the range
        (the noise estimated from the lower quartile of the absolute differences of neighbouring
        samples, which the flat parts of a pulse train give). Zero-crossing timing: the smallest
        arming threshold; default ``NOISE_MARGIN`` times the noise's rms (estimated from third
        differences in the quietest stretch of the block, where a slowly turning VR sensor's own
        waveform leaves only the noise).
    timing : {"mid-level", "zero-crossing"}
        The timing point (see the module docstring): a pulse's mid level (Hall, square pulses) or
        the baseline crossing of a variable-reluctance waveform.
    arm : float, optional
        Zero-crossing timing: the arming threshold as a fraction of the median peak of the last five
        lobes [-].

    Returns
    -------
    EdgeDetection

    Raises
    ------
    SignalError
        If the signal is empty, not finite, flat, or has fewer than two pulses.

    Notes
    -----
    One pass over the samples (compiled with numba, a few nanoseconds per
    sample) alternates between seeking a top and seeking a trough: a top is
    confirmed when the signal has fallen ``min_prominence`` below it and
    below the pulse's own level, a trough when the signal has risen
    ``min_prominence`` above it. A notched or noisy flat top whose dips stay
    above the pulse's level stays one pulse.
    A pulse's level is ``trough + level (top - trough)`` with the trough
    before it (after it, for falling edges); the edge is where the signal
    crosses that level on the way up (down), interpolated linearly between
    the two samples around the crossing. A pulse with its own level keeps a
    weak tooth beside strong ones (the tooth after a tooth wheel's gap) and
    follows an amplitude that falls with speed.
    """
    source: Any = (
        signal if hasattr(signal, "shape") and hasattr(signal, "__getitem__") else np.asarray(signal)
    )
    _check_edge_options(source, sample_rate, level, min_prominence, timing, arm)
    n = int(source.shape[0])
    rising = direction == "rising"
    crossing = timing == "zero-crossing"

    def block_edges(x: npt.ArrayLike) -> _BlockEdges:
        if crossing:
            return _block_crossings(x, min_prominence, arm, rising)
        return _block_edges(x, min_prominence, level, rising)

    if n <= _EDGE_BLOCK:
        times, levels, swings, prominence = block_edges(source[:])
    else:
        times, levels, swings, prominence = _edges_by_blocks(source, n, block_edges)
    if prominence == 0.0 and times.size == 0:
        raise SignalError("signal is flat: no pulses to detect")
    if times.size < 2:
        raise SignalError(
            f"fewer than two whole pulses with prominence {prominence:.4g} found: check the channel"
        )
    return EdgeDetection(start_time + times / sample_rate, levels, swings)


#: A block's edge times [samples of the block], levels and swings, and the prominence it used.
_BlockEdges = tuple[FloatArray, FloatArray, FloatArray, float]


def _check_edge_options(
    source: Any, sample_rate: float, level: float, min_prominence: float | None, timing: str, arm: float
) -> None:
    """Refuse what :func:`detect_edges` cannot time edges with."""
    if len(source.shape) != 1 or source.shape[0] < 8:
        raise SignalError(
            f"signal has shape {tuple(source.shape)}: expected a 1-D waveform of at least 8 samples"
        )
    if not sample_rate > 0:
        raise SignalError(f"sample_rate = {sample_rate!r}: expected a positive rate [Hz]")
    if not 0 < level < 1:
        raise SignalError(f"level = {level!r}: expected a fraction between 0 and 1")
    if min_prominence is not None and not min_prominence > 0:
        raise SignalError(f"min_prominence = {min_prominence!r}: expected a positive height")
    if timing not in ("mid-level", "zero-crossing"):
        raise SignalError(f"timing = {timing!r}: expected 'mid-level' or 'zero-crossing'")
    if not 0 < arm < 1:
        raise SignalError(f"arm = {arm!r}: expected a fraction between 0 and 1")


def _edges_by_blocks(source: Any, n: int, block_edges: Callable[[npt.ArrayLike], _BlockEdges]) -> _BlockEdges:
    """The edges of a long waveform, found block by block; the prominence is the first block's.

    Blocks with context on both sides; each keeps the edges inside its own span. The hysteresis state
    is the whole record's again after a pulse or two of context: take several spacings.
    """
    first, _, _, prominence = block_edges(source[:_EDGE_BLOCK])
    spacing = float(np.median(np.diff(first))) if first.size > 2 else _EDGE_BLOCK / 8
    context = int(min(_EDGE_BLOCK // 4, max(1024, 8 * spacing)))

    def keep(a: int, lo: int, part: _BlockEdges) -> None:
        inside = (part[0] + lo >= a) & (part[0] + lo < a + _EDGE_BLOCK)
        parts.append((part[0][inside] + lo, part[1][inside], part[2][inside]))

    # read in order here (a reader by slices moves forward), find the edges in parallel threads (the
    # compiled pass releases the GIL), a few blocks in flight
    workers = os.cpu_count() or 1
    parts: list[tuple[FloatArray, FloatArray, FloatArray]] = []
    pending: deque[tuple[int, int, Future[_BlockEdges]]] = deque()
    with ThreadPoolExecutor(max_workers=workers) as pool:
        for a in range(0, n, _EDGE_BLOCK):
            lo = max(0, a - context)
            x = np.asarray(source[lo : min(n, a + _EDGE_BLOCK + context)])
            pending.append((a, lo, pool.submit(block_edges, x)))
            if len(pending) > workers:
                done = pending.popleft()
                keep(done[0], done[1], done[2].result())
        for a, lo, job in pending:
            keep(a, lo, job.result())
    times, levels, swings = (np.concatenate([p[i] for p in parts]) for i in range(3))
    return times, levels, swings, prominence


NOISE_MARGIN = 8.0  # default hysteresis over the noise's rms [-]
# a keyphasor interval shorter than this share of the local revolution's closes on an extra pulse [-]
EXTRA_BELOW = 0.6
_EDGE_BLOCK = 1 << 20  # samples per block of a long pulse waveform (4 MB of float32)


def _finite_block(block: npt.ArrayLike) -> tuple[FloatArray, float, float]:
    """A block as float32 or float64 (no copy if it is), its minimum and maximum; refused if not finite."""
    x = np.asarray(block)
    if x.dtype not in (np.float32, np.float64):
        x = x.astype(np.float64)
    low, high = float(np.min(x)), float(np.max(x))
    if not (math.isfinite(low) and math.isfinite(high)):
        bad = int(np.count_nonzero(~np.isfinite(x)))
        raise SignalError(f"signal has {bad} NaN or Inf samples: mask or repair them before edge detection")
    return x, low, high


def _block_edges(
    block: npt.ArrayLike, min_prominence: float | None, level: float, rising: bool
) -> tuple[FloatArray, FloatArray, FloatArray, float]:
    """Edges of one block in samples from its start, levels, swings, and the prominence used."""
    x, low_p, high_p = _finite_block(block)
    if not high_p > low_p:  # flat: no pulse here
        empty = np.empty(0)
        return empty, empty, empty, 0.0
    if min_prominence is None:
        # 5 % of the range, and well above the noise (up to a quarter of the range): the noise's rms
        # from the lower quartile of the absolute differences of neighbouring samples (the flat parts
        # of a pulse train), on every 8th pair; for Gaussian noise that quartile is 0.3186 sqrt(2) rms
        pairs = np.arange(1, x.size, 8)
        steps = np.abs(x[pairs].astype(np.float64) - x[pairs - 1])
        noise = float(np.percentile(steps, 25)) / (0.3186 * math.sqrt(2.0))
        swing = high_p - low_p
        prominence = max(0.05 * swing, min(NOISE_MARGIN * noise, 0.25 * swing))
    else:
        prominence = float(min_prominence)
    times, levels, swings = _timed_pulses(np.ascontiguousarray(x), prominence, level, rising)
    return times, levels, swings, prominence


def _block_crossings(
    block: npt.ArrayLike, min_arm: float | None, arm: float, rising: bool
) -> tuple[FloatArray, FloatArray, FloatArray, float]:
    """Baseline crossings of one block (VR timing), in samples from its start; baselines, peaks, floor."""
    x, low_p, high_p = _finite_block(block)
    if not high_p > low_p:
        empty = np.empty(0)
        return empty, empty, empty, 0.0
    # a VR sensor's voltage is the rate of change of its flux: over a block of many teeth it averages
    # to the channel's offset. A median sits off the offset by a share of the amplitude, which moves
    # the zero crossings by an angle that changes with speed (on the VR run-up from 150 to 750 rpm of
    # tests/signal/test_pitch_over_speed.py, mid-wheel teeth moved by about 2e-3 deg with the median and a
    # quarter of that with the mean)
    baseline = float(np.mean(x, dtype=np.float64))
    y = (x.astype(np.float64) - baseline) * (-1.0 if rising else 1.0)
    floor = float(min_arm) if min_arm is not None else NOISE_MARGIN * _quietest_noise(y)
    floor = max(floor, 1e-9 * (high_p - low_p))  # a noiseless record: above round-off only
    times, peaks = _armed_crossings(y, floor, arm)
    return times, np.full(times.size, baseline), peaks, floor


def _quietest_noise(y: FloatArray) -> float:
    """The noise's rms in the quietest of 64 stretches, from the median absolute third difference.

    White noise of rms s gives third differences of rms sqrt(20) s; a waveform sampled many times
    per period adds little to them, and the quietest stretch (a VR sensor turning slowly, or the gap)
    adds least.
    """
    if y.size < 64 * 16:
        medians = np.array([np.median(np.abs(np.diff(y, 3)))])
    else:
        # 64 stretches spread over the block, up to 4096 samples of each
        length = y.size // 64
        starts = np.arange(64) * length
        take = min(length, 4096)
        pieces = y[starts[:, None] + np.arange(take)]
        medians = np.median(np.abs(np.diff(pieces, 3, axis=1)), axis=1)
    noise = float(np.min(medians)) / (0.6745 * math.sqrt(20.0))
    if noise == 0.0:  # a quantised record whose quiet stretches do not move: a quantisation step
        steps = np.abs(np.diff(y))
        steps = steps[steps > 0]
        noise = float(np.min(steps)) if steps.size else 0.0
    return noise


@numba.njit(cache=True, nogil=True)
def _armed_crossings(
    y: FloatArray, floor: float, arm: float
) -> tuple[FloatArray, FloatArray]:  # pragma: no cover - compiled
    """Downward zero crossings of ``y``, each armed by the lobe before it rising above the threshold.

    Every lobe above the floor enters the history of peaks, armed or not, so that the threshold
    follows an amplitude that drops (a sensor gap that opens, a coast-down) within a few lobes.
    """
    n = y.size
    times = np.empty(n // 2 + 1)
    peaks = np.empty(n // 2 + 1)
    history = np.zeros(5)
    filled = 0
    count = 0
    armed = False
    peak = 0.0  # the highest sample of the current positive lobe
    threshold = floor
    for i in range(1, n):
        v = y[i]
        if v > peak:
            peak = v
        if not armed and v > threshold:
            armed = True
        if v < 0.0 <= y[i - 1]:  # the lobe ends
            if armed:
                a = y[i - 1]
                times[count] = i - 1 + a / (a - v)
                peaks[count] = peak
                count += 1
            if peak > floor:
                history[filled % 5] = peak
                filled += 1
                threshold = max(floor, arm * np.median(history[: min(filled, 5)]))
            armed, peak = False, 0.0
    return times[:count], peaks[:count]


@numba.njit(cache=True, nogil=True)
def _timed_pulses(
    x: FloatArray, prominence: float, level: float, rising: bool
) -> tuple[FloatArray, FloatArray, FloatArray]:  # pragma: no cover - compiled
    """Tops and troughs by hysteresis, then each pulse's edge in samples (sub-sample), level and swing."""
    n = x.size
    extreme = np.empty(n // 2 + 2, dtype=np.int64)  # alternating troughs and tops
    count = 0
    seeking = 0  # 0: not yet known, 1: a top, -1: a trough
    hi_i = lo_i = 0
    for i in range(1, n):
        v = x[i]
        if v > x[hi_i]:
            hi_i = i
        if v < x[lo_i]:
            lo_i = i
        # a top is confirmed once the signal has fallen the hysteresis below it and below the
        # pulse's own level (a notch above that level leaves the pulse whole)
        if (
            seeking >= 0
            and v < x[hi_i] - prominence
            and (count == 0 or v < x[extreme[count - 1]] + level * (x[hi_i] - x[extreme[count - 1]]))
        ):
            if seeking == 0:  # the record opens on a pulse: its trough is not in it
                extreme[count] = -1
                count += 1
            extreme[count] = hi_i
            count += 1
            seeking, lo_i = -1, i
        elif seeking <= 0 and v > x[lo_i] + prominence:
            # a record that opens already rising (by more than 1 % of the hysteresis in its first step)
            # has not shown its first pulse's trough: that pulse is cut off
            extreme[count] = lo_i if lo_i > 0 or x[1] - x[0] <= 0.01 * prominence else -1
            count += 1
            seeking, hi_i = 1, i
    if seeking == -1:  # the record ends falling from its last top: its trough is cut off
        extreme[count] = -1
        count += 1
    pulses = count // 2
    times = np.empty(pulses)
    levels = np.empty(pulses)
    swings = np.empty(pulses)
    found = 0
    for k in range(pulses):
        trough_before, top = extreme[2 * k], extreme[2 * k + 1]
        trough_after = extreme[2 * k + 2] if 2 * k + 2 < count else -1
        trough = trough_before if rising else trough_after
        if trough < 0:
            continue
        mark = x[trough] + level * (x[top] - x[trough])
        if rising:
            j = top - 1
            while j > trough and x[j] >= mark:
                j -= 1
        else:
            j = top
            while j + 1 < trough and x[j + 1] >= mark:
                j += 1
        a, b = x[j] - mark, x[j + 1] - mark
        times[found] = j + (a / (a - b) if a != b else 0.0)
        levels[found] = mark
        swings[found] = x[top] - x[trough]
        found += 1
    return times[:found], levels[:found], swings[:found]


def detect_pulses(
    signal: npt.ArrayLike,
    sample_rate: float,
    *,
    start_time: float = 0.0,
    relative_height: float = 0.5,
) -> EdgeDetection:
    """Rising edges of pulses that are all alike (keyphasor, cam, encoder index), glitches left out.

    Parameters
    ----------
    signal : array_like or sliceable, shape (n,)
        Sensor waveform [V].
    sample_rate : float
        [Hz].
    start_time : float, optional
        Time of the first sample [s].
    relative_height : float, optional
        Fraction of the local pulse height below which a pulse is a glitch [-].

    Returns
    -------
    EdgeDetection

    Raises
    ------
    SignalError
        As :func:`detect_edges`.

    Notes
    -----
    A first pass finds every pulse above the noise (:func:`detect_edges`). Each pulse is then set
    against the height of the real pulses around it: the median swing of those among its 17
    neighbours (itself included) at least half as high as the highest of them. A pulse lower than
    ``relative_height`` of that is a glitch and is left out. The height is local, so a magnetic
    pick-up whose pulses grow with speed over a run-up keeps its low-speed pulses.
    """
    if not 0 < relative_height < 1:
        raise SignalError(f"relative_height = {relative_height!r}: expected a fraction between 0 and 1")
    first = detect_edges(signal, sample_rate, start_time=start_time)
    swings = first.swings
    n = swings.size
    padded = np.pad(swings, 8, mode="reflect") if n > 8 else swings
    height = np.empty(n)
    for j in range(n):
        window = padded[j : j + 17] if n > 8 else swings
        tall = window[window >= 0.5 * np.max(window)]
        height[j] = np.median(tall)
    keep = swings >= relative_height * height
    if np.count_nonzero(keep) < 2:
        raise SignalError("fewer than two pulses stand out of the glitches: check the channel")
    return EdgeDetection(first.times[keep], first.levels[keep], swings[keep])


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

    def note(self, channel: str) -> str | None:
        """What a user should know of the pulses dropped and inserted (None when none was)."""
        if not self.repaired:
            return None
        said = []
        if self.removed.size:
            shown = ", ".join(f"{t:.6f} s" for t in self.removed[:8])
            more = f" and {self.removed.size - 8} more" if self.removed.size > 8 else ""
            said.append(
                f"{self.removed.size} extra pulse(s) dropped (glitches or stray pulses: each closed an "
                f"interval under {EXTRA_BELOW} of a revolution's, at {shown}{more})"
            )
        if self.inserted.size:
            said.append(f"{self.inserted.size} missing pulse(s) inserted")
        return f"keyphasor {channel!r}: " + " and ".join(said) + f", of {self.times.size} kept"


def repair_keyphasor(
    times: npt.ArrayLike, *, window: int = 9, max_missing: int = 3, max_repaired: float = 0.25
) -> KeyphasorRepair:
    """Remove extra and insert missing once-per-revolution pulses.

    Parameters
    ----------
    times : array_like
        Detected pulse times, increasing [s].
    window : int, optional
        Pulses in the running median of the revolution period.
    max_missing : int, optional
        Most consecutive missing pulses that are filled in; a longer gap is an error.
    max_repaired : float, optional
        Largest share of the pulses that may be inserted or removed; a pulse train that needs
        more repair is inconsistent with itself (glitches counted as pulses, a wrong channel) and
        is refused rather than turned into a wrong speed [-].

    Returns
    -------
    KeyphasorRepair

    Raises
    ------
    SignalError
        With fewer than 4 pulses, non-increasing times, a gap longer than ``max_missing``, more
        than ``max_repaired`` of the pulses repaired, or a repaired revolution that lasts more than
        25 % longer or shorter than its neighbours (no engine changes speed so from one revolution
        to the next; glitches as tall as the pulses do).

    Notes
    -----
    An interval shorter than :data:`EXTRA_BELOW` of the local median period marks an extra
    pulse: of the two pulses bounding it, the one whose removal leaves the
    interval nearest the median is dropped.  An interval of about ``m + 1``
    median periods (within +-0.3 of a period) has ``m`` missing pulses, inserted
    evenly.  The speed may vary; the median follows it.  The median mirrors the intervals at the
    record's ends, so the first and the last interval are judged against their neighbours.
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
        ref = median_filter(dt, size=min(window, dt.size), mode="mirror")
        short = np.flatnonzero(dt < EXTRA_BELOW * ref)
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
    ref = median_filter(dt, size=min(window, dt.size), mode="mirror")
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
    repaired = len(inserted) + len(removed)
    final = np.diff(np.asarray(out))
    ratio = final / median_filter(final, size=min(window, final.size), mode="mirror")
    if np.any(np.abs(ratio - 1.0) > 0.25):
        i = int(np.argmax(np.abs(ratio - 1.0)))
        raise SignalError(
            f"keyphasor: after repair, the revolution from t = {out[i]:.6g} s lasts {ratio[i]:.2f} times "
            "its neighbours' (more than 25 % apart): glitches as tall as the pulses, or a channel that is "
            "not once per revolution; the speed would be wrong"
        )
    if repaired > max_repaired * t.size:
        raise SignalError(
            f"keyphasor: {len(removed)} of {t.size} pulses would be removed and {len(inserted)} inserted: "
            f"more than {max_repaired:.0%} of the pulse train does not fit one pulse per revolution "
            "(glitches taken for pulses, or not a once-per-revolution channel); check the channel"
        )
    return KeyphasorRepair(np.asarray(out), np.asarray(inserted), np.asarray(removed))
