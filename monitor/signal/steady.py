"""Steady segments: the spans of a recording at one operating point, and the transitions between them.

The operating point is read cycle by cycle from the angle map (:func:`cycle_series`): each whole
cycle's mean speed ``Omega_c = 2 pi R / (t_end - t_start)``, and its load indicator, the amplitude
of the speed's fluctuation at the firing harmonic of the cycle (the cylinders' count, for firing
angles spread evenly). At a held speed (a generator's governor) the mean speed does not tell a load
step, but the firing impulse grows with the cylinders' pressure, and with it the fluctuation.

Change detection (:func:`steady_segments`), binary segmentation with a threshold from each series'
own noise:

1. The noise: ``sigma = 1.4826 median |x_{c+1} - x_c| / sqrt(2)``, the median absolute successive
   difference scaled to a Gaussian's standard deviation, of each piece tested (a series' noise may
   change with its level: the load indicator's, relative to it, is about constant). A step moves
   one difference and a slow trend moves all of them by little, so neither inflates it.
2. The split: over a piece of ``n`` cycles, the two-sample statistic
   ``T_k = |mean(x[:k]) - mean(x[k:])| / (sigma sqrt(1/k + 1/(n - k)))`` at every ``k``; its largest
   over the two series splits the piece if it exceeds ``tau = Phi^-1(1 - alpha / (4 (n - 1)))``
   (two-sided, Bonferroni over the ``n - 1`` places and the two series: the places' statistics are
   positively correlated, so the chance of a split of a steady piece is at most ``alpha``) and if the
   step is one the diagnosis would tell apart (:data:`SPEED_STEP` of the speed,
   :data:`LOAD_STEP` of the load indicator). Each side is split again until nothing is.
3. The segments: neighbouring pieces that the test of step 2 no longer tells apart are joined
   (a chance split at the binary segmentation's later stages, each a test of its own); then the
   pieces of at least :data:`MIN_CYCLES` cycles (or the fewer asked for) without a drift of their
   own (a least-squares line's rise across them, or across ``drift_over`` cycles where they are
   fewer, of a step or more, its slope beyond ``tau`` of its standard error: binary segmentation
   chops a ramp into pieces that rise by one to two steps, which are no steady segments, nor is a
   shorter piece of a ramp that would rise by a step over ``drift_over`` cycles; a step below the
   floor, left whole, makes a line rise by 1.5 times its size, so one of two thirds of the floor or
   more leaves no segment and the recording is diagnosed whole, as without segments); neighbours
   less than :data:`MIN_CYCLES` apart that the test of step 2 no longer tells apart are joined
   again (a glitch split off does not cut a steady run in two). Last, the cycles of a segment whose speed
   departs from its median by :data:`SPEED_STEP` or more are a transient the split test does not
   see (a short dip and recovery has the same mean on both sides: the held speed after a load step,
   whose load indicator may not tell the step where the inertia torque dominates the firing
   harmonic, as on many cylinders): they are cut out, and the runs either side are segments of
   their own. The :data:`GUARD` cycles on each side of a
   change (the cycle in which the load moved holds both) and every piece that is not a segment
   make the transitions.

tests/signal/test_steady.py measures the false splits on steady noisy series and the boundaries
found for steps of several sizes against the noise.
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass

import numpy as np
from scipy.stats import norm

from monitor.signal.anglemap import AngleMap
from monitor.types import FloatArray

__all__ = [
    "ALPHA",
    "GUARD",
    "LOAD_STEP",
    "MIN_CYCLES",
    "SPEED_STEP",
    "CycleSeries",
    "Segment",
    "Segmentation",
    "Transition",
    "cycle_series",
    "noise_of",
    "steady_segments",
]

MIN_CYCLES = 20  # cycles a steady segment needs to be diagnosed on its own (the balance's blocks) [-]
SPEED_STEP = 0.02  # a change of the mean speed smaller than this (relative) is the same point [-]
LOAD_STEP = 0.10  # a change of the load indicator smaller than this (relative) is the same point [-]
ALPHA = 0.01  # the chance, at most, that the test splits a steady piece [-]
GUARD = 1  # cycles on each side of a change left to the transition [-]
ROUND_OFF = 1e-9  # the least noise a series is taken to have, relative to its level (a noise-free one) [-]


@dataclass(frozen=True)
class CycleSeries:
    """The operating point cycle by cycle.

    Attributes
    ----------
    start, stop : ndarray
        Each whole cycle's first and last instant [s].
    speed : ndarray
        Its mean crank speed [rad/s].
    load : ndarray or None
        Its load indicator: the speed fluctuation's amplitude at the firing harmonic [rad/s];
        None when the angle reference does not resolve it (a keyphasor alone).
    """

    start: FloatArray
    stop: FloatArray
    speed: FloatArray
    load: FloatArray | None

    @property
    def cycles(self) -> int:
        """The number of whole cycles [-]."""
        return int(self.speed.size)


@dataclass(frozen=True)
class Segment:
    """A steady segment: whole cycles at one operating point.

    Attributes
    ----------
    first, stop : int
        Its first cycle and the one after its last [-].
    start_s, stop_s : float
        Its span [s].
    speed : float
        Its mean crank speed [rad/s].
    load_indicator : float or None
        Its mean load indicator [rad/s] (None: not resolved).
    """

    first: int
    stop: int
    start_s: float
    stop_s: float
    speed: float
    load_indicator: float | None

    @property
    def cycles(self) -> int:
        """Its number of cycles [-]."""
        return self.stop - self.first


@dataclass(frozen=True)
class Transition:
    """The span between two steady segments (a change of the operating point).

    Attributes
    ----------
    start_s, stop_s : float
        Its span [s]: from the end of the segment before to the start of the one after.
    before, after : Segment
    """

    start_s: float
    stop_s: float
    before: Segment
    after: Segment


@dataclass(frozen=True)
class Segmentation:
    """A recording's steady segments in time order and the transitions between them.

    Attributes
    ----------
    segments : tuple of Segment
    transitions : tuple of Transition
        One between each two consecutive segments.
    cycles : int
        The whole cycles of the series segmented [-] (0: not known).
    """

    segments: tuple[Segment, ...]
    transitions: tuple[Transition, ...]
    cycles: int = 0

    @property
    def at_one_point(self) -> bool:
        """Whether the series is one steady segment from its first cycle to its last."""
        return len(self.segments) == 1 and (self.segments[0].first, self.segments[0].stop) == (0, self.cycles)


def cycle_series(
    angle_map: AngleMap, *, cycle_revolutions: int, firing_harmonic: int, pulses_per_revolution: int
) -> CycleSeries:
    """Each whole cycle's mean speed and load indicator, from the angle map.

    Parameters
    ----------
    angle_map : AngleMap
        Cycle angle against time (0 at cylinder 1's firing TDC).
    cycle_revolutions : int
        1 two-stroke, 2 four-stroke.
    firing_harmonic : int
        The firing impulses per cycle (the cylinders' count) [-].
    pulses_per_revolution : int
        The map's pulses per revolution: it resolves orders below half of it [-].

    Returns
    -------
    CycleSeries
        Empty (no cycle) when the map covers less than one whole cycle.

    Notes
    -----
    The speed over each of ``M`` equal angle steps of a cycle is the step over the time across it
    (exact, no derivative of the map); the load indicator is ``|(2 / M) sum_m w_m exp(-2 pi i h m /
    M)|`` of those speeds, ``h`` the firing harmonic. The steps' means attenuate it by a sinc that is
    the same in every cycle, which a comparison between cycles does not see.
    """
    cycle = 2 * math.pi * cycle_revolutions
    first = math.ceil(float(angle_map.angles[0]) / cycle)
    last = math.floor(float(angle_map.angles[-1]) / cycle)
    count = max(last - first, 0)
    resolved = firing_harmonic / cycle_revolutions < 0.5 * pulses_per_revolution
    steps = 2 ** math.ceil(math.log2(max(16, 8 * firing_harmonic))) if resolved else 1
    if count == 0:
        empty = np.empty(0)
        return CycleSeries(empty, empty, empty, empty if resolved else None)
    times = angle_map.time_at_steps(first * cycle, cycle / steps, count * steps + 1)
    start, stop = times[:-1:steps], times[steps::steps]
    speed = cycle / (stop - start)
    load = None
    if resolved:
        within = (cycle / steps) / np.diff(times).reshape(count, steps)
        kernel = np.exp(-2j * math.pi * firing_harmonic * np.arange(steps) / steps)
        load = np.abs(within @ kernel) * (2.0 / steps)
    return CycleSeries(start, stop, speed, load)


def noise_of(values: FloatArray) -> float:
    """A series' noise from its successive differences: a Gaussian's standard deviation [its unit].

    Parameters
    ----------
    values : ndarray
        The per-cycle series [any unit].

    Returns
    -------
    float
        ``1.4826 median |diff| / sqrt(2)``; 0 for fewer than two values.
    """
    if values.size < 2:
        return 0.0
    return float(1.4826 * np.median(np.abs(np.diff(values))) / math.sqrt(2.0))


@functools.lru_cache(maxsize=1024)
def _threshold(n: int, series: int) -> float:
    """The split statistic's threshold over ``n`` cycles: two-sided Bonferroni over places and series.

    Kept per ``(n, series)``: a recording's segmentation asks for the same few hundred pieces' lengths
    again and again, and scipy's ``isf`` costs about 0.1 ms a call."""
    return float(norm.isf(ALPHA / (2 * series * max(n - 1, 1))))


def _best_split(columns: list[tuple[FloatArray, float]], a: int, b: int) -> tuple[int, float, bool] | None:
    """The most significant place to split cycles ``a:b``: (place, statistic, step big enough)."""
    n = b - a
    if n < 4:
        return None
    k = np.arange(2, n - 1)  # at least two cycles on each side
    best: tuple[int, float, bool] | None = None
    for values, floor in columns:
        x = values[a:b]
        level = max(abs(float(np.mean(x))), 1e-300)
        # the piece's own noise (a series' noise may change with its level), at least round-off's
        sigma = max(noise_of(x), ROUND_OFF * level)
        total = np.cumsum(x)
        left = total[k - 1] / k
        right = (total[-1] - total[k - 1]) / (n - k)
        step = np.abs(left - right)
        statistic = step / (sigma * np.sqrt(1.0 / k + 1.0 / (n - k)))
        i = int(np.argmax(statistic))
        candidate = (a + int(k[i]), float(statistic[i]), bool(step[i] >= floor * level))
        if best is None or candidate[1] > best[1]:
            best = candidate
    return best


def _splits(columns: list[tuple[FloatArray, float]], a: int, b: int) -> list[int]:
    """Binary segmentation of cycles ``a:b``: the places of significant steps, in order."""
    found = _best_split(columns, a, b)
    if found is None:
        return []
    place, statistic, large = found
    if statistic <= _threshold(b - a, len(columns)) or not large:
        return []
    return [*_splits(columns, a, place), place, *_splits(columns, place, b)]


def _drifts(columns: list[tuple[FloatArray, float]], a: int, b: int, over: int) -> bool:
    """Whether cycles ``a:b`` drift: a least-squares line rising significantly by a step or more over
    them, or over ``over`` cycles where they are fewer (a ramp cut short is still a ramp)."""
    c = np.arange(b - a, dtype=np.float64)
    c -= c.mean()
    for values, floor in columns:
        x = values[a:b]
        level = max(abs(float(np.mean(x))), 1e-300)
        sigma = max(noise_of(x), ROUND_OFF * level)
        slope = float(c @ (x - x.mean()) / (c @ c))
        significant = abs(slope) > _threshold(b - a, len(columns)) * sigma / math.sqrt(c @ c)
        if significant and abs(slope) * max(b - a, over) >= floor * level:
            return True
    return False


def _without_excursions(speed: FloatArray, a: int, b: int) -> list[tuple[int, int]]:
    """Cycles ``a:b`` without those whose speed departs from their median by :data:`SPEED_STEP` or more:
    the runs between such excursions (a transient too short for the split test to cut out)."""
    x = speed[a:b]
    level = float(np.median(x))
    off = np.abs(x - level) >= SPEED_STEP * abs(level)
    if not off.any():
        return [(a, b)]
    edges = np.flatnonzero(np.diff(np.concatenate([[True], off, [True]]).astype(np.int8)))
    # the runs of steady cycles: each from a fall of ``off`` to the next rise
    return [(a + int(start), a + int(stop)) for start, stop in zip(edges[::2], edges[1::2], strict=True)]


def _differ(columns: list[tuple[FloatArray, float]], one: tuple[int, int], two: tuple[int, int]) -> bool:
    """Whether two pieces' levels differ by a significant step that the diagnosis would tell apart."""
    for values, floor in columns:
        x, y = values[one[0] : one[1]], values[two[0] : two[1]]
        step = abs(float(x.mean()) - float(y.mean()))
        # each piece's own noise (Welch); a piece too short to tell its own takes its neighbour's
        level = max(abs(float(np.concatenate([x, y]).mean())), 1e-300)
        sx, sy = noise_of(x), noise_of(y)
        sx, sy = (sx if x.size >= 4 else sy), (sy if y.size >= 4 else sx)
        spread = max(math.sqrt(sx**2 / x.size + sy**2 / y.size), ROUND_OFF * level)
        if step / spread > _threshold(x.size + y.size, len(columns)) and step >= floor * level:
            return True
    return False


def steady_segments(
    series: CycleSeries, *, min_cycles: int = MIN_CYCLES, drift_over: int = 0
) -> Segmentation:
    """The steady segments of a per-cycle series and the transitions between them (module docstring).

    Parameters
    ----------
    series : CycleSeries
    min_cycles : int, optional
        Cycles a segment needs [-].
    drift_over : int, optional
        Cycles over which a shorter piece's drift is judged (a span of a ramp is no segment however
        short); 0, the default, judges each piece over its own cycles [-].

    Returns
    -------
    Segmentation
        No segment when none is steady and long enough (a run-up); one when the whole recording is
        at one point (its cycles all, or those of its one steady span).
    """
    columns = [(series.speed, SPEED_STEP)]
    if series.load is not None:
        columns.append((series.load, LOAD_STEP))
    n = series.cycles
    places = [0, *_splits(columns, 0, n), n]
    merged: list[tuple[int, int]] = []
    for a, b in itertools.pairwise(places):  # a split the test no longer confirms pairwise is undone
        if merged and not _differ(columns, merged[-1], (a, b)):
            merged[-1] = (merged[-1][0], b)
        else:
            merged.append((a, b))
    pieces = [(a, b) for a, b in merged if b - a >= min_cycles and not _drifts(columns, a, b, drift_over)]
    joined: list[tuple[int, int]] = []
    for piece in pieces:  # neighbours that the test no longer tells apart are one segment
        if joined and piece[0] - joined[-1][1] < min_cycles and not _differ(columns, joined[-1], piece):
            joined[-1] = (joined[-1][0], piece[1])
        else:
            joined.append(piece)
    steady = [part for a, b in joined for part in _without_excursions(series.speed, a, b)]
    trimmed = [(a + (GUARD if a > 0 else 0), b - (GUARD if b < n else 0)) for a, b in steady]
    segments = tuple(
        Segment(
            first=a,
            stop=b,
            start_s=float(series.start[a]),
            stop_s=float(series.stop[b - 1]),
            speed=float(series.speed[a:b].mean()),
            load_indicator=None if series.load is None else float(series.load[a:b].mean()),
        )
        for a, b in trimmed
        if b - a >= min_cycles
    )
    transitions = tuple(
        Transition(before.stop_s, after.start_s, before, after)
        for before, after in itertools.pairwise(segments)
    )
    return Segmentation(segments, transitions, n)
