"""Impacts: where in the cycle a channel's high-frequency power lies.

The samples are band-passed in time (:func:`impact_band`, 1-10 kHz) and the mean square of each bin of
the cycle accumulated over the cycles (:class:`HighFrequencyProfiler`), in the same pass over the
samples as the resampling (:mod:`monitor.signal.resample`): :class:`HighFrequencyPower`.

The part that varies from cycle to cycle.  The engine's own events (a valve's seating, the
combustion's pressure rise) start at fixed crank angles, and the rings they leave repeat, cycle
after cycle, at the same angle with the same phase; a bearing's knock comes when the journal crosses
its clearance, a little earlier or later each cycle, and a ring of 1-10 kHz shifted by a tenth of a
millisecond is out of phase.  Two of the engine's events that ring the same resonance add in phase
at one speed and cancel at another a few per cent away (the validation case 200472: a two-stroke's
exhaust opening and the next cylinder's firing, 7 deg apart, on a resonance of the bearing's frame
below 1 kHz, in phase at 146 rpm and cancelling near 153), which no interpolation between calibrated
points follows.  So each bin is also sampled at ``q`` fixed angles (about one per input sample at
the slowest speed, each the band-passed sample nearest to it), the synchronous average ``ybar`` of
each angle over the cycles kept, and the bin's varying power is

    v = C / (C - 1) (mean over the bin's angles and the cycles of y^2 - mean over its angles of ybar^2),

the mean square of the samples less the synchronous average's power, unbiased for ``C`` cycles of
noise independent from cycle to cycle (:attr:`HighFrequencyPower.varying`).  The nearest sample,
not an interpolation between two: an interpolation damps the band's top (linear, at a quarter of the
sampling rate, to half its power), and a knock there would lose against the noise below it; a sample
keeps every frequency's power, so a part that does not repeat reads in ``v`` as in the whole power.
The nearest sample is up to half a sample from the angle, another each cycle: a ring at ``f`` keeps
its coherence to within ``cos(pi f / fs)`` at worst (0.99 at 1 kHz and 25.6 kHz sampling, 0.6 at
8 kHz), so the repeating part is underestimated near the band's top and the varying part
overestimated, never the other way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numba
import numpy as np

from monitor.errors import SignalError
from monitor.signal.kernels import CentredFir
from monitor.types import FloatArray

__all__ = [
    "HIGH_FREQUENCY_BINS_PER_REVOLUTION",
    "HIGH_FREQUENCY_BIN_SECONDS",
    "HIGH_FREQUENCY_MAX_BINS_PER_REVOLUTION",
    "IMPACT_BAND_HZ",
    "HighFrequencyPower",
    "HighFrequencyProfiler",
    "impact_band",
]


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
    varying : ndarray or None, shape (bins,)
        Each bin's power less that of its synchronous average over the cycles: the part that does not
        repeat from cycle to cycle (module docstring) [unit^2]; None where not measured (a baseline
        written before it was).
    speeds_rpm : tuple of float
        The lowest and the highest speed of the profiles this one was made from [rpm] (a reference
        interpolated between, or the loudest over, calibrated points; :meth:`speed_span`); NaN: its
        own ``speed_rpm`` alone.
    """

    mean: FloatArray
    std: FloatArray
    cycles: int
    sample_rate: float
    band_hz: tuple[float, float] = (math.nan, math.nan)
    speed_rpm: float = math.nan
    varying: FloatArray | None = None
    speeds_rpm: tuple[float, float] = (math.nan, math.nan)

    def speed_span(self) -> tuple[float, float]:
        """The lowest and the highest speed the profile's power was measured at [rpm] (NaN: unknown)."""
        if all(math.isfinite(s) for s in self.speeds_rpm):
            return self.speeds_rpm
        return (self.speed_rpm, self.speed_rpm)

    def varying_part(self) -> HighFrequencyPower | None:
        """The profile of the part that varies from cycle to cycle (None where it was not measured).

        Its spread is the whole power's: the synchronous average's removal takes the repeating part's
        share of the cycles' spread away and leaves the rest, so the whole's spread bounds it.
        """
        if self.varying is None:
            return None
        return replace(self, mean=self.varying, varying=None)

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
        varying = None if self.varying is None else self.varying.reshape(bins, k).mean(axis=1)
        return replace(self, mean=mean, std=std, varying=varying)


def impact_band(sample_rate: float) -> tuple[CentredFir, tuple[float, float]]:
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
    band : CentredFir
        The FIR (its ``taps``; applied centred by its ``apply``).
    edges : tuple of float
        The pass band's edges [Hz].
    """
    # here, not at the top: scipy.signal takes most of a second to import, and the diagnosis and the
    # service import HighFrequencyPower without ever designing a filter
    from scipy.signal import firwin, kaiserord

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
    return CentredFir(np.asarray(taps), 1, band[1]), band


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


@numba.njit(cache=True, nogil=True)
def _bin_synchronous(
    x: FloatArray, edges: FloatArray, m: int, q: int, sums: FloatArray, power: FloatArray, seen: FloatArray
) -> None:
    """Add ``x`` at ``q`` angles evenly inside each bin (the nearest sample) to ``sums[bin % m, k]``,
    its mean square over the bin's angles to ``power[bin % m]`` and 1 to ``seen[bin % m]``, for the
    bins whose samples the block holds on both sides; the first bin is a whole number of cycles from
    the grid's start.
    """  # pragma: no cover - compiled
    n = x.size
    for i in range(edges.size - 1):
        e0 = edges[i]
        width = (edges[i + 1] - e0) / q
        if e0 < 0.0 or edges[i + 1] >= n - 1:
            continue
        b = i % m
        acc = 0.0
        for k in range(q):
            v = float(x[int(e0 + (k + 0.5) * width + 0.5)])
            sums[b, k] += v
            acc += v * v
        power[b] += acc / q
        seen[b] += 1.0


class HighFrequencyProfiler:
    """The high-frequency profile of a channel resampled block by block, accumulated a block at a time.

    Parameters
    ----------
    sample_rate : float
        Of the channel [Hz].
    samples_per_cycle : int
        Of the angle-domain grid.
    cycle_revolutions : int
        1 or 2.
    slowest : float
        The slowest speed of the recording [rev/s].
    """

    def __init__(
        self, sample_rate: float, samples_per_cycle: int, cycle_revolutions: int, slowest: float
    ) -> None:
        self.sample_rate = sample_rate
        self.band, self.band_hz = impact_band(sample_rate)
        # the profile's bins: the grid's, split evenly until they are no wider than a knock's ring at speed
        per_revolution = 2 ** math.ceil(math.log2(max(1.0, 1.0 / (slowest * HIGH_FREQUENCY_BIN_SECONDS))))
        per_revolution = min(
            max(per_revolution, HIGH_FREQUENCY_BINS_PER_REVOLUTION), HIGH_FREQUENCY_MAX_BINS_PER_REVOLUTION
        )
        self.split = max(1, (per_revolution * cycle_revolutions) // samples_per_cycle)
        self.bins = samples_per_cycle * self.split
        self._sum, self._squares, self._counts = np.zeros(self.bins), np.zeros(self.bins), np.zeros(self.bins)
        # the synchronous average's angles: about one per input sample at the slowest speed
        self.angles_per_bin = max(1, math.ceil(sample_rate * cycle_revolutions / (slowest * self.bins)))
        self._synchronous = np.zeros((self.bins, self.angles_per_bin))
        self._power, self._seen = np.zeros(self.bins), np.zeros(self.bins)

    @property
    def margin(self) -> int:
        """Input samples the band-pass needs beyond a block's first and last grid times."""
        return self.band.lead + 2

    def add(self, x: FloatArray, edges: FloatArray) -> None:
        """A block's samples ``x``, and its grid times in samples of ``x`` (whole cycles, and one more
        grid time that closes the last bin)."""
        fine = edges - self.band.lead  # in samples of the band-passed block
        if self.split > 1:
            finer = np.arange((fine.size - 1) * self.split + 1) / self.split
            fine = np.interp(finer, np.arange(fine.size), fine)
        band_passed = self.band.apply(x)
        _bin_power(band_passed, fine, self.bins, self._sum, self._squares, self._counts)
        _bin_synchronous(
            band_passed, fine, self.bins, self.angles_per_bin, self._synchronous, self._power, self._seen
        )

    def result(self, cycles: int, speed_rpm: float) -> HighFrequencyPower:
        """The profile of the blocks given, ``cycles`` cycles at a mean ``speed_rpm``."""
        # each bin's cycles that held at least one sample (a grid finer than the samples leaves some
        # bins empty in some cycles; the last grid point's bin is open, one cycle fewer)
        counts = np.maximum(self._counts, 1.0)
        mean = self._sum / counts
        variance = np.maximum(self._squares / counts - mean**2, 0.0) * counts / np.maximum(counts - 1, 1)
        return HighFrequencyPower(
            mean, np.sqrt(variance), cycles, float(self.sample_rate), self.band_hz, speed_rpm, self._varying()
        )

    def _varying(self) -> FloatArray:
        """Each bin's power less its synchronous average's, unbiased (module docstring); a bin seen in
        fewer than two cycles keeps its whole power (nothing tells what repeats)."""
        seen = np.maximum(self._seen, 1.0)
        total = self._power / seen
        repeating = np.mean((self._synchronous / seen[:, None]) ** 2, axis=1)
        varying = np.maximum(total - repeating, 0.0) * seen / np.maximum(seen - 1.0, 1.0)
        return np.where(self._seen >= 2, varying, total)
