"""Resampling to the crank-angle domain, and order spectra of angle-domain signals.

Resampling.  A channel sampled in time is evaluated at a uniform crank-angle
grid of ``N`` samples per cycle (per revolution on a two-stroke, per two
revolutions on a four-stroke), whole cycles only, cycle angle 0 at (firing)
TDC of cylinder 1.  The times of the grid angles come from the angle map's
monotone inverse.  The angle-domain Nyquist order ``N / (2 R)`` (``R``
revolutions per cycle) is reached in time at the lowest speed of the
recording: that is the stopband edge of the anti-alias low-pass; its
passband edge is the highest order wanted at the fastest speed (or
``cutoff`` of the stopband edge).

The default kernel does the anti-alias filtering and the interpolation in
one step, computing only the output samples: each grid time's value is the
channel convolved with a continuous windowed-sinc low-pass (Kaiser window,
passband ripple and stopband 1e-5) evaluated at that time,

    y(t) = sum_n x[n] h(t fs - n),

so a sample is as many multiply-adds as the kernel is long (the filter's
transition band sets its length), whatever the decimation.  ``h`` is
tabulated at ``_PHASES`` (1024) fractions of a sample and each time rounded
to the nearest; the loop is compiled with numba and runs in the samples'
stored precision (float32 recordings in float32).  The filter is zero-phase:
the orders' phases are untouched.

The second kernel, for filters too long for the first (more than
``_FUSED_TAPS_PER_INPUT`` taps per input sample between grid points: a narrow
transition band at a high sampling rate), for comparison (``interpolation_order``
1, 3 or 5), and without anti-aliasing: a linear-phase FIR low-pass applied through FFTs,
decimation to at least ``OVERSAMPLING`` (10) times the passband edge, then
B-spline interpolation of that order (prefilter and evaluation compiled with
numba, the splines of ``scipy.ndimage.map_coordinates``); at the passband
edge cubic splines are within 4e-4 of a sine's amplitude, at a tenth of it
within 1e-7.  docs/accuracy-vs-time.md compares the two.

The channel is processed in blocks of whole cycles (about 2^18 input
samples and a margin on each side for the kernel), read by slices: a
channel in an HDF5 file is never held whole in memory.

Order spectra.  The angle-domain signal is cut into blocks of whole cycles;
each block's real FFT, scaled to peak amplitudes, gives complex order
amplitudes (phase relative to TDC of cylinder 1, under the convention of
:mod:`monitor.fourier`).  Their complex mean over the blocks is the
synchronous average's spectrum; the spread of the magnitudes over the
blocks is reported beside it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import cached_property, lru_cache
from typing import Any, Literal, Protocol

import numba
import numpy as np
import numpy.typing as npt

from monitor.errors import SignalError
from monitor.fourier import scaled_rfft
from monitor.runtime.timing import StageClock, stage
from monitor.signal.anglemap import AngleMap
from monitor.types import ComplexArray, FloatArray

__all__ = [
    "OVERSAMPLING",
    "AngleDomainSignal",
    "AngleGrid",
    "HighFrequencyPower",
    "OrderSpectrum",
    "OrderSpectrumStream",
    "OrderSpeedMap",
    "Samples",
    "angle_domain_spectrum",
    "angle_grid",
    "impact_band",
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
        Passband edge of the anti-alias filter applied [Hz]; None when no filter was needed.
    interpolation : str
        How the samples were found: "band-limited" (the fused windowed-sinc kernel), "B-spline 1",
        "B-spline 3" or "B-spline 5" (FFT filter, decimation, splines), or what made them otherwise.
    high_frequency : HighFrequencyPower or None
        The crank-angle profile of the channel's high-frequency power, when asked for.
    """

    values: FloatArray
    first_cycle: int
    samples_per_cycle: int
    cycle_revolutions: int
    cutoff_hz: float | None
    interpolation: str
    high_frequency: HighFrequencyPower | None = None

    @property
    def angle(self) -> FloatArray:
        """Cycle angle of every sample, shape of ``values`` [rad]."""
        cycle = 2 * math.pi * self.cycle_revolutions
        step = cycle / self.samples_per_cycle
        rows = (self.first_cycle + np.arange(self.values.shape[0]))[:, None] * cycle
        return rows + step * np.arange(self.samples_per_cycle)[None, :]


@dataclass(frozen=True)
class HighFrequencyPower:
    """Where in the cycle a channel's high-frequency content lies: impacts, knocks, rattles.

    For each bin of the cycle (the grid's intervals, split evenly into at least
    :data:`HIGH_FREQUENCY_BINS_PER_REVOLUTION` per revolution, and into bins no
    longer than :data:`HIGH_FREQUENCY_BIN_SECONDS` at the slowest speed) the mean square
    of the time-domain samples band-passed to :attr:`band_hz` (linear-phase FIR,
    Kaiser window, applied centred so that an impact stays at its crank angle):
    from :data:`IMPACT_BAND_HZ` ``[0]`` (1 kHz, or an eighth of the sampling
    rate if that is lower), above the smooth, low-order response of the
    structure, up to :data:`IMPACT_BAND_HZ` ``[1]`` (10 kHz) or the Nyquist
    frequency, where bearing knocks ring the structure's resonances.  Every
    frequency in the band weighs the same, so a 2 kHz ring counts as much as
    an 8 kHz one.  Averaged over the cycles in the channel's unit squared:
    compare profiles of one sensor at one sampling rate and band only.

    Attributes
    ----------
    mean, std : ndarray, shape (bins,)
        Mean over the cycles of each bin's power, and its standard deviation
        over the cycles [unit^2].
    cycles : int
        Cycles averaged.
    sample_rate : float
        Of the channel [Hz].
    band_hz : tuple of float
        The pass band's edges [Hz] (NaN for a profile whose band is not known).
    speed_rpm : float
        Mean speed over the cycles averaged [rpm] (NaN where not known): turns a bin's angle to time.
    """

    mean: FloatArray
    std: FloatArray
    cycles: int
    sample_rate: float
    band_hz: tuple[float, float] = (math.nan, math.nan)
    speed_rpm: float = math.nan

    @property
    def bin_angle(self) -> FloatArray:
        """Cycle angle at the start of each bin, as a fraction of the cycle [-]."""
        return np.arange(self.mean.size) / self.mean.size

    def coarsened(self, bins: int) -> HighFrequencyPower:
        """The profile on ``bins`` bins, each the mean of consecutive ones (their spreads independent).

        Raises
        ------
        SignalError
            Where ``bins`` does not divide the profile's.
        """
        k, rest = divmod(self.mean.size, bins)
        if rest or k < 1:
            raise SignalError(f"a profile of {self.mean.size} bins cannot be coarsened to {bins}")
        if k == 1:
            return self
        mean = self.mean.reshape(bins, k).mean(axis=1)
        std = np.sqrt((self.std.reshape(bins, k) ** 2).sum(axis=1)) / k
        return replace(self, mean=mean, std=std)


class Samples(Protocol):
    """A 1-D channel that can be read by slices: a numpy array, an h5py dataset, a streamed reader."""

    @property
    def shape(self) -> tuple[int, ...]: ...

    def __getitem__(self, index: slice, /) -> Any: ...


@dataclass(frozen=True)
class AngleGrid:
    """Whole cycles of a uniform cycle-angle grid and the times the crank reaches them.

    Attributes
    ----------
    first_cycle : int
        Index of the first cycle (cycle ``c`` starts at cycle angle ``c x cycle``).
    samples_per_cycle : int
    cycle_revolutions : int
    times : ndarray, shape (n_cycles * samples_per_cycle,)
        Time of every grid angle [s].
    """

    first_cycle: int
    samples_per_cycle: int
    cycle_revolutions: int
    times: FloatArray

    @property
    def cycles(self) -> int:
        """Whole cycles in the grid."""
        return self.times.size // self.samples_per_cycle


def angle_grid(
    angle_map: AngleMap,
    start_time: float,
    end_time: float,
    *,
    samples_per_cycle: int,
    cycle_revolutions: int = 1,
    known: list[AngleGrid] | None = None,
) -> AngleGrid:
    """The whole cycles that both the angle map and the span ``[start_time, end_time]`` cover.

    Parameters
    ----------
    angle_map : AngleMap
    start_time, end_time : float
        The channel's first and last sample times [s].
    samples_per_cycle : int
        Grid points per cycle, even, at least 8.
    cycle_revolutions : int, optional
        1 or 2.
    known : list of AngleGrid, optional
        Grids already computed with the same map: one with the same cycles is returned as it is, or
        every k-th of its times taken when it is k times finer.

    Returns
    -------
    AngleGrid

    Raises
    ------
    SignalError
        For a bad grid or a span shorter than one whole cycle.
    """
    if samples_per_cycle < 8 or samples_per_cycle % 2:
        raise SignalError(f"samples_per_cycle = {samples_per_cycle!r}: expected an even number >= 8")
    if cycle_revolutions not in (1, 2):
        raise SignalError(f"cycle_revolutions = {cycle_revolutions!r}: expected 1 or 2")
    cycle = 2 * math.pi * cycle_revolutions
    lo = max(angle_map.angles[0], float(angle_map.angle_at(max(start_time, angle_map.times[0]))))
    hi = min(angle_map.angles[-1], float(angle_map.angle_at(min(end_time, angle_map.times[-1]))))
    first = math.ceil(lo / cycle - 1e-12)
    last = math.floor(hi / cycle + 1e-12)
    if last - first < 1:
        raise SignalError("the recording covers less than one whole cycle of the angle map")
    for other in known or []:
        cycles = (other.first_cycle, other.cycles, other.cycle_revolutions)
        finer = other.samples_per_cycle % samples_per_cycle == 0
        if cycles == (first, last - first, cycle_revolutions) and finer:  # as fine or finer: every k-th
            if other.samples_per_cycle == samples_per_cycle:
                return other
            stride = other.samples_per_cycle // samples_per_cycle
            times = np.ascontiguousarray(other.times[::stride])
            return AngleGrid(first, samples_per_cycle, cycle_revolutions, times)
    times = angle_map.time_at_steps(
        first * cycle, cycle / samples_per_cycle, (last - first) * samples_per_cycle
    )
    times[0] = max(times[0], start_time)  # guard the ends against round-off just outside the span
    times[-1] = min(times[-1], end_time)
    return AngleGrid(first, samples_per_cycle, cycle_revolutions, times)


# decimated rate over the passband edge: cubic B-splines then interpolate a sine at the edge to 4e-4
OVERSAMPLING = 10.0
_RIPPLE_DB = 100.0  # anti-alias FIR: passband ripple and stopband attenuation 1e-5
_SPLINE_MARGIN = 32  # decimated samples beyond the grid: the B-spline prefilter's edge effect < 1e-12
_BLOCK_SAMPLES = 1 << 18  # input samples per processed block
# bins of the high-frequency profile per revolution, at least: 0.7 deg, so that a knock's ring (about a
# millisecond, 4 deg at 600 rpm) fills its bins instead of being averaged with a grid interval's noise
HIGH_FREQUENCY_BINS_PER_REVOLUTION = 512
# and no bin longer than this at the slowest speed (a power of two per revolution, at most the cap), so
# that a slow engine's knock (a millisecond or two) is not averaged with several milliseconds of noise
HIGH_FREQUENCY_BIN_SECONDS = 0.5e-3
HIGH_FREQUENCY_MAX_BINS_PER_REVOLUTION = 8192
# the high-frequency profile's pass band: above the structure's low-order response (a 1500 rpm engine's
# 40th order is at 1 kHz), up to where knocks ring a machine frame's resonances [Hz]
IMPACT_BAND_HZ = (1000.0, 10000.0)
_IMPACT_BAND_DB = 80.0  # its stopband attenuation; the transition is half the lower edge wide


# the fused kernel's windowed sinc, tabulated at this many fractions of a sample; a position is rounded to
# the nearest, at most 1 / 2048 of a sample away: at the passband edge f_p that moves a sample's phase by at
# most pi f_p / (fs _PHASES), 2e-4 rad when f_p is fs / 15, and averages out over a recording's cycles
_PHASES = 1024
# its design attenuation: 10 dB beyond the 1e-5 of ripple and stopband wanted, because sampled at a sample's
# fraction the continuous kernel's images at multiples of the sampling rate add up in its passband (measured:
# 2.5e-5 at a 100 dB design, below 1e-5 at 110 dB; tests/signal/test_signal.py)
_FUSED_DESIGN_DB = 110.0
# a kernel longer than this many taps per input sample between grid points costs about as much as the FFT
# filter and splines (whose cost per input sample hardly depends on the filter's length; the forced rows of
# the angle-domain section of docs/accuracy-vs-time.md): a narrow transition band at a high sampling rate,
# or a grid much finer than the samples, takes that route instead
_FUSED_TAPS_PER_INPUT = 48.0


@dataclass(frozen=True)
class _BandLimited:
    """A continuous windowed-sinc low-pass, tabulated for evaluation at fractional sample positions.

    ``table[p, j]`` is ``h(p / phases + half - 1 - j)``, ``h`` in input samples, ``half`` the kernel's
    half length: the value at position ``u = n0 + p / phases`` is
    ``sum_j x[n0 - half + 1 + j] table[p, j]``.
    """

    table: FloatArray
    passband_hz: float
    stopband_hz: float

    @property
    def half(self) -> int:
        """Input samples the kernel reaches on each side of a position."""
        return int(self.table.shape[1] // 2)


@lru_cache(maxsize=16)  # the channels of a recording share one kernel
def _band_limited(passband_hz: float, stopband_hz: float, sample_rate: float) -> _BandLimited:
    """The fused kernel passing up to ``passband_hz`` and stopping from ``stopband_hz`` (at most Nyquist).

    Kaiser's design rules (Oppenheim & Schafer, Discrete-Time Signal Processing, 3rd ed., eqs. 7.62 and
    7.63): for an attenuation of ``A`` dB (here :data:`_FUSED_DESIGN_DB`) the window's shape is
    ``beta = 0.1102 (A - 8.7)`` and its length ``(A - 8) / (2.285 dw)`` samples, ``dw`` the transition
    width in radians per sample.  Each row of the
    table is scaled to a sum of one: a constant passes exactly at every fractional position.
    """
    beta = 0.1102 * (_FUSED_DESIGN_DB - 8.7)
    half = _fused_taps(passband_hz, stopband_hz, sample_rate) // 2
    cutoff = 0.5 * (passband_hz + stopband_hz) / sample_rate  # [cycles per sample]
    offsets = np.arange(_PHASES + 1)[:, None] / _PHASES + (half - 1) - np.arange(2 * half)[None, :]
    window = np.i0(beta * np.sqrt(np.clip(1.0 - (offsets / half) ** 2, 0.0, None))) / np.i0(beta)
    table = 2 * cutoff * np.sinc(2 * cutoff * offsets) * window
    table /= table.sum(axis=1, keepdims=True)
    return _BandLimited(np.ascontiguousarray(table), passband_hz, stopband_hz)


def _fused_taps(passband_hz: float, stopband_hz: float, sample_rate: float) -> int:
    """The fused kernel's length for this design [samples]."""
    width = 2 * math.pi * (stopband_hz - passband_hz) / sample_rate
    return 2 * max(2, math.ceil((_FUSED_DESIGN_DB - 8.0) / (2.285 * width) / 2))


@numba.njit(cache=True, nogil=True, fastmath=True)
def _resample(x: FloatArray, positions: FloatArray, table: FloatArray, out: FloatArray) -> None:
    """The band-limited value of ``x`` at each of ``positions`` (in samples of ``x``), into ``out``.

    Every position needs ``half`` samples of ``x`` before it and ``half`` after (the caller's margins).
    The sum runs in the precision of ``x`` and ``table`` (the same dtype); ``out`` may be wider.
    """  # pragma: no cover - compiled
    phases = table.shape[0] - 1
    taps = table.shape[1]
    half = taps // 2
    for k in range(positions.size):
        u = positions[k]
        n0 = math.floor(u)
        p = int((u - n0) * phases + 0.5)  # the nearest tabulated fraction (the last row is a whole sample)
        base = int(n0) - half + 1
        window = x[base : base + taps]  # a slice: indices known to be in range, so the loop vectorises
        weights = table[p]
        total = weights[0] - weights[0]  # zero in the table's dtype (weights[0] * 0 would be float64)
        for j in range(taps):
            total += window[j] * weights[j]
        out[k] = total


@dataclass(frozen=True)
class _AntiAlias:
    """Low-pass FIR (Kaiser window, linear phase, applied centred: zero phase) and the decimation after it.

    Applied by overlap-save over short segments, transformed together (many
    short real FFTs cost a third of one long one per sample).
    """

    taps: FloatArray
    decimation: int
    passband_hz: float

    @property
    def lead(self) -> int:
        """Input samples lost at each end of a segment: half the kernel, rounded up to the decimation."""
        return -(-(self.taps.size // 2) // self.decimation) * self.decimation

    @cached_property
    def segment(self) -> int:
        """Segment length: the decimation times a power of two, at least 16 leads."""
        return self.decimation * 2 ** math.ceil(math.log2(max(4096, 16 * self.lead) / self.decimation))

    @cached_property
    def response(self) -> FloatArray:
        """Real frequency response of the centred kernel on the segment's FFT grid (the bins kept)."""
        half = self.taps.size // 2
        kernel = np.zeros(self.segment)
        kernel[: half + 1] = self.taps[half:]
        kernel[self.segment - half :] = self.taps[:half]
        keep = self.segment // self.decimation // 2 + 1
        return np.ascontiguousarray(np.fft.rfft(kernel)[:keep].real)

    def apply(self, x: FloatArray) -> FloatArray:
        """Filtered samples at input samples ``lead``, ``lead + decimation``, ... of ``x``.

        Valid up to ``lead`` samples before the end of ``x``.
        """
        hop = self.segment - 2 * self.lead
        count = max(1, -(-(x.size - 2 * self.lead) // hop))
        padded = np.zeros(count * hop + 2 * self.lead, dtype=x.dtype)
        padded[: x.size] = x
        import scipy.fft as sp_fft  # where it is used: scipy's FFTs transform float32 in float32

        rows = np.lib.stride_tricks.sliding_window_view(padded, self.segment)[::hop]
        spectra = sp_fft.rfft(rows, axis=-1)
        kept = spectra[:, : self.response.size] * self.response.astype(spectra.real.dtype)
        filtered = sp_fft.irfft(kept, n=self.segment // self.decimation, axis=-1)
        lead = self.lead // self.decimation
        return np.asarray(filtered[:, lead : lead + hop // self.decimation].reshape(-1) / self.decimation)


def _anti_alias(passband_hz: float, stopband_hz: float, sample_rate: float) -> _AntiAlias | None:
    if stopband_hz >= 0.5 * sample_rate:
        return None
    from scipy.signal import firwin, kaiserord  # where it is used: scipy.signal is slow to import

    numtaps, beta = kaiserord(_RIPPLE_DB, (stopband_hz - passband_hz) / (0.5 * sample_rate))
    taps = firwin(numtaps | 1, 0.5 * (passband_hz + stopband_hz), window=("kaiser", beta), fs=sample_rate)
    decimation = max(1, int(sample_rate // (OVERSAMPLING * passband_hz)))
    return _AntiAlias(np.asarray(taps), decimation, passband_hz)


def impact_band(sample_rate: float) -> tuple[_AntiAlias, tuple[float, float]]:
    """The high-frequency profile's band-pass (not decimated) and its pass band's edges [Hz].

    The lower edge is :data:`IMPACT_BAND_HZ` ``[0]``, or an eighth of the sampling rate if that is lower;
    the upper :data:`IMPACT_BAND_HZ` ``[1]`` where the transition above it stays below the Nyquist
    frequency, else the Nyquist frequency itself (a high-pass).

    Parameters
    ----------
    sample_rate : float
        Of the channel [Hz].

    Returns
    -------
    band : _AntiAlias
        The FIR (its ``taps``; applied centred by its ``apply``).
    edges : tuple of float
        The pass band's edges [Hz].
    """
    from scipy.signal import firwin, kaiserord  # where it is used: scipy.signal is slow to import

    low = min(IMPACT_BAND_HZ[0], sample_rate / 8)
    width = 0.5 * low
    numtaps, beta = kaiserord(_IMPACT_BAND_DB, width / (0.5 * sample_rate))
    window = ("kaiser", beta)
    if IMPACT_BAND_HZ[1] + width < 0.5 * sample_rate:
        edges = [low - 0.5 * width, IMPACT_BAND_HZ[1] + 0.5 * width]
        band = (low, IMPACT_BAND_HZ[1])
    else:
        edges = [low - 0.5 * width]
        band = (low, 0.5 * sample_rate)
    taps = firwin(numtaps | 1, edges, window=window, pass_zero=False, fs=sample_rate)
    return _AntiAlias(np.asarray(taps), 1, band[1]), band


def to_angle_domain(
    signal: npt.ArrayLike | Samples,
    sample_rate: float,
    angle_map: AngleMap,
    *,
    samples_per_cycle: int,
    cycle_revolutions: int = 1,
    start_time: float = 0.0,
    interpolation_order: Literal[1, 3, 5] | None = None,
    anti_alias: bool = True,
    cutoff: float = 0.8,
    max_order: float | None = None,
    grid: AngleGrid | None = None,
    high_frequency: bool = False,
    progress: Callable[[float], None] | None = None,
    clock: StageClock | None = None,
) -> AngleDomainSignal:
    """Resample a time-domain channel to whole cycles of a uniform crank-angle grid.

    The channel is read and processed in blocks of about 2^18 samples, so an
    h5py dataset or another sliceable reader is never held whole in memory.

    Parameters
    ----------
    signal : array_like or sliceable, shape (n,)
        Samples [the channel's unit]: an array, or anything with ``shape`` and
        slicing (an h5py dataset); float32 is processed in float32.
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
        Resample with the FFT filter and B-splines of this order instead of the fused band-limited
        kernel (the default; see the module docstring).
    anti_alias : bool, optional
        Low-pass before resampling; without it, cubic B-splines (or ``interpolation_order``).
    cutoff : float, optional
        Passband edge of the filter as a fraction of the angle-domain Nyquist
        frequency at the lowest speed [-], unless ``max_order`` is given.
    max_order : float, optional
        The highest order wanted [per revolution]: the fused kernel's passband edge is this order at
        the fastest speed (a shorter kernel than ``cutoff``'s when it is lower); orders above it, up
        to the grid's Nyquist order, are attenuated but not aliased.
    grid : AngleGrid, optional
        The grid times, when several channels with the same sample times share them.
    high_frequency : bool, optional
        Also profile the high-frequency power over the cycle (:class:`HighFrequencyPower`),
        in the same pass over the samples.
    progress : callable, optional
        Told the fraction of the grid done after every block [-].
    clock : StageClock, optional
        Adds the time spent reading, resampling and profiling (stages "reading", "resampling",
        "high-frequency profile").

    Returns
    -------
    AngleDomainSignal

    See Also
    --------
    angle_domain_spectrum : The order spectrum of the same samples, without holding them.

    Raises
    ------
    SignalError
        For a bad grid, non-finite samples, a ``max_order`` the grid cannot hold, or a recording
        shorter than one cycle.
    """
    source, grid = _source_and_grid(
        signal,
        sample_rate,
        angle_map,
        samples_per_cycle,
        cycle_revolutions,
        start_time,
        interpolation_order,
        cutoff,
        grid,
    )
    values = np.empty(grid.times.size)
    cutoff_hz, interpolation, profile = _resample_channel(
        source,
        sample_rate,
        angle_map,
        grid,
        start_time=start_time,
        interpolation_order=interpolation_order,
        anti_alias=anti_alias,
        cutoff=cutoff,
        max_order=max_order,
        high_frequency=high_frequency,
        progress=progress,
        clock=clock,
        output=lambda g0, count: values[g0 : g0 + count],
    )
    return AngleDomainSignal(
        values.reshape(grid.cycles, grid.samples_per_cycle),
        grid.first_cycle,
        grid.samples_per_cycle,
        grid.cycle_revolutions,
        cutoff_hz,
        interpolation,
        profile,
    )


def angle_domain_spectrum(
    signal: npt.ArrayLike | Samples,
    sample_rate: float,
    angle_map: AngleMap,
    *,
    samples_per_cycle: int,
    max_order: float,
    cycle_revolutions: int = 1,
    start_time: float = 0.0,
    block_cycles: int = 1,
    interpolation_order: Literal[1, 3, 5] | None = None,
    grid: AngleGrid | None = None,
    high_frequency: bool = False,
    progress: Callable[[float], None] | None = None,
    clock: StageClock | None = None,
) -> tuple[OrderSpectrum, HighFrequencyPower | None]:
    """The order spectrum of a channel resampled to the crank-angle domain, its samples never held.

    What :func:`to_angle_domain` then :func:`order_spectrum` give (equal to
    round-off), with each block of cycles transformed and averaged as soon as
    it is resampled, while it is still in the processor's cache: the memory
    is a block's, not the recording's.

    Parameters
    ----------
    signal : array_like or sliceable, shape (n,)
        Samples [the channel's unit] (see :func:`to_angle_domain`).
    sample_rate : float
        [Hz].
    angle_map : AngleMap
    samples_per_cycle : int
        Grid points per cycle, even.
    max_order : float
        The highest order wanted and reported [per revolution] (see :func:`to_angle_domain`).
    cycle_revolutions : int, optional
        1 or 2.
    start_time : float, optional
        Time of the first sample [s].
    block_cycles : int, optional
        Cycles per averaged block.
    interpolation_order : {1, 3, 5}, optional
        The FFT filter and B-splines instead of the fused kernel (see :func:`to_angle_domain`).
    grid : AngleGrid, optional
        The grid times, shared by channels sampled at the same times.
    high_frequency : bool, optional
        Also profile the high-frequency power over the cycle, in the same pass.
    progress : callable, optional
        Told the fraction of the grid done after every block [-].
    clock : StageClock, optional
        Adds the time spent reading, resampling, profiling and transforming ("order spectra").

    Returns
    -------
    spectrum : OrderSpectrum
    high_frequency : HighFrequencyPower or None
        When asked for.

    Raises
    ------
    SignalError
        As :func:`to_angle_domain` and :func:`order_spectrum` do.
    """
    source, grid = _source_and_grid(
        signal,
        sample_rate,
        angle_map,
        samples_per_cycle,
        cycle_revolutions,
        start_time,
        interpolation_order,
        0.8,
        grid,
    )
    if not 1 <= block_cycles <= grid.cycles:
        raise SignalError(
            f"block_cycles = {block_cycles!r}: expected 1..{grid.cycles} (cycles in the signal)"
        )
    stream = OrderSpectrumStream(
        samples_per_cycle, cycle_revolutions, block_cycles=block_cycles, max_order=max_order
    )
    buffer: list[FloatArray] = []  # one block's samples, reused

    def output(g0: int, count: int) -> FloatArray:
        if not buffer or buffer[0].size < count:
            buffer[:] = [np.empty(count)]
        return buffer[0][:count]

    def filled(block: FloatArray) -> None:
        with stage(clock, "order spectra"):
            stream.add(block.reshape(-1, samples_per_cycle))

    _, _, profile = _resample_channel(
        source,
        sample_rate,
        angle_map,
        grid,
        start_time=start_time,
        interpolation_order=interpolation_order,
        anti_alias=True,
        cutoff=0.8,
        max_order=max_order,
        high_frequency=high_frequency,
        progress=progress,
        clock=clock,
        output=output,
        filled=filled,
    )
    return stream.result(), profile


def _source_and_grid(
    signal: npt.ArrayLike | Samples,
    sample_rate: float,
    angle_map: AngleMap,
    samples_per_cycle: int,
    cycle_revolutions: int,
    start_time: float,
    interpolation_order: int | None,
    cutoff: float,
    grid: AngleGrid | None,
) -> tuple[Any, AngleGrid]:
    """The samples as something sliceable, checked, and the grid (made, or the given one checked)."""
    source: Any = (
        signal if hasattr(signal, "shape") and hasattr(signal, "__getitem__") else np.asarray(signal)
    )
    if len(source.shape) != 1 or source.shape[0] < 4:
        raise SignalError(f"signal has shape {tuple(source.shape)}: expected a 1-D channel")
    if interpolation_order not in (None, 1, 3, 5):
        raise SignalError(f"interpolation_order = {interpolation_order!r}: expected 1, 3, 5 or None")
    if not 0 < cutoff < 1:
        raise SignalError(f"cutoff = {cutoff!r}: expected a fraction between 0 and 1")
    n = int(source.shape[0])
    t_end = start_time + (n - 1) / sample_rate
    if grid is None:
        grid = angle_grid(
            angle_map,
            start_time,
            t_end,
            samples_per_cycle=samples_per_cycle,
            cycle_revolutions=cycle_revolutions,
        )
    elif (grid.samples_per_cycle, grid.cycle_revolutions) != (samples_per_cycle, cycle_revolutions):
        raise SignalError("the given grid has another number of samples per cycle or revolutions per cycle")
    return source, grid


def _resample_channel(
    source: Any,
    sample_rate: float,
    angle_map: AngleMap,
    grid: AngleGrid,
    *,
    start_time: float,
    interpolation_order: int | None,
    anti_alias: bool,
    cutoff: float,
    max_order: float | None,
    high_frequency: bool,
    progress: Callable[[float], None] | None,
    clock: StageClock | None,
    output: Callable[[int, int], FloatArray],
    filled: Callable[[FloatArray], None] | None = None,
) -> tuple[float | None, str, HighFrequencyPower | None]:
    """Resample ``source`` at ``grid`` block by block (whole cycles each).

    ``output(g0, count)`` gives the array to fill with the values at grid points ``g0`` to
    ``g0 + count``; ``filled`` is told each filled block. Returns the filter's passband edge [Hz], the
    interpolation's name and the high-frequency profile (when asked for).
    """
    samples_per_cycle, cycle_revolutions = grid.samples_per_cycle, grid.cycle_revolutions
    slowest, fastest = (w / (2 * math.pi) for w in angle_map.speed_range)  # rev/s
    stopband = samples_per_cycle / (2 * cycle_revolutions) * slowest  # angle-domain Nyquist at the slowest
    passband = cutoff * stopband
    if max_order is not None:
        if not max_order * fastest < stopband:
            highest = stopband / fastest
            raise SignalError(
                f"max_order = {max_order!r}: at the fastest speed it lies at or above the grid's Nyquist "
                f"order at the slowest ({highest:.3g}); use more samples per cycle or a lower max_order"
            )
        passband = max_order * fastest
    kernel: _BandLimited | None = None
    fir: _AntiAlias | None = None
    edge = min(stopband, 0.5 * sample_rate)
    # input samples per grid point at the mean speed
    spacing = sample_rate * float(grid.times[-1] - grid.times[0]) / max(grid.times.size - 1, 1)
    if (
        anti_alias
        and interpolation_order is None
        and passband < 0.9 * edge
        and _fused_taps(passband, edge, sample_rate) <= _FUSED_TAPS_PER_INPUT * spacing
    ):
        kernel = _band_limited(passband, edge, sample_rate)
    elif anti_alias:
        # the splines lose up to 4e-4 of a sine at the passband's edge (see above): the wanted orders are
        # kept well inside it, whatever max_order
        fir = _anti_alias(cutoff * stopband, stopband, sample_rate)
    order = interpolation_order if interpolation_order is not None else 3
    decimation = fir.decimation if fir is not None else 1
    lead = fir.lead if fir is not None else 0  # input sample of the first filtered sample
    margin = kernel.half + 1 if kernel is not None else lead + _SPLINE_MARGIN * decimation
    band, band_hz = impact_band(sample_rate) if high_frequency else (None, (math.nan, math.nan))
    if band is not None:
        margin = max(margin, band.lead + 2)
    table = None
    reuse: list[np.ndarray] = []  # the block buffer a file's reader fills
    cycle_seconds = (grid.times[-1] - grid.times[0]) / max(grid.times.size - 1, 1) * grid.samples_per_cycle
    per_block = max(1, int(_BLOCK_SAMPLES / (sample_rate * cycle_seconds)))
    step = per_block * grid.samples_per_cycle
    m = grid.samples_per_cycle
    # the profile's bins: the grid's, split evenly until they are no wider than a knock's ring at speed
    per_revolution = 2 ** math.ceil(math.log2(max(1.0, 1.0 / (slowest * HIGH_FREQUENCY_BIN_SECONDS))))
    per_revolution = min(
        max(per_revolution, HIGH_FREQUENCY_BINS_PER_REVOLUTION), HIGH_FREQUENCY_MAX_BINS_PER_REVOLUTION
    )
    split = max(1, (per_revolution * cycle_revolutions) // m)
    bins = m * split
    power_sum, power_squares, power_counts = np.zeros(bins), np.zeros(bins), np.zeros(bins)
    for g0 in range(0, grid.times.size, step):
        # in input samples; one more grid time than the block's closes its last bin
        edges = (grid.times[g0 : g0 + step + 1] - start_time) * sample_rate
        where = edges[: min(step, grid.times.size - g0)]
        a = math.floor(where[0]) - margin
        b = math.ceil(edges[-1]) + margin + 2
        a -= a % decimation  # filtered samples on one lattice of input samples for every block
        with stage(clock, "reading"):
            x = _read(source, a, b, start_time, sample_rate, reuse)
        if band is not None:
            with stage(clock, "high-frequency profile"):
                fine = edges - a - band.lead  # in samples of the band-passed block
                if split > 1:
                    finer = np.arange((fine.size - 1) * split + 1) / split
                    fine = np.interp(finer, np.arange(fine.size), fine)
                _bin_power(band.apply(x), fine, bins, power_sum, power_squares, power_counts)
        out = output(g0, where.size)
        with stage(clock, "resampling"):
            if kernel is not None:
                if table is None or table.dtype != x.dtype:
                    table = kernel.table.astype(x.dtype)
                _resample(x, where - a, table, out)
            else:
                y = fir.apply(x) if fir is not None else x
                _interpolate(
                    _spline_coefficients(y, order),
                    (where - a - lead) / decimation,
                    order,
                    out,
                )
        if filled is not None:
            filled(out)
        if progress is not None:
            progress(min(1.0, (g0 + step) / grid.times.size))
    profile = None
    if high_frequency:
        # each bin's cycles that held at least one sample (a grid finer than the samples leaves some
        # bins empty in some cycles; the last grid point's bin is open, one cycle fewer)
        counts = np.maximum(power_counts, 1.0)
        mean = power_sum / counts
        variance = np.maximum(power_squares / counts - mean**2, 0.0) * counts / np.maximum(counts - 1, 1)
        seconds = float(grid.times[-1] - grid.times[0])
        revolutions = (grid.times.size - 1) / grid.samples_per_cycle * cycle_revolutions
        speed_rpm = 60.0 * revolutions / seconds if seconds > 0 else math.nan
        profile = HighFrequencyPower(
            mean, np.sqrt(variance), grid.cycles, float(sample_rate), band_hz, speed_rpm
        )
    if kernel is not None:
        cutoff_hz: float | None = kernel.passband_hz
        interpolation = "band-limited"
    else:
        cutoff_hz = fir.passband_hz if fir is not None else None
        interpolation = f"B-spline {order}"
    return cutoff_hz, interpolation, profile


@numba.njit(cache=True, nogil=True)
def _bin_power(
    x: FloatArray, edges: FloatArray, m: int, total: FloatArray, squares: FloatArray, counts: FloatArray
) -> None:
    """Add each bin's mean square of ``x`` to ``total[bin % m]`` (its square to
    ``squares``, and 1 to ``counts``) when the bin holds a sample.

    Bin ``i`` holds the samples from ``edges[i]`` up to ``edges[i + 1]`` (positions in ``x``); the
    first bin is a whole number of cycles from the grid's start.
    """  # pragma: no cover - compiled
    n = x.size
    for i in range(edges.size - 1):
        j0 = max(math.ceil(edges[i]), 0)
        j1 = min(math.ceil(edges[i + 1]), n)
        acc = 0.0
        for j in range(j0, j1):
            acc += float(x[j]) * float(x[j])
        if j1 > j0:
            acc /= j1 - j0
            total[i % m] += acc
            squares[i % m] += acc * acc
            counts[i % m] += 1.0


# poles of the B-spline interpolation prefilters (Unser, Aldroubi & Eden 1991; Thevenaz et al. 2000)
_POLES = {1: (), 3: (math.sqrt(3.0) - 2.0,), 5: (-0.430575347099973, -0.0430962882032647)}


def _spline_coefficients(y: FloatArray, order: int) -> FloatArray:
    """B-spline coefficients that interpolate ``y`` (mirror boundaries; exact away from the ends)."""
    c = np.array(y, dtype=np.float64)
    if order > 1:
        _prefilter(c, np.array(_POLES[order]))
    return c


@numba.njit(cache=True, nogil=True)
def _prefilter(c: FloatArray, poles: FloatArray) -> None:  # pragma: no cover - compiled
    """In place: the causal and anticausal recursions of each pole, with the overall gain."""
    n = c.size
    gain = 1.0
    for z in poles:
        gain *= (1.0 - z) * (1.0 - 1.0 / z)
    for k in range(n):
        c[k] *= gain
    for z in poles:
        horizon = min(n, math.ceil(math.log(1e-16) / math.log(abs(z))))
        total, power = c[0], z
        for k in range(1, horizon):  # causal start: the mirrored signal's sum, truncated below 1e-16
            total += power * c[k]
            power *= z
        c[0] = total
        for k in range(1, n):
            c[k] += z * c[k - 1]
        c[n - 1] = z / (z * z - 1.0) * (c[n - 1] + z * c[n - 2])
        for k in range(n - 2, -1, -1):
            c[k] = z * (c[k + 1] - c[k])


@numba.njit(cache=True, nogil=True)
def _interpolate(c: FloatArray, q: FloatArray, order: int, out: FloatArray) -> None:  # pragma: no cover
    """The B-spline of ``order`` with coefficients ``c`` at positions ``q`` (in samples), into ``out``."""
    n = c.size
    for p in range(q.size):
        x = q[p]
        i = math.floor(x)
        t = x - i
        if order == 1:
            out[p] = (1.0 - t) * c[min(max(i, 0), n - 1)] + t * c[min(max(i + 1, 0), n - 1)]
        elif order == 3:
            s = 1.0 - t
            w0 = s * s * s / 6.0
            w3 = t * t * t / 6.0
            w1 = (4.0 - 6.0 * t * t + 3.0 * t * t * t) / 6.0
            w2 = 1.0 - w0 - w1 - w3
            out[p] = (
                w0 * c[min(max(i - 1, 0), n - 1)]
                + w1 * c[min(max(i, 0), n - 1)]
                + w2 * c[min(max(i + 1, 0), n - 1)]
                + w3 * c[min(max(i + 2, 0), n - 1)]
            )
        else:
            total = 0.0
            for j in range(
                -2, 4
            ):  # quintic B-spline at t - j: 1/120 sum_k (-1)^k C(6, k) (t - j + 3 - k)_+^5
                d = t - j
                beta, sign, binomial = 0.0, 1.0, 1.0
                for k in range(7):
                    u = d + 3.0 - k
                    if u > 0.0:
                        beta += sign * binomial * u**5
                    sign = -sign
                    binomial = binomial * (6 - k) / (k + 1)
                total += beta / 120.0 * c[min(max(i + j, 0), n - 1)]
            out[p] = total


def _read(
    source: Any, a: int, b: int, start_time: float, sample_rate: float, reuse: list[np.ndarray] | None = None
) -> FloatArray:
    """Samples ``a`` to ``b`` (may reach past either end: mirrored about the end sample, odd).

    A file's reader (one with ``read_into``, which refuses NaN, Inf and clipping itself) reads a span
    inside the channel straight into the buffer held in ``reuse`` (made or grown as needed): the
    returned samples are a view of it, valid until the next read.
    """
    n = int(source.shape[0])
    lo, hi = max(a, 0), min(b, n)
    if reuse is not None and hasattr(source, "read_into") and source.dtype in (np.float32, np.float64):
        if not reuse or reuse[0].size < hi - lo or reuse[0].dtype != source.dtype:
            reuse[:] = [np.empty(max(hi - lo, 1), dtype=source.dtype)]
        x = reuse[0][: hi - lo]
        source.read_into(lo, x)
    else:
        x = np.asarray(source[lo:hi])
        if x.dtype not in (np.float32, np.float64):
            x = x.astype(np.float64)
        if not np.all(np.isfinite(x)):
            bad = lo + int(np.flatnonzero(~np.isfinite(x))[0])
            raise SignalError(
                f"signal has NaN or Inf samples (the first at {start_time + bad / sample_rate:.6f} s): "
                "mask them (see the reader's report) before resampling"
            )
    before, after = max(0, -a), max(0, b - n)
    if before or after:
        x = np.pad(x, (before, after), mode="reflect", reflect_type="odd")
    return x


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
    scatter : ndarray, shape (n_orders,)
        Root-mean-square distance of the blocks' complex amplitudes from their
        mean (sample standard deviation, magnitude and phase jitter together);
        ``scatter / sqrt(blocks)`` is the standard error of ``amplitude``.
    blocks : int
        Blocks averaged.
    block_cycles : int
        Cycles per block.
    """

    orders: FloatArray
    amplitude: ComplexArray
    magnitude_mean: FloatArray
    magnitude_std: FloatArray
    scatter: FloatArray
    blocks: int
    block_cycles: int

    @property
    def standard_error(self) -> FloatArray:
        """Standard error of the complex mean ``amplitude`` from the blocks' scatter."""
        return np.asarray(self.scatter / math.sqrt(self.blocks))

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
    n_cycles = signal.values.shape[0]
    if not 1 <= block_cycles <= n_cycles:
        raise SignalError(f"block_cycles = {block_cycles!r}: expected 1..{n_cycles} (cycles in the signal)")
    stream = OrderSpectrumStream(
        signal.samples_per_cycle, signal.cycle_revolutions, block_cycles=block_cycles, max_order=max_order
    )
    stream.add(signal.values)
    return stream.result()


class OrderSpectrumStream:
    """An order spectrum averaged over blocks of whole cycles given a few at a time, in order.

    Each block's scaled real FFT gives complex order amplitudes; the means of
    the amplitudes and of their magnitudes, and the squared deviations from
    them, are combined part by part by Chan's rule (Chan, Golub & LeVeque,
    "Updating formulae and a pairwise algorithm for computing sample
    variances", 1979): the same as over all blocks at once, to round-off.
    Cycles that do not yet fill a block wait for the next part; those left at
    the end are not used.

    Parameters
    ----------
    samples_per_cycle : int
    cycle_revolutions : int
        1 or 2.
    block_cycles : int, optional
        Cycles per block.
    max_order : float, optional
        Highest order kept [-].
    """

    _PART_BLOCKS = 4096  # blocks transformed at once: bounded memory for a long signal given whole
    _GATHER_CYCLES = 1024  # cycles given in smaller parts are gathered to about this many first

    def __init__(
        self,
        samples_per_cycle: int,
        cycle_revolutions: int,
        *,
        block_cycles: int = 1,
        max_order: float | None = None,
    ) -> None:
        if block_cycles < 1:
            raise SignalError(f"block_cycles = {block_cycles!r}: expected at least 1")
        self.samples_per_cycle = samples_per_cycle
        self.block_cycles = block_cycles
        self._length = block_cycles * samples_per_cycle
        resolution = 1.0 / (block_cycles * cycle_revolutions)
        orders = resolution * np.arange(self._length // 2 + 1, dtype=np.float64)
        limit = max_order if max_order is not None else orders[-1]
        self._keep = int(np.count_nonzero(orders <= limit + 1e-12))
        self.orders = orders[: self._keep]
        self._average = np.zeros(self._keep, dtype=np.complex128)
        self._spread = np.zeros(self._keep)  # squared distances of the complex amplitudes from their mean
        self._mean = np.zeros(self._keep)
        self._squares = np.zeros(self._keep)
        self.blocks = 0
        # cycles waiting: short of a whole block, or gathered so that each transform is worth its
        # overhead (whole blocks of about _GATHER_CYCLES)
        gather = -(-self._GATHER_CYCLES // block_cycles) * block_cycles
        self._waiting = np.empty((gather, samples_per_cycle))
        self._count = 0

    def add(self, cycles: FloatArray) -> None:
        """The next cycles, shape ``(k, samples_per_cycle)``."""
        if cycles.ndim != 2 or cycles.shape[1] != self.samples_per_cycle:
            raise SignalError(
                f"cycles of shape {cycles.shape}: expected (k, {self.samples_per_cycle}) samples"
            )
        room = self._waiting.shape[0]
        start = 0
        if self._count:  # fill the waiting cycles up first
            take = min(room - self._count, cycles.shape[0])
            self._waiting[self._count : self._count + take] = cycles[:take]
            self._count += take
            start = take
            if self._count < room:
                return
            self._transform(self._waiting)
            self._count = 0
        rest = cycles[start:]
        whole = rest.shape[0] // self.block_cycles * self.block_cycles
        if whole >= room:  # a long part: its whole blocks at once
            self._transform(rest[:whole])
            rest = rest[whole:]
        self._waiting[: rest.shape[0]] = rest
        self._count = rest.shape[0]

    def _transform(self, cycles: FloatArray) -> None:
        """Whole blocks of cycles (a multiple of ``block_cycles`` of them) into the statistics."""
        data = cycles.reshape(-1, self._length)
        for b0 in range(0, data.shape[0], self._PART_BLOCKS):
            self._combine(scaled_rfft(data[b0 : b0 + self._PART_BLOCKS])[:, : self._keep])

    def _combine(self, spectra: ComplexArray) -> None:
        magnitudes = np.abs(spectra)
        part = magnitudes.shape[0]
        weight = part / (self.blocks + part)
        part_average = spectra.mean(axis=0)
        part_spread = (np.abs(spectra - part_average) ** 2).sum(axis=0)
        shift = part_average - self._average
        self._spread += part_spread + np.abs(shift) ** 2 * self.blocks * weight
        self._average += shift * weight
        part_mean = magnitudes.mean(axis=0)
        part_squares = ((magnitudes - part_mean) ** 2).sum(axis=0)
        delta = part_mean - self._mean
        self._squares += part_squares + delta**2 * self.blocks * weight
        self._mean += delta * weight
        self.blocks += part

    def result(self) -> OrderSpectrum:
        """The spectrum of the blocks given so far.

        Raises
        ------
        SignalError
            Before a whole block.
        """
        whole = self._count // self.block_cycles * self.block_cycles
        if whole:  # the whole blocks still waiting
            self._transform(self._waiting[:whole])
            self._waiting[: self._count - whole] = self._waiting[whole : self._count]
            self._count -= whole
        blocks = self.blocks
        if blocks == 0:
            raise SignalError(f"no whole block of {self.block_cycles} cycles: no order spectrum")
        spread = np.sqrt(self._spread / (blocks - 1)) if blocks > 1 else np.zeros(self._keep)
        std = np.sqrt(self._squares / (blocks - 1)) if blocks > 1 else np.zeros(self._keep)
        return OrderSpectrum(
            orders=self.orders.copy(),
            amplitude=self._average.copy(),
            magnitude_mean=self._mean.copy(),
            magnitude_std=std,
            scatter=spread,
            blocks=blocks,
            block_cycles=self.block_cycles,
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
        upper speed exceeds the anti-alias passband edge (it would be attenuated).
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
        # an order whose frequency in a bin exceeds the anti-alias passband was attenuated: not reported
        fastest = edges[1:] / (2 * math.pi)
        amplitude[np.multiply.outer(fastest, orders[keep]) > signal.cutoff_hz] = np.nan
    return OrderSpeedMap(centres, orders[keep], amplitude, counts)
