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
from scipy.interpolate import PchipInterpolator, make_interp_spline

from monitor.signal.pulses import SignalError
from monitor.types import FloatArray

__all__ = ["AngleMap", "cycle_phase_from_cam", "cycle_phase_from_pressure"]

_SPEED_WINDOW = 1 << 14  # pulses per window of the speed spline
_SPEED_OVERLAP = 64  # pulses added on each side of a window


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
        inside = np.flatnonzero((flat >= self.times[0]) & (flat <= self.times[-1]))
        n = self.times.size
        if n <= 5:
            out[inside] = (self.angles[-1] - self.angles[0]) / (self.times[-1] - self.times[0])
            return out.reshape(t.shape)
        queried = flat[inside]
        starts = self.times[::_SPEED_WINDOW][1:]  # first pulse of every window but the first
        if np.all(queried[1:] >= queried[:-1]):  # sorted (a grid): each window's queries are one run
            order = np.arange(queried.size)
            bounds = np.concatenate([[0], np.searchsorted(queried, starts, side="right"), [queried.size]])
        else:
            window = np.searchsorted(starts, queried, side="right")
            order = np.argsort(window, kind="stable")
            bounds = np.searchsorted(window[order], np.arange(starts.size + 2))
        for w in range(bounds.size - 1):
            chosen = inside[order[bounds[w] : bounds[w + 1]]]
            if chosen.size == 0:
                continue
            lo = max(0, w * _SPEED_WINDOW - _SPEED_OVERLAP)
            hi = min(n, (w + 1) * _SPEED_WINDOW + 1 + _SPEED_OVERLAP)
            spline = make_interp_spline(self.times[lo:hi], self.angles[lo:hi], k=5 if hi - lo > 5 else 1)
            out[chosen] = spline.derivative()(flat[chosen])
        return out.reshape(t.shape)

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
        out = np.empty(flat.shape)
        slack = 1e-12 * (abs(self.angles[0]) + abs(self.angles[-1]))  # round-off at the span's ends
        coefficients = self._forward.c  # the cubic of each piece, powers of (t - t0): shape (4, pieces)
        workers = min(os.cpu_count() or 1, max(1, flat.size // (1 << 20)))
        bounds = np.linspace(0, flat.size, workers + 1).astype(np.int64)
        with ThreadPoolExecutor(max_workers=workers) as pool:  # the compiled loop releases the GIL
            for job in [
                pool.submit(_invert, coefficients, self.times, self.angles, flat[a:b], slack, out[a:b])
                for a, b in itertools.pairwise(bounds)
            ]:
                job.result()
        return out.reshape(target.shape)

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


def cycle_phase_from_cam(angle_map: AngleMap, cam_times: npt.ArrayLike, *, cam_angle: float) -> float:
    """The shift (0 or 2 pi) from a once-per-cycle cam pulse at ``cam_angle`` in the cycle.

    Parameters
    ----------
    angle_map : AngleMap
        Map whose angle 0 (mod 2 pi) is a TDC of cylinder 1.
    cam_times : array_like
        Cam pulse times [s].
    cam_angle : float
        Cycle angle of the cam pulse after cylinder 1's firing TDC, 0..4 pi [rad].

    Returns
    -------
    float
        0 or 2 pi [rad].
    """
    angles = angle_map.angle_at(np.asarray(cam_times, dtype=np.float64))
    angles = angles[np.isfinite(angles)]
    if angles.size == 0:
        raise SignalError("cycle phase: no cam pulse inside the mapped span")
    shift = np.mod(cam_angle - angles, 4 * math.pi)
    # every pulse must agree on a shift of 0 or 2 pi (within 90 degrees)
    candidates = np.round(shift / (2 * math.pi)) % 2
    if not (
        np.all(candidates == candidates[0])
        and np.all(np.abs(shift - 2 * math.pi * np.round(shift / (2 * math.pi))) < math.pi / 2)
    ):
        raise SignalError("cycle phase: the cam pulses do not fall once per cycle at the stated angle")
    return float(2 * math.pi * candidates[0])


@numba.njit(cache=True, nogil=True)
def _invert(
    c: FloatArray, times: FloatArray, angles: FloatArray, target: FloatArray, slack: float, out: FloatArray
) -> None:  # pragma: no cover - compiled
    """Solve ``c[:, i] (t - t_i) = angle`` on the piece ``i`` of each angle (monotone cubic); NaN outside."""
    last = angles.size - 1
    i, solved = 0, -1  # the piece, and the one of the last solution (its angle, offset and slope)
    a_before = s_before = slope_before = 0.0
    for p in range(target.size):
        a = target[p]
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
