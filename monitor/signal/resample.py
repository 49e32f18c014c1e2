"""Resampling a time-domain channel to the crank-angle domain.

A channel sampled in time is evaluated at whole cycles of a uniform
crank-angle grid (:mod:`monitor.signal.grid`) by one of the kernels of
:mod:`monitor.signal.kernels`, profiling its high-frequency power on the way
when asked (:mod:`monitor.signal.impact`).

The channel is processed in blocks of whole cycles (about 2^18 input
samples and a margin on each side for the kernel), read by slices: a
channel in an HDF5 file is never held whole in memory.
:func:`angle_domain_spectrum` transforms each block into the order spectrum
(:mod:`monitor.signal.spectrum`) as soon as it is resampled.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from monitor.errors import SignalError
from monitor.runtime.timing import StageClock, stage
from monitor.signal.anglemap import AngleMap
from monitor.signal.grid import AngleDomainSignal, AngleGrid, Samples, angle_grid
from monitor.signal.impact import HighFrequencyPower, HighFrequencyProfiler
from monitor.signal.kernels import Resampler, choose_resampler
from monitor.signal.spectrum import OrderSpectrum, OrderSpectrumStream
from monitor.types import FloatArray

__all__ = ["angle_domain_spectrum", "to_angle_domain"]

_BLOCK_SAMPLES = 1 << 18  # input samples per processed block


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
        kernel (the default; see :mod:`monitor.signal.kernels`).
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
    slowest = angle_map.speed_range[0] / (2 * math.pi)  # rev/s
    resampler = _resampler(
        sample_rate,
        angle_map,
        grid,
        interpolation_order=interpolation_order,
        anti_alias=anti_alias,
        cutoff=cutoff,
        max_order=max_order,
    )
    profiler = (
        HighFrequencyProfiler(sample_rate, grid.samples_per_cycle, grid.cycle_revolutions, slowest)
        if high_frequency
        else None
    )
    margin = resampler.margin if profiler is None else max(resampler.margin, profiler.margin)
    decimation = resampler.decimation
    reuse: list[np.ndarray] = []  # the block buffer a file's reader fills
    per_block = max(1, int(_BLOCK_SAMPLES / (sample_rate * grid.cycle_seconds)))
    step = per_block * grid.samples_per_cycle
    for g0 in range(0, grid.times.size, step):
        # in input samples; one more grid time than the block's closes its last bin
        edges = (grid.times[g0 : g0 + step + 1] - start_time) * sample_rate
        where = edges[: min(step, grid.times.size - g0)]
        a = math.floor(where[0]) - margin
        b = math.ceil(edges[-1]) + margin + 2
        a -= a % decimation  # filtered samples on one lattice of input samples for every block
        with stage(clock, "reading"):
            x = _read(source, a, b, start_time, sample_rate, reuse)
        if profiler is not None:
            with stage(clock, "high-frequency profile"):
                profiler.add(x, edges - a)
        out = output(g0, where.size)
        with stage(clock, "resampling"):
            resampler.evaluate(x, where - a, out)
        if filled is not None:
            filled(out)
        if progress is not None:
            progress(min(1.0, (g0 + step) / grid.times.size))
    profile = profiler.result(grid.cycles, grid.speed_rpm) if profiler is not None else None
    return resampler.cutoff_hz, resampler.name, profile


def _resampler(
    sample_rate: float,
    angle_map: AngleMap,
    grid: AngleGrid,
    *,
    interpolation_order: int | None,
    anti_alias: bool,
    cutoff: float,
    max_order: float | None,
) -> Resampler:
    """The kernel for this grid: its stopband edge the grid's Nyquist order at the slowest speed, its
    passband edge ``cutoff`` of that, or ``max_order`` at the fastest speed.

    Raises
    ------
    SignalError
        Where ``max_order`` at the fastest speed is not below the stopband edge.
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
    # input samples per grid point at the mean speed
    spacing = sample_rate * float(grid.times[-1] - grid.times[0]) / max(grid.times.size - 1, 1)
    return choose_resampler(
        sample_rate,
        passband,
        stopband,
        cutoff=cutoff,
        spacing=spacing,
        anti_alias=anti_alias,
        interpolation_order=interpolation_order,
    )


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
