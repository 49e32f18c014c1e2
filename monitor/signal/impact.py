"""Impacts: where in the cycle a channel's high-frequency power lies.

The samples are band-passed in time (:func:`impact_band`, 1-10 kHz) and the mean square of each bin of
the cycle accumulated over the cycles (:class:`HighFrequencyProfiler`), in the same pass over the
samples as the resampling (:mod:`monitor.signal.resample`): :class:`HighFrequencyPower`.
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
        _bin_power(self.band.apply(x), fine, self.bins, self._sum, self._squares, self._counts)

    def result(self, cycles: int, speed_rpm: float) -> HighFrequencyPower:
        """The profile of the blocks given, ``cycles`` cycles at a mean ``speed_rpm``."""
        # each bin's cycles that held at least one sample (a grid finer than the samples leaves some
        # bins empty in some cycles; the last grid point's bin is open, one cycle fewer)
        counts = np.maximum(self._counts, 1.0)
        mean = self._sum / counts
        variance = np.maximum(self._squares / counts - mean**2, 0.0) * counts / np.maximum(counts - 1, 1)
        return HighFrequencyPower(
            mean, np.sqrt(variance), cycles, float(self.sample_rate), self.band_hz, speed_rpm
        )
