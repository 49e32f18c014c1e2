"""Resampling to the crank-angle domain, and order spectra of angle-domain signals.

Resampling.  A channel sampled in time is evaluated at a uniform crank-angle
grid of ``N`` samples per cycle (per revolution on a two-stroke, per two
revolutions on a four-stroke), whole cycles only, cycle angle 0 at (firing)
TDC of cylinder 1.  Steps:

1. times of the grid angles from the angle map's monotone inverse;
2. anti-alias filtering: the angle-domain Nyquist order ``N / (2 R)`` (``R``
   revolutions per cycle) is reached in time at the lowest speed of the
   recording, so a zero-phase Butterworth low-pass (``sosfiltfilt``, orders'
   phases untouched) at ``cutoff`` of that frequency removes what would alias;
   it is skipped when it would not be below the time-domain Nyquist;
3. interpolation of the filtered samples at those times with B-splines of
   order 1 (linear), 3 or 5 (``scipy.ndimage.map_coordinates``).

Order spectra.  The angle-domain signal is cut into blocks of whole cycles;
each block's real FFT, scaled to peak amplitudes, gives complex order
amplitudes (phase relative to TDC of cylinder 1, under the convention of
:mod:`monitor.orders`).  Their complex mean over the blocks is the
synchronous average's spectrum; the spread of the magnitudes over the
blocks is reported beside it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt
from scipy.ndimage import map_coordinates
from scipy.signal import butter, sosfiltfilt

from monitor.orders import scaled_rfft
from monitor.signal.anglemap import AngleMap
from monitor.signal.pulses import SignalError
from monitor.types import ComplexArray, FloatArray

__all__ = [
    "AngleDomainSignal",
    "OrderSpectrum",
    "OrderSpeedMap",
    "order_spectrum",
    "order_speed_map",
    "to_angle_domain",
]


@dataclass(frozen=True)
class AngleDomainSignal:
    """A channel on a uniform crank-angle grid.

    Attributes
    ----------
    values : ndarray, shape (n_cycles, samples_per_cycle)
        Samples, one row per cycle, in the channel's unit.
    first_cycle : int
        Index of the first cycle (cycle ``c`` starts at cycle angle ``c x cycle``).
    samples_per_cycle : int
    cycle_revolutions : int
        1 two-stroke, 2 four-stroke.
    cutoff_hz : float or None
        Anti-alias cutoff applied [Hz]; None when no filter was needed.
    interpolation_order : int
    """

    values: FloatArray
    first_cycle: int
    samples_per_cycle: int
    cycle_revolutions: int
    cutoff_hz: float | None
    interpolation_order: int

    @property
    def angle(self) -> FloatArray:
        """Cycle angle of every sample, shape of ``values`` [rad]."""
        cycle = 2 * math.pi * self.cycle_revolutions
        step = cycle / self.samples_per_cycle
        rows = (self.first_cycle + np.arange(self.values.shape[0]))[:, None] * cycle
        return rows + step * np.arange(self.samples_per_cycle)[None, :]


def to_angle_domain(
    signal: npt.ArrayLike,
    sample_rate: float,
    angle_map: AngleMap,
    *,
    samples_per_cycle: int,
    cycle_revolutions: int = 1,
    start_time: float = 0.0,
    interpolation_order: Literal[1, 3, 5] = 3,
    anti_alias: bool = True,
    cutoff: float = 0.8,
) -> AngleDomainSignal:
    """Resample a time-domain channel to whole cycles of a uniform crank-angle grid.

    Parameters
    ----------
    signal : array_like, shape (n,)
        Samples [the channel's unit].
    sample_rate : float
        [Hz].
    angle_map : AngleMap
        Crank (cycle) angle against time.
    samples_per_cycle : int
        Grid points per cycle, even.
    cycle_revolutions : int, optional
        1 (two-stroke or per-revolution analysis) or 2 (four-stroke cycle).
    start_time : float, optional
        Time of the first sample [s].
    interpolation_order : {1, 3, 5}, optional
        B-spline order of the interpolation in time.
    anti_alias : bool, optional
        Low-pass before resampling (see the module docstring).
    cutoff : float, optional
        Filter cutoff as a fraction of the angle-domain Nyquist frequency at the lowest speed [-].

    Returns
    -------
    AngleDomainSignal

    Raises
    ------
    SignalError
        For a bad grid, non-finite samples, or a recording shorter than one cycle.
    """
    x = np.asarray(signal, dtype=np.float64)
    if x.ndim != 1 or x.size < 4:
        raise SignalError(f"signal has shape {x.shape}: expected a 1-D channel")
    if not np.all(np.isfinite(x)):
        raise SignalError(
            "signal has NaN or Inf samples: mask them (see the reader's report) before resampling"
        )
    if samples_per_cycle < 8 or samples_per_cycle % 2:
        raise SignalError(f"samples_per_cycle = {samples_per_cycle!r}: expected an even number >= 8")
    if cycle_revolutions not in (1, 2):
        raise SignalError(f"cycle_revolutions = {cycle_revolutions!r}: expected 1 or 2")
    if interpolation_order not in (1, 3, 5):
        raise SignalError(f"interpolation_order = {interpolation_order!r}: expected 1, 3 or 5")
    cycle = 2 * math.pi * cycle_revolutions
    t_end = start_time + (x.size - 1) / sample_rate
    lo = max(angle_map.angles[0], float(angle_map.angle_at(max(start_time, angle_map.times[0]))))
    hi = min(angle_map.angles[-1], float(angle_map.angle_at(min(t_end, angle_map.times[-1]))))
    first = math.ceil(lo / cycle - 1e-12)
    last = math.floor(hi / cycle + 1e-12)
    n_cycles = last - first
    if n_cycles < 1:
        raise SignalError("the recording covers less than one whole cycle of the angle map")
    grid = first * cycle + (cycle / samples_per_cycle) * np.arange(n_cycles * samples_per_cycle)
    times = angle_map.time_at(grid)
    times[0] = max(times[0], start_time)  # guard the ends against round-off just outside the span
    times[-1] = min(times[-1], t_end)
    cutoff_hz = None
    if anti_alias:
        speed = angle_map.speed_at(np.linspace(angle_map.times[0], angle_map.times[-1], 1000))
        slowest = float(np.nanmin(speed)) / (2 * math.pi)  # rev/s
        nyquist_order = samples_per_cycle / (2 * cycle_revolutions)
        candidate = cutoff * nyquist_order * slowest
        if candidate < 0.45 * sample_rate:
            cutoff_hz = candidate
            sos = butter(8, cutoff_hz, fs=sample_rate, output="sos")
            x = sosfiltfilt(sos, x)
    position = (times - start_time) * sample_rate
    values = map_coordinates(x, position[None, :], order=interpolation_order, mode="nearest", prefilter=True)
    return AngleDomainSignal(
        values.reshape(n_cycles, samples_per_cycle),
        first,
        samples_per_cycle,
        cycle_revolutions,
        cutoff_hz,
        interpolation_order,
    )


@dataclass(frozen=True)
class OrderSpectrum:
    """Complex order amplitudes of a channel, averaged over blocks of whole cycles.

    Attributes
    ----------
    orders : ndarray, shape (n_orders,)
        0, then steps of ``1 / cycle_revolutions`` [-].
    amplitude : ndarray, shape (n_orders,)
        Complex mean over the blocks (peak amplitude, phase relative to TDC of
        cylinder 1), in the channel's unit.
    magnitude_mean, magnitude_std : ndarray, shape (n_orders,)
        Mean and standard deviation of the blocks' magnitudes.
    blocks : int
        Blocks averaged.
    block_cycles : int
        Cycles per block.
    """

    orders: FloatArray
    amplitude: ComplexArray
    magnitude_mean: FloatArray
    magnitude_std: FloatArray
    blocks: int
    block_cycles: int

    @property
    def magnitude(self) -> FloatArray:
        """|amplitude| (of the synchronous average) in the channel's unit."""
        return np.abs(self.amplitude)

    @property
    def phase(self) -> FloatArray:
        """Phase of the synchronous average [rad]."""
        return np.angle(self.amplitude)


def order_spectrum(
    signal: AngleDomainSignal, *, block_cycles: int = 1, max_order: float | None = None
) -> OrderSpectrum:
    """Order spectrum over blocks of whole cycles.

    Parameters
    ----------
    signal : AngleDomainSignal
    block_cycles : int, optional
        Cycles per block; a longer block resolves finer orders (``1 / (block_cycles R)``).
    max_order : float, optional
        Highest order kept [-].

    Returns
    -------
    OrderSpectrum
    """
    n_cycles, n = signal.values.shape
    if not 1 <= block_cycles <= n_cycles:
        raise SignalError(f"block_cycles = {block_cycles!r}: expected 1..{n_cycles} (cycles in the signal)")
    blocks = n_cycles // block_cycles
    data = signal.values[: blocks * block_cycles].reshape(blocks, block_cycles * n)
    spectra = scaled_rfft(data)
    resolution = 1.0 / (block_cycles * signal.cycle_revolutions)
    orders = resolution * np.arange(spectra.shape[-1], dtype=np.float64)
    keep = orders <= (max_order if max_order is not None else orders[-1]) + 1e-12
    spectra = spectra[:, keep]
    magnitudes = np.abs(spectra)
    return OrderSpectrum(
        orders=orders[keep],
        amplitude=spectra.mean(axis=0),
        magnitude_mean=magnitudes.mean(axis=0),
        magnitude_std=magnitudes.std(axis=0, ddof=1) if blocks > 1 else np.zeros(int(keep.sum())),
        blocks=blocks,
        block_cycles=block_cycles,
    )


@dataclass(frozen=True)
class OrderSpeedMap:
    """Order amplitudes against crank speed (a run-up or run-down).

    Attributes
    ----------
    speed : ndarray, shape (n_bins,)
        Bin centres [rad/s].
    orders : ndarray, shape (n_orders,)
        [-].
    amplitude : ndarray, shape (n_bins, n_orders)
        Mean magnitude of the cycles in each speed bin, in the channel's unit; NaN
        where a bin holds no cycle, or where the order's frequency at the bin's
        upper speed exceeds 0.6 of the anti-alias cutoff (it would be attenuated).
    cycles : ndarray of int, shape (n_bins,)
        Cycles per bin.
    """

    speed: FloatArray
    orders: FloatArray
    amplitude: FloatArray
    cycles: npt.NDArray[np.int64]


def order_speed_map(
    signal: AngleDomainSignal, angle_map: AngleMap, *, bins: int = 40, max_order: float | None = None
) -> OrderSpeedMap:
    """Order amplitudes of every cycle, binned by the cycle's mean speed.

    Parameters
    ----------
    signal : AngleDomainSignal
        The channel resampled with the same angle map.
    angle_map : AngleMap
        Gives each cycle's duration, hence its mean speed.
    bins : int, optional
        Speed bins between the slowest and the fastest cycle.
    max_order : float, optional
        Highest order kept [-].

    Returns
    -------
    OrderSpeedMap
    """
    if bins < 1:
        raise SignalError(f"bins = {bins!r}: expected at least one speed bin")
    n_cycles = signal.values.shape[0]
    cycle = 2 * math.pi * signal.cycle_revolutions
    edges_angle = (signal.first_cycle + np.arange(n_cycles + 1)) * cycle
    times = angle_map.time_at(edges_angle)
    speed = cycle / np.diff(times)
    magnitude = np.abs(scaled_rfft(signal.values))
    orders = np.arange(magnitude.shape[-1], dtype=np.float64) / signal.cycle_revolutions
    keep = orders <= (max_order if max_order is not None else orders[-1]) + 1e-12
    lo, hi = float(np.nanmin(speed)), float(np.nanmax(speed))
    edges = np.linspace(lo, hi if hi > lo else lo * (1 + 1e-9) + 1e-12, bins + 1)
    which = np.clip(np.searchsorted(edges, speed, side="right") - 1, 0, bins - 1)
    amplitude = np.full((bins, int(keep.sum())), np.nan)
    counts = np.bincount(which, minlength=bins).astype(np.int64)
    for b in np.flatnonzero(counts):
        amplitude[b] = magnitude[which == b][:, keep].mean(axis=0)
    centres = 0.5 * (edges[:-1] + edges[1:])
    if signal.cutoff_hz is not None:
        # an order whose frequency in a bin exceeds 0.6 of the anti-alias cutoff was attenuated (by more
        # than 3e-4, Butterworth 8 forward and back): not reported
        fastest = edges[1:] / (2 * math.pi)
        amplitude[np.multiply.outer(fastest, orders[keep]) > 0.6 * signal.cutoff_hz] = np.nan
    return OrderSpeedMap(centres, orders[keep], amplitude, counts)
