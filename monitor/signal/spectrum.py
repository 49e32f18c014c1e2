"""Order spectra of angle-domain signals.

The angle-domain signal is cut into blocks of whole cycles; each block's real
FFT, scaled to peak amplitudes, gives complex order amplitudes (phase relative
to TDC of cylinder 1, under the convention of :mod:`monitor.fourier`).  Their
complex mean over the blocks is the synchronous average's spectrum; the
spread of the magnitudes over the blocks is reported beside it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from monitor.errors import SignalError
from monitor.fourier import scaled_rfft
from monitor.signal.anglemap import AngleMap
from monitor.signal.grid import AngleDomainSignal
from monitor.types import ComplexArray, FloatArray

__all__ = ["OrderSpectrum", "OrderSpectrumStream", "OrderSpeedMap", "order_spectrum", "order_speed_map"]


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
    systematic : ndarray or None
        A bound on each order's systematic error that averaging does not remove (the crank speed's
        integer orders: a wheel's unlearned pitch errors, :mod:`monitor.signal.pitch_uncertainty`),
        in the channel's unit; None where none is known.
    """

    orders: FloatArray
    amplitude: ComplexArray
    magnitude_mean: FloatArray
    magnitude_std: FloatArray
    scatter: FloatArray
    blocks: int
    block_cycles: int
    systematic: FloatArray | None = None

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
