"""The measured side, composed: recording -> angle map -> angle-domain channels -> order spectra.

The CLI, the service and the batch call these functions, nothing deeper.

Angle reference: :mod:`monitor.signal.reference`.

Crank speed.  The angle map's derivative gives the speed-fluctuation orders
(``crank speed`` in the spectra, [rad/s]); they are what the torque orders
of the model predict.  It is evaluated on a crank-angle grid of its own, at
least twice as fine as the pulses (a 60-2 wheel: 128 points a revolution),
whatever the grid of the other channels: the map interpolates between the
pulses, so nothing above half the pulse rate is in it to alias, and the
speed orders do not depend on ``max_order``.  The
angular-vibration orders (``crank angular vibration``, [rad]) are those of
the crank's angle lead over a uniform rotation at each cycle's own mean
speed, ``theta - Omega_c (t(theta) - t_c)``: the integral over the cycle of
``1 - Omega_c / omega(theta)``, integrated order by order (divided by
``i k``), with no small-fluctuation approximation.  A map
made of ``P`` pulses per revolution resolves speed orders below ``P / 2``
only: a tooth wheel gives them, a keyphasor alone gives the mean speed.

Grid.  The default angle-domain grid is sized so that the anti-alias
filter leaves every order up to ``max_order`` untouched at the fastest
speed of the recording; a grid given too coarse for that is refused.
"""

from __future__ import annotations

import math
import os
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np

from monitor.errors import SignalError
from monitor.io.recording import Channel, Recording
from monitor.runtime.timing import StageClock
from monitor.signal.anglemap import AngleMap
from monitor.signal.crank_speed import crank_speed_spectra
from monitor.signal.grid import AngleGrid, angle_grid
from monitor.signal.impact import HighFrequencyPower
from monitor.signal.pitch import PitchCorrection
from monitor.signal.pitch_uncertainty import learned_bound, systematic_bound
from monitor.signal.reference import AngleReference, angle_reference, waveform_rate
from monitor.signal.resample import angle_domain_spectrum, to_angle_domain
from monitor.signal.spectrum import OrderSpectrum, OrderSpeedMap, order_spectrum, order_speed_map
from monitor.signal.steady import MIN_CYCLES, cycle_series, steady_segments
from monitor.signal.tdc import PLAUSIBLE_FIRED_PEAK, pressure_peaks

__all__ = ["ANGULAR_VIBRATION_CHANNEL", "SPEED_CHANNEL", "SpectrumResult", "spectra"]

SPEED_CHANNEL = "crank speed"
ANGULAR_VIBRATION_CHANNEL = "crank angular vibration"


@dataclass(frozen=True)
class SpectrumResult:
    """Order spectra of a recording's channels.

    Attributes
    ----------
    reference : AngleReference
    spectra : dict of str to OrderSpectrum
        By channel name; ``"crank speed"`` is the speed fluctuation [rad/s],
        ``"crank angular vibration"`` the crank's angle lead over a uniform
        rotation at each cycle's mean speed [rad].
    units : dict of str to str
    mean_speed : float
        Mean crank speed over the analysed span [rad/s].
    cycle_revolutions : int
    speed_maps : dict of str to OrderSpeedMap
        Order amplitudes against speed per channel (run-ups), when asked for.
    high_frequency : dict of str to HighFrequencyPower
        Crank-angle profiles of the vibration channels' high-frequency power, when asked for.
    stage_seconds : dict of str to float
        Seconds spent in each stage of the computation (those run per channel summed over the
        threads that ran them) [s].
    """

    reference: AngleReference
    spectra: dict[str, OrderSpectrum]
    units: dict[str, str]
    mean_speed: float
    cycle_revolutions: int
    speed_maps: dict[str, OrderSpeedMap] = field(default_factory=dict)
    high_frequency: dict[str, HighFrequencyPower] = field(default_factory=dict)
    stage_seconds: dict[str, float] = field(default_factory=dict)


def spectra(
    recording: Recording,
    *,
    cycle_revolutions: int,
    channels: list[str] | None = None,
    samples_per_cycle: int | None = None,
    max_order: float = 24.0,
    block_cycles: int = 1,
    interpolation_order: Literal[1, 3, 5] | None = None,
    cycle_phase: float | None = None,
    speed_bins: int | None = None,
    workers: int | None = None,
    high_frequency: bool = False,
    pitch_correction: PitchCorrection | Literal["estimate", "none"] = "estimate",
    kept_orders: list[int] | None = None,
    progress: Callable[[float], None] | None = None,
) -> SpectrumResult:
    """Order spectra of the waveform channels of a recording and of its crank speed.

    Parameters
    ----------
    recording : Recording
    cycle_revolutions : int
        1 two-stroke, 2 four-stroke.
    channels : list of str, optional
        Channels to analyse; default: every accelerometer, velocity, pressure and speed channel.
    samples_per_cycle : int, optional
        Angle-domain grid; default: at least 8 samples per highest order, a power of two.
    max_order : float, optional
        Highest order reported [-].
    block_cycles : int, optional
        Cycles per averaged block.
    interpolation_order : int, optional
        1, 3 or 5: B-spline resampling after an FFT filter instead of the fused band-limited kernel
        (see :mod:`monitor.signal.kernels`).
    cycle_phase : float, optional
        Four-stroke phase shift if known [rad].
    speed_bins : int, optional
        Also map every channel's order amplitudes against speed in this many bins (run-ups).
    workers : int, optional
        Threads computing channels in parallel; default: one per core.
    high_frequency : bool, optional
        Also profile the high-frequency power of every acceleration and velocity channel over
        the cycle (in the same pass over its samples).
    pitch_correction : PitchCorrection or {"estimate", "none"}, optional
        The tooth wheel's pitch errors (see :func:`angle_reference`).
    kept_orders : list of int, optional
        Integer orders the engine excites, left to it by the pitch-error estimate (see
        :func:`angle_reference`) [-].
    progress : callable, optional
        Told the fraction of the resampling done (over all channels), from 0 to 1 [-].

    Returns
    -------
    SpectrumResult
        With the seconds spent in each stage (``stage_seconds``; the channels' stages summed over
        the threads that ran them).
    """
    if not (math.isfinite(max_order) and max_order > 0):
        raise SignalError(f"max_order = {max_order!r}: expected a positive order")
    clock = StageClock()
    reference = angle_reference(
        recording,
        cycle_revolutions=cycle_revolutions,
        cycle_phase=cycle_phase,
        pitch_correction=pitch_correction,
        kept_orders=kept_orders,
        clock=clock,
    )
    angle_map = reference.angle_map
    how = _Resampling(
        angle_map,
        _grid_samples(angle_map, cycle_revolutions, max_order, samples_per_cycle),
        cycle_revolutions,
        max_order,
        block_cycles,
        interpolation_order,
        speed_bins,
        high_frequency,
        clock,
    )
    jobs, grids = _channel_grids(recording, _analysed(recording, channels), how)
    shared = _SharedProgress(list(jobs), progress)
    # channels in parallel threads: reading, FFTs, splines and the compiled loops release the GIL
    count = workers if workers is not None else min(os.cpu_count() or 1, len(jobs) + 1)
    with ThreadPoolExecutor(max_workers=max(1, count)) as pool:
        crank_job = pool.submit(_crank_spectra, reference, how, list(grids.values()))
        # the steady-speed check reads the angle map alone: beside the channels, not after them
        steadiness = pool.submit(_speed_notes, reference, cycle_revolutions, clock)
        channel_jobs = {
            name: pool.submit(_channel_spectrum, *jobs[name], how, shared.told(name)) for name in jobs
        }
        outcomes = {name: job.result() for name, job in channel_jobs.items()}
        crank = crank_job.result()
    result = {name: outcome[0] for name, outcome in outcomes.items()}
    units = {name: jobs[name][0].unit for name in jobs}
    maps = {name: outcome[1] for name, outcome in outcomes.items() if outcome[1] is not None}
    if crank is not None:
        result[SPEED_CHANNEL], result[ANGULAR_VIBRATION_CHANNEL] = _with_systematic(
            crank, reference, angle_map.mean_speed
        )
        units[SPEED_CHANNEL], units[ANGULAR_VIBRATION_CHANNEL] = "rad/s", "rad"
    profiled = dict(sorted((name, o[2]) for name, o in outcomes.items() if o[2] is not None))
    reference = replace(
        reference,
        notes=reference.notes
        + tuple(_pressure_peak_notes(recording, reference))
        + tuple(steadiness.result()),
    )
    return SpectrumResult(
        reference,
        result,
        units,
        angle_map.mean_speed,
        cycle_revolutions,
        maps,
        profiled,
        dict(clock.seconds),
    )


def _grid_samples(
    angle_map: AngleMap, cycle_revolutions: int, max_order: float, samples_per_cycle: int | None
) -> int:
    """The angle-domain grid's samples per cycle: the given ones checked, or enough for ``max_order``.

    Raises
    ------
    SignalError
        For a given grid too coarse for ``max_order`` at the recording's speed range.
    """
    slowest, fastest = angle_map.speed_range
    speed_ratio = fastest / slowest
    # the anti-alias filter passes up to 0.8 of the grid's Nyquist order at the slowest speed: max_order
    # at the fastest speed must lie below that: N >= R (fastest / slowest) max_order / (0.8 * 0.5)
    needed = cycle_revolutions * speed_ratio * max_order / 0.4
    if samples_per_cycle is None:
        return int(2 ** math.ceil(math.log2(max(needed, 16))))
    if samples_per_cycle < needed:
        raise SignalError(
            f"samples_per_cycle = {samples_per_cycle}: with the speed varying {speed_ratio:.2f}:1 the "
            f"anti-alias filter would attenuate orders up to max_order = {max_order:g}; "
            f"use at least {math.ceil(needed)} (or a lower max_order)"
        )
    return samples_per_cycle


def _analysed(recording: Recording, channels: list[str] | None) -> list[str]:
    """The channels named, or every accelerometer, velocity, pressure and speed waveform."""
    if channels is not None:
        return channels
    return [
        c.name
        for c in recording.channels
        if c.kind in ("acceleration", "velocity", "pressure", "speed") and not c.is_events
    ]


@dataclass(frozen=True)
class _Resampling:
    """What every channel of one :func:`spectra` is resampled and transformed with."""

    angle_map: AngleMap
    samples_per_cycle: int
    cycle_revolutions: int
    max_order: float
    block_cycles: int
    interpolation_order: Literal[1, 3, 5] | None
    speed_bins: int | None
    high_frequency: bool
    clock: StageClock


def _channel_grids(
    recording: Recording, wanted: list[str], how: _Resampling
) -> tuple[dict[str, tuple[Channel, AngleGrid]], dict[tuple[float, float], AngleGrid]]:
    """Each wanted channel, checked, with its grid's times; and the grids by the span they cover.

    Raises
    ------
    SignalError
        For an event channel or one with unusable spans.
    """
    grids: dict[tuple[float, float], AngleGrid] = {}
    jobs: dict[str, tuple[Channel, AngleGrid]] = {}
    for name in wanted:
        channel = recording.channel(name)
        if channel.is_events:
            raise SignalError(f"channel {name!r} holds events, not a waveform: no spectrum")
        if channel.mask is not None:
            spans = ", ".join(f"{q.reason} {q.start:.3f}-{q.stop:.3f} s" for q in channel.quality[:3])
            more = " ..." if len(channel.quality) > 3 else ""
            raise SignalError(
                f"channel {name!r} has unusable spans ({spans}{more}): "
                "cut them out before computing its spectrum"
            )
        rate = waveform_rate(channel)
        span = (channel.start_offset, channel.start_offset + (channel.data.shape[0] - 1) / rate)
        if span not in grids:  # channels sampled at the same times share the grid's times
            with how.clock.stage("grid times"):
                grids[span] = angle_grid(
                    how.angle_map,
                    *span,
                    samples_per_cycle=how.samples_per_cycle,
                    cycle_revolutions=how.cycle_revolutions,
                )
        jobs[name] = (channel, grids[span])
    return jobs, grids


class _SharedProgress:
    """The fraction resampled over all channels, told to ``progress`` whenever one channel's grows."""

    def __init__(self, names: list[str], progress: Callable[[float], None] | None) -> None:
        self._done = dict.fromkeys(names, 0.0)
        self._progress = progress
        self._lock = threading.Lock()

    def told(self, name: str) -> Callable[[float], None]:
        """What channel ``name`` tells its fraction to."""
        return lambda fraction: self._report(name, fraction)

    def _report(self, name: str, fraction: float) -> None:
        if self._progress is None:
            return
        with self._lock:
            self._done[name] = fraction
            self._progress(sum(self._done.values()) / max(len(self._done), 1))


#: A channel's order spectrum, its order-against-speed map and its high-frequency profile (when asked).
_ChannelOutcome = tuple[OrderSpectrum, OrderSpeedMap | None, HighFrequencyPower | None]


def _channel_spectrum(
    channel: Channel, grid: AngleGrid, how: _Resampling, progress: Callable[[float], None]
) -> _ChannelOutcome:
    """One channel resampled on ``grid`` and transformed."""
    options: dict[str, Any] = {
        "samples_per_cycle": how.samples_per_cycle,
        "cycle_revolutions": how.cycle_revolutions,
        "start_time": channel.start_offset,
        "interpolation_order": how.interpolation_order,
        "grid": grid,
        "high_frequency": how.high_frequency and channel.kind in ("acceleration", "velocity"),
        "progress": progress,
        "clock": how.clock,
    }
    if how.speed_bins is None:  # the spectrum only: each block transformed as it is resampled
        spectrum, profile = angle_domain_spectrum(
            channel.data,
            waveform_rate(channel),
            how.angle_map,
            block_cycles=how.block_cycles,
            max_order=how.max_order,
            **options,
        )
        return spectrum, None, profile
    resampled = to_angle_domain(
        channel.data, waveform_rate(channel), how.angle_map, max_order=how.max_order, **options
    )
    with how.clock.stage("order spectra"):
        spectrum = order_spectrum(resampled, block_cycles=how.block_cycles, max_order=how.max_order)
    with how.clock.stage("order against speed"):
        speed_map = order_speed_map(resampled, how.angle_map, bins=how.speed_bins, max_order=how.max_order)
    return spectrum, speed_map, resampled.high_frequency


def _crank_spectra(
    reference: AngleReference, how: _Resampling, known: list[AngleGrid]
) -> tuple[OrderSpectrum, OrderSpectrum] | None:
    """The crank speed's and angular vibration's spectra (:func:`crank_speed_spectra`), timed."""
    with how.clock.stage("crank speed"):
        return crank_speed_spectra(
            reference.angle_map,
            reference.pulses_per_revolution,
            cycle_revolutions=how.cycle_revolutions,
            block_cycles=how.block_cycles,
            max_order=how.max_order,
            known=known,
        )


def _with_systematic(
    crank: tuple[OrderSpectrum, OrderSpectrum], reference: AngleReference, mean_speed: float
) -> tuple[OrderSpectrum, OrderSpectrum]:
    """The crank speed's and angular vibration's spectra with the bound the wheel's pitch errors left in
    the map put on their integer orders (:mod:`monitor.signal.pitch_uncertainty`), where it is known:
    the unlearned errors' and a correction learned over speed's own."""
    sigma = reference.pitch_scatter
    correction = reference.pitch_correction
    learned = correction is not None and correction.order_errors is not None
    if sigma is None and not learned:
        return crank
    speed, lead = crank
    teeth = reference.pulses_per_revolution

    def bounded(spectrum: OrderSpectrum, speed_of: float | None) -> OrderSpectrum:
        bound = np.zeros(spectrum.orders.shape)
        if sigma is not None:
            bound += systematic_bound(
                spectrum.orders, sigma, teeth, mean_speed=speed_of, only=reference.pitch_orders
            )
        if correction is not None:  # a correction learned over speed: its own error, order by order
            bound += learned_bound(spectrum.orders, correction, mean_speed=speed_of)
        return replace(spectrum, systematic=bound)

    return bounded(speed, mean_speed), bounded(lead, None)


def _speed_notes(reference: AngleReference, cycle_revolutions: int, clock: StageClock) -> list[str]:
    """A note when the speed is not at one steady point: the orders are then the mean over the speeds.

    The cycles' mean speeds are segmented as the diagnosis segments them (:mod:`monitor.signal.steady`,
    the speed alone): a recording that is not one steady segment from its first cycle to its last (a
    run-up, a coast-down, a load step) is noted, with its speeds and its steady spans. Timed as the
    stage "steady-speed check".
    """
    with clock.stage("steady-speed check"):
        series = cycle_series(
            reference.angle_map,
            cycle_revolutions=cycle_revolutions,
            firing_harmonic=1,
            pulses_per_revolution=reference.pulses_per_revolution,
        )
        if series.cycles < 4:
            return []
        found = steady_segments(replace(series, load=None), min_cycles=min(MIN_CYCLES, series.cycles))
    if found.at_one_point:
        return []
    rpm = series.speed * 30 / math.pi
    spread = float(rpm.std() / rpm.mean())
    spans = ", ".join(f"{s.start_s:.1f}-{s.stop_s:.1f} s" for s in found.segments)
    return [
        f"the speed is not steady: {rpm[0]:.1f} rpm at the start, {rpm[-1]:.1f} at the end, "
        f"{rpm.min():.1f} to {rpm.max():.1f} over the cycles ({100 * spread:.0f} % rms; "
        + (f"steady {spans}" if spans else "no steady span")
        + "): the orders are their mean; '--speed-map BINS' shows them by speed"
    ]


def _pressure_peak_notes(recording: Recording, reference: AngleReference) -> list[str]:
    """A warning when cylinder 1's pressure peaks implausibly far from its firing TDC (first 50 cycles)."""
    notes = []
    cycle = 2 * math.pi * (2 if reference.cycle_phase else 1)
    for channel in recording.of_kind("pressure"):
        if int(channel.fields.get("cylinder", 0)) != 1 or channel.is_events or channel.mask is not None:
            continue
        try:
            peaks = pressure_peaks(
                reference.angle_map,
                channel.data,
                waveform_rate(channel),
                start_time=channel.start_offset,
                period=cycle,
                window=math.radians(120.0),
                max_cycles=50,
            )
        except SignalError:
            continue
        low, high = PLAUSIBLE_FIRED_PEAK
        if not low <= peaks.median <= high:
            notes.append(
                f"{channel.name}: cylinder 1's pressure peaks {math.degrees(peaks.median):.1f} deg after its "
                f"firing TDC (expected {math.degrees(low):.0f} to {math.degrees(high):.0f}): the angle "
                f"reference's stated angle ({reference.source}) is probably wrong; measure it on a motored "
                "run with 'engine-monitor tdc --motored'"
            )
    return notes
