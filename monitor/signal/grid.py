"""The crank-angle grid a channel is resampled to, and the resampled channel.

A channel sampled in time is evaluated at a uniform crank-angle grid of ``N``
samples per cycle (per revolution on a two-stroke, per two revolutions on a
four-stroke), whole cycles only, cycle angle 0 at (firing) TDC of cylinder 1.
The times of the grid angles come from the angle map's monotone inverse
(:func:`angle_grid`); :mod:`monitor.signal.resample` evaluates the channel at
them (:class:`AngleDomainSignal`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from monitor.errors import SignalError
from monitor.signal.anglemap import AngleMap
from monitor.signal.impact import HighFrequencyPower
from monitor.types import FloatArray

__all__ = ["AngleDomainSignal", "AngleGrid", "Samples", "angle_grid"]


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

    @property
    def speed_rpm(self) -> float:
        """Mean speed from the first grid time to the last [rpm]; NaN when they are one time."""
        seconds = float(self.times[-1] - self.times[0])
        revolutions = (self.times.size - 1) / self.samples_per_cycle * self.cycle_revolutions
        return 60.0 * revolutions / seconds if seconds > 0 else math.nan

    @property
    def cycle_seconds(self) -> float:
        """Mean duration of a cycle [s]."""
        step = (self.times[-1] - self.times[0]) / max(self.times.size - 1, 1)
        return float(step * self.samples_per_cycle)


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
