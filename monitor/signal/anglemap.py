"""The angle map: crank angle as a function of time, and the four-stroke cycle phase.

The map is built from pulse times with known crank angles (tooth-wheel
edges, or keyphasor pulses one revolution apart) by monotone (PCHIP)
interpolation of the cumulative angle: it passes through every pulse,
never runs backwards, and has a continuous speed.  Its inverse, time as a
function of angle, is the same construction with the axes swapped: this is
what resampling to the angle domain evaluates.

Four-stroke engines repeat every two revolutions.  The cycle phase says
which revolution holds cylinder 1's firing TDC: from a cam pulse (once per
cycle), from a cylinder-pressure channel (the revolution whose TDC has the
higher pressure), or given explicitly.  The map's angle is then the cycle
angle, 0 at firing TDC of cylinder 1.
"""

from __future__ import annotations

import itertools
import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import cached_property

import numba
import numpy as np
import numpy.typing as npt
from scipy.interpolate import PchipInterpolator

from monitor.errors import SignalError
from monitor.signal.quintic import QuinticSpline
from monitor.types import FloatArray

__all__ = ["AngleMap", "cycle_phase_from_pressure"]

_SPEED_WINDOW = 1 << 14  # pulses per window of the speed spline
_SPEED_OVERLAP = 64  # pulses added on each side of a window
REPEATING = 0.5  # share of the speed's fluctuation the cycle's shape must explain for a gap to be filled
_FILL_NEIGHBOURS = 32  # pulses on each side of a gap through which its spline error on the shape is taken


@dataclass(frozen=True)
class AngleMap:
    """Crank angle against time, from pulses with known angles.

    Attributes
    ----------
    times : ndarray
        Pulse times [s].
    angles : ndarray
        Their crank angles, increasing, 0 at TDC of cylinder 1 (firing TDC on a
        four-stroke once the cycle phase is applied) [rad].
    """

    times: FloatArray
    angles: FloatArray

    def __post_init__(self) -> None:
        if self.times.shape != self.angles.shape or self.times.size < 2:
            raise SignalError(
                f"angle map: {self.times.shape} pulse times and {self.angles.shape} angles: expected "
                "matching 1-D arrays of at least two"
            )
        if np.any(np.diff(self.times) <= 0) or np.any(np.diff(self.angles) <= 0):
            dt, da = np.diff(self.times), np.diff(self.angles)
            first = int(np.flatnonzero((dt <= 0) | (da <= 0))[0])
            raise SignalError(
                f"angle map: pulse {first + 1} (t = {self.times[first + 1]:.9g} s, angle "
                f"{self.angles[first + 1]:.9g} rad) does not follow pulse {first}: expected increasing "
                "times and angles"
            )

    @classmethod
    def from_keyphasor(cls, times: npt.ArrayLike, *, pulse_angle: float = 0.0) -> AngleMap:
        """One pulse per revolution, the pulse at ``pulse_angle`` after TDC of cylinder 1.

        Parameters
        ----------
        times : array_like
            Repaired pulse times, one per revolution [s].
        pulse_angle : float, optional
            Crank angle of the pulse's leading edge after TDC of cylinder 1 [rad].

        Returns
        -------
        AngleMap
        """
        t = np.asarray(times, dtype=np.float64)
        return cls(t, pulse_angle + 2 * math.pi * np.arange(t.size, dtype=np.float64))

    def with_gaps_filled(self, cycle: float, harmonics: int) -> AngleMap:
        """The map with points in its wheel's gaps (missing teeth), where the cycle's shape puts them.

        Across a gap of ``n`` pitches the map has one interval, where the speed's spline sees no
        pulse: the speed's fluctuation inside it (a slow engine's firing order, 18 deg of a 60-2
        wheel's gap against its 30 deg period on a 12-cylinder two-stroke) is lost, and its loss leaks
        into every order once per revolution.  The part of the speed that repeats every cycle is seen
        by the pulses everywhere but in the gaps: the slowness relative to its local mean, as a
        Fourier series of the cycle angle, is fitted by least squares to every interval's mean of it
        (an interval's time over its angle, averaged over the cycles at its place in the cycle), the
        gaps' intervals included; of every number of harmonics from a quarter to nearly a half of the
        places in a cycle, the one whose fit predicts each place best from the others (leave-one-out)
        is kept.  Each missing tooth is then put where the spline through the pulses
        reaches its angle, moved by the error the same spline makes across the same gap on that shape
        alone (the shape's own pulses through the same spline): the repeating part is corrected,
        anything else (a transient, a sensor's error beside the gap) stays as the spline has it.  A
        map without gaps (an encoder, a keyphasor), or one whose speed does not repeat by at least
        :data:`REPEATING` of its variance, is returned as it is.

        Parameters
        ----------
        cycle : float
            The cycle angle the shape repeats over [rad].
        harmonics : int
            Orders of the cycle fitted, at most [-].

        Returns
        -------
        AngleMap
        """
        span = np.diff(self.angles)
        if span.size < 8:
            return self
        pitch = float(np.median(span))
        gaps = np.flatnonzero(span > 1.5 * pitch)
        per_cycle = cycle / pitch
        if gaps.size == 0 or per_cycle < 8:
            return self
        candidates = _harmonic_candidates(self.angles, span, gaps, pitch, cycle, harmonics)
        if not candidates:
            return self
        local = self._local_slowness(cycle)
        relative = np.diff(self.times) / span / local
        places = _CyclePlaces.of(self.angles, span, relative, cycle, pitch)
        fit = _fit_cycle_shape(places, candidates, cycle)
        if fit is None:
            return self
        shape, fitted = fit
        # the shape that repeats every cycle must be most of the speed's fluctuation: where it is not (a
        # free vibration at an order that is not whole, a run-up), the spline across the gap is left
        if np.var(relative - fitted[places.which]) > (1 - REPEATING) * np.var(relative):
            return self
        inside, missing = _missing_teeth(self.angles, span, gaps, pitch)
        # the spline through the pulses (the one speed_at differentiates) reaches each missing angle at
        crossing = self._spline_crossings(missing, inside)
        filled = crossing + local[inside] * self._shape_errors(shape, missing, inside, pitch)
        return self._with_points(filled, missing, inside)

    def _local_slowness(self, cycle: float) -> FloatArray:
        """The slowness's local mean at each interval: the time the crank takes over the cycle centred
        on it, over the cycle's angle [s/rad]."""
        middle = 0.5 * (self.angles[1:] + self.angles[:-1])
        low = np.clip(middle - 0.5 * cycle, self.angles[0], self.angles[-1])
        high = np.clip(middle + 0.5 * cycle, self.angles[0], self.angles[-1])
        return np.asarray(
            (np.interp(high, self.angles, self.times) - np.interp(low, self.angles, self.times))
            / (high - low)
        )

    def _shape_errors(
        self, shape: _CycleShape, missing: FloatArray, inside: npt.NDArray[np.int64], pitch: float
    ) -> FloatArray:
        """How far the spline through the pulses misses the cycle's shape at each missing tooth, in the
        shape's time.

        It misses the cycle's shape across a gap by as much at every gap in the same place of the
        cycle: that error, from the same spline through the shape's own pulses.
        """
        cycle = shape.cycle
        correction = np.zeros(missing.size)
        gap_place = np.round(np.mod(self.angles[inside], cycle) / (1e-3 * pitch)).astype(np.int64)
        for where in np.unique(gap_place):
            chosen = np.flatnonzero(gap_place == where)
            g = int(inside[chosen[chosen.size // 2]])  # one amid the pulses, away from the spline's ends
            alike = chosen[inside[chosen] == g]
            lo, hi = max(0, g - _FILL_NEIGHBOURS), min(self.angles.size, g + _FILL_NEIGHBOURS + 2)
            shape_times = shape.elapsed(self.angles[lo:hi])
            spline = QuinticSpline(shape_times, self.angles[lo:hi])
            target = missing[alike]
            low = np.full(target.size, shape_times[g - lo])
            high = np.full(target.size, shape_times[g + 1 - lo])
            error = shape.elapsed(target) - _crossing(spline, target, low, high)
            correction[np.flatnonzero(gap_place == where)] = np.resize(error, chosen.size)
        return correction

    def _with_points(
        self, filled: FloatArray, missing: FloatArray, inside: npt.NDArray[np.int64]
    ) -> AngleMap:
        """The map with the missing teeth's points at times ``filled``, angles ``missing``, each in the
        interval after pulse ``inside``.

        Each gap's points must be in order inside it, and not where the spline ends (there it is not
        the one the correction was taken on), or the gap is left as it is.
        """
        bounds = np.concatenate([self.times[inside][:, None], self.times[inside + 1][:, None]], axis=1)
        ok = (filled > bounds[:, 0]) & (filled < bounds[:, 1])
        ok &= (inside >= _FILL_NEIGHBOURS) & (inside < self.times.size - 1 - _FILL_NEIGHBOURS)
        ordered = np.ones(filled.size, dtype=bool)
        ordered[1:] = (inside[1:] != inside[:-1]) | (np.diff(filled) > 0)
        bad = np.unique(inside[~(ok & ordered)])
        use = ~np.isin(inside, bad)
        # each point lies inside its own gap's interval, in order: merged in, not sorted with the rest
        where = np.searchsorted(self.times, filled[use])
        times = np.insert(self.times, where, filled[use])
        return AngleMap(times, np.insert(self.angles, where, missing[use]))

    def _spline_crossings(self, targets: FloatArray, gaps: npt.NDArray[np.int64]) -> FloatArray:
        """When the speed's spline through the pulses reaches each target angle inside its gap [s].

        ``gaps`` holds the index of the pulse that starts each target's gap; the spline is built over
        the same windows of pulses as :meth:`speed_at`'s, and each crossing found by bisection.
        """
        out = np.empty(targets.size)
        window = np.asarray(gaps, dtype=np.int64) // _SPEED_WINDOW
        for w in np.unique(window):
            chosen = np.flatnonzero(window == w)
            spline = self._window_spline(int(w))
            g = np.asarray(gaps, dtype=np.int64)[chosen]
            out[chosen] = _crossing(spline, targets[chosen], self.times[g], self.times[g + 1])
        return out

    def shifted(self, angle: float) -> AngleMap:
        """The same map with ``angle`` added to every angle (a cycle-phase correction) [rad]."""
        return AngleMap(self.times, self.angles + angle)

    @cached_property
    def _forward(self) -> PchipInterpolator:
        return PchipInterpolator(self.times, self.angles, extrapolate=False)

    def angle_at(self, time: npt.ArrayLike) -> FloatArray:
        """Crank angle at times inside the mapped span [rad]; NaN outside it.

        Parameters
        ----------
        time : array_like
            [s].

        Returns
        -------
        ndarray
        """
        t = np.asarray(time, dtype=np.float64)
        slack = 1e-12 * (abs(self.times[0]) + abs(self.times[-1]))
        inside = (t >= self.times[0] - slack) & (t <= self.times[-1] + slack)
        values = self._forward(np.clip(t, self.times[0], self.times[-1]))
        return np.asarray(np.where(inside, values, np.nan))

    def speed_at(self, time: npt.ArrayLike) -> FloatArray:
        """Angular speed d(angle)/dt at times inside the mapped span [rad/s]; NaN outside it.

        Parameters
        ----------
        time : array_like
            [s].

        Returns
        -------
        ndarray

        Notes
        -----
        The derivative of a quintic interpolating spline through the pulses, not
        of the monotone map: the map's shape-preserving slopes flatten the speed's
        extremes, while the quintic spline follows a speed fluctuation of order
        ``k`` closely as long as there are several pulses per period of it
        (tested: a 60-2 wheel and order 7). The spline is built over windows of
        2^14 pulses overlapping by 64 on each side (an interpolating spline's
        dependence on a distant pulse decays geometrically, below 1e-20 at 64
        pulses), so an hour of tooth-wheel pulses needs little memory.
        """
        t = np.asarray(time, dtype=np.float64)
        flat = t.ravel()
        out = np.full(flat.shape, np.nan)
        n = self.times.size
        if n <= 5:
            inside = (flat >= self.times[0]) & (flat <= self.times[-1])
            out[inside] = (self.angles[-1] - self.angles[0]) / (self.times[-1] - self.times[0])
            return out.reshape(t.shape)
        starts = self.times[::_SPEED_WINDOW][1:]  # first pulse of every window but the first
        if flat.size < 2 or np.all(flat[1:] >= flat[:-1]):
            # sorted (a grid): each window's queries are one run, written in place
            first = int(np.searchsorted(flat, self.times[0], side="left"))
            last = int(np.searchsorted(flat, self.times[-1], side="right"))
            bounds = np.concatenate([[first], np.searchsorted(flat, starts, side="right"), [last]])
            bounds = np.clip(bounds, first, last)
            for w in range(bounds.size - 1):
                if bounds[w + 1] > bounds[w]:
                    run = slice(int(bounds[w]), int(bounds[w + 1]))
                    out[run] = self._window_spline(w).slope(flat[run])
            return out.reshape(t.shape)
        inside = np.flatnonzero((flat >= self.times[0]) & (flat <= self.times[-1]))
        window = np.searchsorted(starts, flat[inside], side="right")
        order = np.argsort(window, kind="stable")
        bounds = np.searchsorted(window[order], np.arange(starts.size + 2))
        for w in range(bounds.size - 1):
            chosen = inside[order[bounds[w] : bounds[w + 1]]]
            if chosen.size:
                out[chosen] = self._window_spline(w).slope(flat[chosen])
        return out.reshape(t.shape)

    def _window_spline(self, w: int) -> QuinticSpline:
        """The quintic interpolating spline over window ``w`` of the pulses and its overlaps."""
        lo = max(0, w * _SPEED_WINDOW - _SPEED_OVERLAP)
        hi = min(self.times.size, (w + 1) * _SPEED_WINDOW + 1 + _SPEED_OVERLAP)
        return QuinticSpline(self.times[lo:hi], self.angles[lo:hi])

    def time_at(self, angle: npt.ArrayLike) -> FloatArray:
        """Time at which the crank reaches each angle: the exact inverse of :meth:`angle_at` [s].

        NaN outside the span. Each angle's cubic piece is solved by Newton
        iteration kept inside a shrinking bracket (the piece is monotone, so the
        root is unique and always found), compiled with numba: about 50 ns per angle.

        Parameters
        ----------
        angle : array_like
            [rad].

        Returns
        -------
        ndarray
        """
        target = np.asarray(angle, dtype=np.float64)
        flat = np.ascontiguousarray(target.ravel())
        if flat.size == 0:
            return np.empty(target.shape)
        out = np.empty(flat.shape)
        self._solve(flat, 0.0, 0.0, out)
        return out.reshape(target.shape)

    def time_at_steps(self, first: float, step: float, count: int) -> FloatArray:
        """:meth:`time_at` of the angles ``first + step * k``, ``k = 0 .. count - 1``, never made [s].

        Parameters
        ----------
        first, step : float
            [rad].
        count : int

        Returns
        -------
        ndarray, shape (count,)
        """
        out = np.empty(count)
        if count:
            self._solve(np.empty(0), first, step, out)
        return out

    def _solve(self, target: FloatArray, first: float, step: float, out: FloatArray) -> None:
        """The compiled inverse into ``out``, in parallel threads over parts of it."""
        slack = 1e-12 * (abs(self.angles[0]) + abs(self.angles[-1]))  # round-off at the span's ends
        coefficients = self._forward.c  # the cubic of each piece, powers of (t - t0): shape (4, pieces)
        workers = min(os.cpu_count() or 1, max(1, out.size // (1 << 20)))
        bounds = np.linspace(0, out.size, workers + 1).astype(np.int64)
        with ThreadPoolExecutor(max_workers=workers) as pool:  # the compiled loop releases the GIL
            for job in [
                pool.submit(
                    _invert,
                    coefficients,
                    self.times,
                    self.angles,
                    target[a:b] if target.size else target,
                    first,
                    step,
                    int(a),
                    slack,
                    out[a:b],
                )
                for a, b in itertools.pairwise(bounds)
            ]:
                job.result()

    @cached_property
    def speed_range(self) -> tuple[float, float]:
        """Slowest and fastest mean speed between consecutive pulses [rad/s]."""
        speed = np.diff(self.angles) / np.diff(self.times)
        return float(speed.min()), float(speed.max())

    @property
    def mean_speed(self) -> float:
        """Mean angular speed over the mapped span [rad/s]."""
        return float((self.angles[-1] - self.angles[0]) / (self.times[-1] - self.times[0]))


def cycle_phase_from_pressure(
    angle_map: AngleMap,
    pressure: npt.ArrayLike,
    sample_rate: float,
    *,
    start_time: float = 0.0,
    window: float = math.radians(30.0),
) -> float:
    """The shift (0 or 2 pi) that puts cylinder 1's firing TDC at cycle angle 0, from its pressure.

    Parameters
    ----------
    angle_map : AngleMap
        Map whose angle 0 (mod 2 pi) is a TDC of cylinder 1.
    pressure : array_like
        Cylinder 1's pressure (any unit) [Pa or V].
    sample_rate : float
        [Hz].
    start_time : float, optional
        Time of the first pressure sample [s].
    window : float, optional
        Half-width of the crank-angle window around each TDC [rad].

    Returns
    -------
    float
        0 if the TDCs at even multiples of 2 pi (0, 4 pi, ...) have the higher mean
        pressure, else 2 pi [rad].

    Raises
    ------
    SignalError
        With fewer than two TDCs of each kind, or no clear difference between them.
    """
    p = np.asarray(pressure, dtype=np.float64)
    t = start_time + np.arange(p.size) / sample_rate
    angle = angle_map.angle_at(t)
    valid = np.isfinite(angle)
    angle, p = angle[valid], p[valid]
    revolution = np.round(angle / (2 * math.pi))
    near = np.abs(angle - 2 * math.pi * revolution) < window
    even = near & (np.mod(revolution, 2) == 0)
    odd = near & (np.mod(revolution, 2) == 1)
    if np.unique(revolution[even]).size < 2 or np.unique(revolution[odd]).size < 2:
        raise SignalError("cycle phase: the recording needs at least two TDCs of each revolution kind")
    mean_even = np.array([p[even & (revolution == r)].mean() for r in np.unique(revolution[even])])
    mean_odd = np.array([p[odd & (revolution == r)].mean() for r in np.unique(revolution[odd])])
    if mean_even.min() > mean_odd.max():
        return 0.0
    if mean_odd.min() > mean_even.max():
        return 2 * math.pi
    raise SignalError(
        "cycle phase: the pressure around TDC does not separate the firing revolution from the other "
        "(no firing, or a misfiring cylinder 1); give the phase explicitly or use a cam channel"
    )


def _harmonic_candidates(
    angles: FloatArray,
    span: FloatArray,
    gaps: npt.NDArray[np.int64],
    pitch: float,
    cycle: float,
    harmonics: int,
) -> list[int]:
    """The numbers of harmonics tried for the cycle's shape.

    The places of intervals in a cycle (a gap's pitches share one) sample the shape; the number of
    harmonics fitted is the one, of every number from a quarter to nearly a half of the places, whose
    fit predicts each place best from the others (leave-one-out): more follow a sharper shape, fewer
    keep a noisy one from swinging where no pulse sees it. Every number is tried, not a few: a 16
    cylinder V four-stroke's speed, once a baseline's pitch errors are taken out, is its firing
    harmonics up to the 48th of the cycle, which a quarter (29 of a 60-2 wheel's 116 places) and a
    third (38) leave half unexplained and nearly a half (56, of 113 coefficients) fits to the noise;
    between 48 and 53 the fit predicts the places a thousand times better, and the gap, filled on some
    recordings and not on others of the same engine, moved its whole orders by many standard errors
    (tests/signal/test_gap_harmonics.py). The places are counted gap by gap, each
    with its own length: one length for all put 68 places in a 36-2-1 wheel's cycle of 66, and 65
    coefficients fitted to them swung its teeth's pitch errors into orders 1 to 4 seven times over
    (tests/signal/test_pitch_systematic.py).
    """
    # each gap of the cycle by its place, with its own length (a wheel may have gaps of several)
    where = np.round(np.mod(angles[gaps], cycle) / pitch)
    lengths = np.rint(span[gaps] / pitch)
    hidden = sum(float(np.median(lengths[where == w])) - 1 for w in np.unique(where))
    places_per_cycle = round(cycle / pitch - hidden)
    return sorted(
        {min(int(harmonics), c) for c in range(places_per_cycle // 4, (places_per_cycle - 3) // 2 + 1)} - {0}
    )


@dataclass(frozen=True)
class _CyclePlaces:
    """The intervals of a map at one place in the cycle, averaged: one row per place.

    Attributes
    ----------
    which : ndarray of int
        Each interval's place.
    count : ndarray of int
        Intervals at each place.
    mean : ndarray
        Their mean relative slowness [-].
    start, width : ndarray
        Their mean cycle angle at the start, and mean angle [rad].
    """

    which: npt.NDArray[np.int64]
    count: npt.NDArray[np.int64]
    mean: FloatArray
    start: FloatArray
    width: FloatArray

    @classmethod
    def of(
        cls, angles: FloatArray, span: FloatArray, relative: FloatArray, cycle: float, pitch: float
    ) -> _CyclePlaces:
        """The places of the intervals between ``angles`` (``span`` wide, ``relative`` slowness)."""
        place = np.round(np.mod(angles[:-1], cycle) / (1e-3 * pitch)).astype(np.int64)
        # the places are small non-negative codes (at most 1000 per pitch of a cycle): numbered by a
        # count of each code, in one pass instead of a sort of every interval of the recording
        present = np.bincount(place) > 0
        which = (np.cumsum(present) - 1)[place]
        count = np.bincount(which)
        mean = np.bincount(which, relative) / count
        start = np.bincount(which, np.mod(angles[:-1], cycle)) / count
        width = np.bincount(which, span) / count
        return cls(which, count, mean, start, width)


@dataclass(frozen=True)
class _CycleShape:
    """The relative slowness that repeats every cycle: a mean, then cosine and sine terms at ``w``."""

    coefficients: FloatArray
    w: FloatArray
    cycle: float

    def integral(self, x: FloatArray) -> FloatArray:
        """The shape's integral from 0 to each cycle angle in ``x``."""
        h_count = self.w.size
        x = x[:, None]
        return np.asarray(
            self.coefficients[0] * x[:, 0]
            + (np.sin(self.w * x) / self.w) @ self.coefficients[1 : h_count + 1]
            + ((1 - np.cos(self.w * x)) / self.w) @ self.coefficients[h_count + 1 :]
        )

    @cached_property
    def full(self) -> float:
        """The shape's integral over a whole cycle."""
        return float(self.integral(np.array([self.cycle]))[0])

    def elapsed(self, x: FloatArray) -> FloatArray:
        """The shape's integral from cycle angle 0 to each (absolute) angle in ``x``."""
        turns = np.floor(x / self.cycle)
        return np.asarray(turns * self.full + self.integral(x - turns * self.cycle))


def _fit_cycle_shape(
    places: _CyclePlaces, candidates: list[int], cycle: float
) -> tuple[_CycleShape, FloatArray] | None:
    """The shape fitted by least squares to the places' means, with the number of harmonics whose fit
    predicts each place best from the others (leave-one-out), and its fit at every place; None where
    no fit is well posed."""
    # one QR of the design with every candidate's harmonics, ordered by harmonic (the mean, then each
    # harmonic's two terms): a candidate's design is its leading columns, and their QR the leading part
    # of the whole one (Householder reflections take the columns in order)
    most = max(candidates)
    w_all = np.asarray(2 * math.pi / cycle * np.arange(1, most + 1), dtype=np.float64)
    means = _interval_means(places.start, places.start + places.width, w_all)
    by_harmonic = np.concatenate(
        [[0], np.column_stack([1 + np.arange(most), 1 + most + np.arange(most)]).ravel()]
    )
    design_all = means[:, by_harmonic]
    root = np.sqrt(places.count)
    q_all, r_all = np.linalg.qr(design_all * root[:, None])
    projected = q_all.T @ (places.mean * root)
    best: tuple[float, FloatArray, int] | None = None
    for h_count in candidates:
        m = 1 + 2 * h_count
        r, q = r_all[:m, :m], q_all[:, :m]
        if not np.all(np.abs(np.diag(r)) > 1e-12):
            continue
        fitted = np.linalg.solve(r, projected[:m])
        leverage = np.minimum((q**2).sum(axis=1), 1 - 1e-9)
        residual = (design_all[:, :m] @ fitted - places.mean) * root / (1 - leverage)
        score = float(residual @ residual)
        if best is None or score < best[0]:
            best = (score, np.asarray(fitted, dtype=np.float64), h_count)
    if best is None:
        return None
    _, fitted, h_count = best
    # back to the shape's order: the mean, the cosine terms, then the sine terms
    coefficients = np.concatenate([fitted[:1], fitted[1::2], fitted[2::2]])
    shape = _CycleShape(coefficients, w_all[:h_count], cycle)
    return shape, np.asarray(design_all[:, : 1 + 2 * h_count] @ fitted)


def _missing_teeth(
    angles: FloatArray, span: FloatArray, gaps: npt.NDArray[np.int64], pitch: float
) -> tuple[npt.NDArray[np.int64], FloatArray]:
    """The pulse before each missing tooth (its gap's), and the missing teeth's angles [rad]."""
    pitches = np.rint(span[gaps] / pitch).astype(np.int64)
    gaps, pitches = gaps[pitches >= 2], pitches[pitches >= 2]
    inside = np.repeat(gaps, pitches - 1)
    step = np.concatenate([np.arange(1, k) for k in pitches]) if gaps.size else np.zeros(0)
    missing = angles[inside] + span[inside] * step / np.repeat(pitches, pitches - 1)
    return inside, missing


def _interval_means(start: FloatArray, end: FloatArray, w: FloatArray) -> FloatArray:
    """Each interval ``[start, end]``'s mean of 1, cos(w x) and sin(w x), shape (intervals, 1 + 2 w.size)."""
    a, b = start[:, None], end[:, None]
    return np.hstack(
        [
            np.ones((start.size, 1)),
            (np.sin(w * b) - np.sin(w * a)) / (w * (b - a)),
            (np.cos(w * a) - np.cos(w * b)) / (w * (b - a)),
        ]
    )


def _crossing(spline: QuinticSpline, target: FloatArray, low: FloatArray, high: FloatArray) -> FloatArray:
    """Where a spline increasing over ``[low, high]`` reaches ``target``, by bisection to round-off."""
    low, high = np.asarray(low, dtype=np.float64), np.asarray(high, dtype=np.float64)
    for _ in range(60):
        middle = 0.5 * (low + high)
        ahead = spline(middle) >= target
        high, low = np.where(ahead, middle, high), np.where(ahead, low, middle)
    return np.asarray(0.5 * (low + high))


@numba.njit(cache=True, nogil=True)
def _invert(
    c: FloatArray,
    times: FloatArray,
    angles: FloatArray,
    target: FloatArray,
    first: float,
    increment: float,
    offset: int,
    slack: float,
    out: FloatArray,
) -> None:  # pragma: no cover - compiled
    """Solve ``c[:, i] (t - t_i) = angle`` on the piece ``i`` of each angle (monotone cubic); NaN outside.

    The angles are ``target``, or, when it is empty, ``first + increment * (offset + p)`` for each ``p`` of
    ``out`` (a uniform grid, never made).
    """
    last = angles.size - 1
    i, solved = 0, -1  # the piece, and the one of the last solution (its angle, offset and slope)
    a_before = s_before = slope_before = 0.0
    given = target.size > 0
    for p in range(out.size):
        a = target[p] if given else first + increment * float(offset + p)
        if not (angles[0] - slack <= a <= angles[last] + slack):
            out[p] = np.nan
            continue
        a = min(max(a, angles[0]), angles[last])
        if not angles[i] <= a < angles[i + 1]:  # sorted targets: the piece is this one or a next one
            if a >= angles[i + 1] and (i + 2 > last - 1 or a < angles[i + 2]):
                i = min(i + 1, last - 1)
            else:
                i = min(max(np.searchsorted(angles, a, side="right") - 1, 0), last - 1)
        h = times[i + 1] - times[i]
        c0, c1, c2, c3 = c[0, i], c[1, i], c[2, i], c[3, i] - a
        lo, hi = 0.0, h
        if solved == i and slope_before > 0.0:  # sorted targets: a step from the last solution
            s = min(max(s_before + (a - a_before) / slope_before, 0.0), h)
        else:
            s = (a - angles[i]) / (angles[i + 1] - angles[i]) * h
        for _ in range(100):
            value = ((c0 * s + c1) * s + c2) * s + c3
            if value == 0.0:
                break
            if value < 0.0:
                lo = s
            else:
                hi = s
            slope = (3.0 * c0 * s + 2.0 * c1) * s + c2
            step = s - value / slope if slope > 0.0 else -1.0
            if not lo < step < hi:
                step = 0.5 * (lo + hi)  # Newton left the bracket: bisect
            if abs(step - s) <= 1e-15 * h:
                s = step
                break
            s = step
        out[p] = times[i] + s
        solved, a_before, s_before = i, a, s
        slope_before = (3.0 * c0 * s + 2.0 * c1) * s + c2
