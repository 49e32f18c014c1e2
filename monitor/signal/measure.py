"""The measured side, composed: recording -> angle map -> angle-domain channels -> order spectra.

The CLI, the service and the batch call these functions, nothing deeper.

Angle reference.  A tooth-wheel channel is preferred (many pulses per
revolution: a precise map at varying speed), then an encoder with its
index, else a keyphasor; a recording with none is refused, not guessed.
A tooth wheel's or encoder's own pitch errors are estimated from the
recording (or taken from a baseline) and corrected
(:func:`monitor.signal.pitch.estimate_pitch_errors`).  Four-stroke
engines also need the cycle phase: given, else the recording's
``cycle_phase_deg``, else from a cam channel, else from cylinder 1's pressure
channel; without these it is refused.

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
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np

from monitor.errors import SignalError
from monitor.io import open_recording, read_recording
from monitor.io.recording import Channel, Recording
from monitor.model.engine import Engine
from monitor.runtime.timing import StageClock, stage
from monitor.signal.anglemap import AngleMap, cycle_phase_from_cam, cycle_phase_from_pressure
from monitor.signal.crank_speed import crank_speed_spectra
from monitor.signal.grid import AngleGrid, angle_grid
from monitor.signal.impact import HighFrequencyPower
from monitor.signal.pitch import (
    PitchCorrection,
    correct_pitch,
    estimate_pitch_errors,
    learn_pitch_over_speed,
)
from monitor.signal.pulses import detect_edges, detect_pulses, repair_keyphasor
from monitor.signal.resample import angle_domain_spectrum, to_angle_domain
from monitor.signal.spectrum import OrderSpectrum, OrderSpeedMap, order_spectrum, order_speed_map
from monitor.signal.tdc import PLAUSIBLE_FIRED_PEAK, pressure_peaks
from monitor.signal.toothwheel import (
    ToothWheelDecoding,
    decode_encoder,
    decode_tooth_signal,
    decode_tooth_wheel,
)

__all__ = [
    "AngleReference",
    "SpectrumResult",
    "angle_reference",
    "learn_pitch_errors",
    "learn_pitch_errors_over_speed",
    "open_recording",
    "read_recording",
    "spectra",
]

SPEED_CHANNEL = "crank speed"
# a learned pitch error of a tooth away from the gap larger than this share of the pitch is no wheel's
# machining (hundredths of a degree): it is the engine's own speed fluctuation at orders above those
# left to it (a single cylinder's sharp firing pulse); correcting it would take that motion away [-]
PLAUSIBLE_PITCH_ERROR = 0.1
ANGULAR_VIBRATION_CHANNEL = "crank angular vibration"


@dataclass(frozen=True)
class AngleReference:
    """The angle map of a recording and how it was found.

    Attributes
    ----------
    angle_map : AngleMap
        Cycle angle against time (0 at firing TDC of cylinder 1).
    source : str
        The channel it came from.
    repairs : int
        Pulses inserted or removed.
    cycle_phase : str
        How the four-stroke phase was found ("cam", "pressure", "given", or "" for two-stroke).
    pulses_per_revolution : int
        Pulses the map is built from per revolution (teeth present, or 1): the map
        resolves speed orders below half of it.
    pitch_correction : PitchCorrection or None
        The tooth wheel's or encoder's pitch errors corrected, if any.
    notes : tuple of str
        What a user should know about the reference (an inferred sensor kind, reversed polarity,
        a correction skipped).
    """

    angle_map: AngleMap
    source: str
    repairs: int
    cycle_phase: str
    pulses_per_revolution: int
    pitch_correction: PitchCorrection | None = None
    notes: tuple[str, ...] = ()


def _edges(channel: Channel, *, alike: bool = False) -> np.ndarray:
    """Edge times of a pulse channel; ``alike``: pulses all of one height, glitches left out."""
    if channel.is_events:
        return np.asarray(channel.data, dtype=np.float64)
    _clean(channel)
    if alike:
        return detect_pulses(channel.data, _rate(channel), start_time=channel.start_offset).times
    return detect_edges(channel.data, _rate(channel), start_time=channel.start_offset).times


def _clean(channel: Channel) -> None:
    if channel.mask is not None:
        raise SignalError(
            f"channel {channel.name!r} has {len(channel.quality)} unusable span(s) "
            "(NaN, Inf or clipping): a pulse channel must be clean"
        )


def _tooth_decoding(channel: Channel) -> ToothWheelDecoding:
    teeth, missing = int(channel.fields["teeth"]), int(channel.fields["missing_teeth"])
    first = math.radians(float(channel.fields["first_tooth_angle_deg"]))
    try:
        if channel.is_events:
            return decode_tooth_wheel(_edges(channel), teeth=teeth, missing=missing, first_tooth_angle=first)
        _clean(channel)
        sensor = channel.fields.get("sensor")
        polarity = channel.fields.get("polarity")
        return decode_tooth_signal(
            channel.data,
            _rate(channel),
            teeth=teeth,
            missing=missing,
            first_tooth_angle=first,
            start_time=channel.start_offset,
            sensor=None if sensor is None else "vr" if sensor == "vr" else "hall",
            polarity=None if polarity is None else "reversed" if polarity == "reversed" else "normal",
        )
    except SignalError as error:
        raise SignalError(f"tooth wheel {channel.name!r}: {error}") from None


def _encoder_decoding(recording: Recording, channel: Channel) -> ToothWheelDecoding:
    named = channel.fields.get("index_channel")
    if named is not None:
        index = recording.channel(str(named))
    else:
        candidates = recording.of_kind("keyphasor")
        if not candidates:
            raise SignalError(
                f"encoder {channel.name!r} has no index: add a keyphasor channel with the index pulse, "
                "or name it in the encoder's 'index_channel'"
            )
        index = candidates[0]
    try:
        return decode_encoder(
            _edges(channel, alike=True),
            _edges(index, alike=True),
            pulses=int(channel.fields["pulses_per_revolution"]),
            first_pulse_angle=math.radians(float(channel.fields["first_pulse_angle_deg"])),
        )
    except SignalError as error:
        raise SignalError(f"encoder {channel.name!r} with index {index.name!r}: {error}") from None


def _rate(channel: Channel) -> float:
    if channel.sample_rate is None:
        raise SignalError(f"channel {channel.name!r} holds events, not a waveform")
    return float(channel.sample_rate)


def angle_reference(
    recording: Recording,
    *,
    cycle_revolutions: int,
    cycle_phase: float | None = None,
    pitch_correction: PitchCorrection | Literal["estimate", "none"] = "estimate",
    kept_orders: list[int] | None = None,
    clock: StageClock | None = None,
) -> AngleReference:
    """The crank (cycle) angle map of a recording.

    Parameters
    ----------
    recording : Recording
    cycle_revolutions : int
        1 two-stroke, 2 four-stroke.
    cycle_phase : float, optional
        Four-stroke: the shift (0 or 2 pi) to apply, if known [rad]; otherwise it is found from
        a cam or a cylinder-1 pressure channel.
    pitch_correction : PitchCorrection or {"estimate", "none"}, optional
        A tooth wheel's or encoder's pitch errors: a correction learned earlier (a baseline's),
        estimated from this recording (the default; skipped with a note on fewer than four
        revolutions), or none.
    kept_orders : list of int, optional
        Integer orders left to the engine by the estimate (see
        :func:`monitor.signal.pitch.estimate_pitch_errors`).
    clock : StageClock, optional
        Adds the time of each stage (pulses and decoding, pitch errors, gap filling, cycle phase).

    Returns
    -------
    AngleReference

    Raises
    ------
    SignalError
        Without a usable angle reference (no tooth wheel, encoder or keyphasor channel, or one that
        does not decode), or a four-stroke cycle phase that cannot be found.
    """
    teeth = recording.of_kind("tooth")
    encoders = recording.of_kind("encoder")
    keyphasors = recording.of_kind("keyphasor")
    notes: list[str] = []
    correction: PitchCorrection | None = None
    if teeth or encoders:
        channel = teeth[0] if teeth else encoders[0]
        with stage(clock, "angle reference: pulses and decoding"):
            decoding = _tooth_decoding(channel) if teeth else _encoder_decoding(recording, channel)
        notes.extend(f"{channel.name}: {note}" for note in decoding.notes)
        with stage(clock, "angle reference: pitch errors"):
            if isinstance(pitch_correction, PitchCorrection):
                correction = pitch_correction
            elif pitch_correction == "estimate":
                try:
                    estimate = estimate_pitch_errors(decoding, kept_orders=kept_orders)
                    correction = _plausible(estimate, decoding)
                except SignalError as why:
                    notes.append(f"{channel.name}: no tooth-pitch correction ({why})")
            if correction is not None:
                try:
                    decoding = correct_pitch(decoding, correction)
                except SignalError as error:
                    raise SignalError(f"{channel.name}: {error}") from None
        # the wheel's gap: the speed's shape inside it from the cycle's shape elsewhere (orders the
        # pulses determine, below half the pulses per cycle)
        with stage(clock, "angle reference: gap filling"):
            angle_map = AngleMap(decoding.times, decoding.angles).with_gaps_filled(
                2 * math.pi * cycle_revolutions, harmonics=decoding.teeth * cycle_revolutions
            )
        repairs = int(decoding.inserted.size + decoding.removed.size)
        pulses = decoding.teeth - decoding.missing
    elif keyphasors:
        channel = keyphasors[0]
        try:
            with stage(clock, "angle reference: pulses and decoding"):
                repaired = repair_keyphasor(_edges(channel, alike=True))
        except SignalError as error:
            raise SignalError(f"keyphasor {channel.name!r}: {error}") from None
        angle_map = AngleMap.from_keyphasor(
            repaired.times, pulse_angle=math.radians(float(channel.fields["pulse_angle_deg"]))
        )
        repairs = int(repaired.inserted.size + repaired.removed.size)
        pulses = 1
    else:
        raise SignalError(
            "the recording has no tooth-wheel, encoder or keyphasor channel: no usable angle reference"
        )
    how = ""
    if cycle_revolutions == 2:
        start = time.perf_counter()
        firing_pressure = [c for c in recording.of_kind("pressure") if int(c.fields.get("cylinder", 0)) == 1]
        if cycle_phase is not None:
            shift, how = float(cycle_phase), "given"
        elif recording.cycle_phase_deg is not None:
            shift, how = math.radians(recording.cycle_phase_deg), "recording"
        elif recording.of_kind("cam"):
            cam = recording.of_kind("cam")[0]
            shift = cycle_phase_from_cam(
                angle_map, _edges(cam, alike=True), cam_angle=math.radians(float(cam.fields["cam_angle_deg"]))
            )
            how = "cam"
        elif firing_pressure:
            p = firing_pressure[0]
            shift = cycle_phase_from_pressure(angle_map, p.data, _rate(p), start_time=p.start_offset)
            how = "pressure"
        else:
            raise SignalError(
                "four-stroke recording without a cam or cylinder-1 pressure channel: the cycle phase "
                "(which revolution holds cylinder 1's firing TDC) cannot be found; give it with "
                "--cycle-phase 0 or 360 (the crank angle added to the angle reference's, in degrees), or "
                "state it as the recording's cycle_phase_deg"
            )
        angle_map = angle_map.shifted(shift)
        if clock is not None:
            clock.add("angle reference: cycle phase", time.perf_counter() - start)
    return AngleReference(angle_map, channel.name, repairs, how, pulses, correction, tuple(notes))


def learn_pitch_errors(recording: Recording, *, engine_orders: list[int]) -> PitchCorrection | None:
    """Every tooth's pitch error, learned on a healthy baseline recording, for later recordings.

    Parameters
    ----------
    recording : Recording
        A healthy recording at steady speed, with a tooth wheel or an encoder.
    engine_orders : list of int
        The integer crank-speed orders a healthy engine of this kind excites (its firing harmonics):
        left to the engine [-].

    Returns
    -------
    PitchCorrection or None
        None without a tooth wheel or encoder, or where the errors it would learn are more than
        :data:`PLAUSIBLE_PITCH_ERROR` of a tooth pitch (the engine's motion, not the wheel's).

    Raises
    ------
    SignalError
        If the wheel does not decode or the recording is shorter than four revolutions.

    Notes
    -----
    A healthy engine's cylinders fire alike, so its gas and inertia torques, and the speed
    fluctuation they drive, sit at the firing harmonics; everything else that repeats every
    revolution is taken as the wheel's (:func:`monitor.signal.pitch.estimate_pitch_errors`
    with every tooth corrected). What the baseline's own cylinders do unevenly at the other
    integer orders is taken as the wheel's too: later recordings corrected with it measure those
    orders against the baseline's.
    """
    teeth = recording.of_kind("tooth")
    encoders = recording.of_kind("encoder")
    if not (teeth or encoders):
        return None
    channel = teeth[0] if teeth else encoders[0]
    decoding = _tooth_decoding(channel) if teeth else _encoder_decoding(recording, channel)
    learned = estimate_pitch_errors(decoding, kept_orders=engine_orders, scope="all")
    try:
        _plausible(learned, decoding)
    except SignalError:
        return None  # the recordings diagnosed later estimate their own, and say why they cannot
    return replace(learned, source="baseline")


def _plausible(correction: PitchCorrection, decoding: ToothWheelDecoding) -> PitchCorrection:
    """The correction, if its largest error is one a wheel can have (:data:`PLAUSIBLE_PITCH_ERROR`).

    Only a correction of every tooth is judged: the gap's neighbours are timed late or early by the
    bent field by up to a third of a pitch on a real wheel (the tue-4gb10 wheel,
    tests/signal/test_real_sensors.py).
    """
    if correction.scope == "all" and correction.largest > PLAUSIBLE_PITCH_ERROR * decoding.pitch:
        raise SignalError(
            f"the errors it would learn reach {math.degrees(correction.largest):.2g} deg, more than "
            f"{PLAUSIBLE_PITCH_ERROR:g} of a tooth pitch: that is the engine's own motion, not the wheel's"
        )
    return correction


def learn_pitch_errors_over_speed(recording: Recording, engine: Engine | None = None) -> PitchCorrection:
    """Every tooth's pitch error at every order, learned on a run whose speed changes.

    Parameters
    ----------
    recording : Recording
        A motored run-up, a coast-down with the fuel cut, or a run-up at a fixed fuel setting, with
        a tooth wheel or an encoder; its mean speed must change by a quarter or more.
    engine : Engine, optional
        With a ``[shaft_line]``: its reciprocating parts' inertia fluctuation (the same at every speed,
        like the wheel's errors) is taken out of the estimate by the model
        (:func:`monitor.model.predicted.inertia_angle_fluctuation`). Without one it stays in.

    Returns
    -------
    PitchCorrection
        ``source="run-up"``.

    Raises
    ------
    SignalError
        Without a tooth wheel or encoder, or a run whose speed changes too little.

    Notes
    -----
    See :func:`monitor.signal.pitch.learn_pitch_over_speed`: the gas forces' share of the crank's
    fluctuation falls with the square of the speed, the wheel's errors do not change; the
    inertia's share does not change either and comes from the model.
    """
    teeth = recording.of_kind("tooth")
    encoders = recording.of_kind("encoder")
    if not (teeth or encoders):
        raise SignalError("the run has no tooth-wheel or encoder channel: no pitch errors to learn")
    channel = teeth[0] if teeth else encoders[0]
    decoding = _tooth_decoding(channel) if teeth else _encoder_decoding(recording, channel)
    fluctuation = None
    if engine is not None and engine.shaft_line is not None:
        from monitor.model.predicted import inertia_angle_fluctuation

        fluctuation = inertia_angle_fluctuation(engine)
    return learn_pitch_over_speed(decoding, speed_independent=fluctuation)


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
    slowest, fastest = reference.angle_map.speed_range
    speed_ratio = fastest / slowest
    # the anti-alias filter passes up to 0.8 of the grid's Nyquist order at the slowest speed: max_order
    # at the fastest speed must lie below that: N >= R (fastest / slowest) max_order / (0.8 * 0.5)
    needed = cycle_revolutions * speed_ratio * max_order / 0.4
    if samples_per_cycle is None:
        samples_per_cycle = 2 ** math.ceil(math.log2(max(needed, 16)))
    elif samples_per_cycle < needed:
        raise SignalError(
            f"samples_per_cycle = {samples_per_cycle}: with the speed varying {speed_ratio:.2f}:1 the "
            f"anti-alias filter would attenuate orders up to max_order = {max_order:g}; "
            f"use at least {math.ceil(needed)} (or a lower max_order)"
        )
    wanted = (
        channels
        if channels is not None
        else [
            c.name
            for c in recording.channels
            if c.kind in ("acceleration", "velocity", "pressure", "speed") and not c.is_events
        ]
    )
    angle_map = reference.angle_map
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
        rate = _rate(channel)
        span = (channel.start_offset, channel.start_offset + (channel.data.shape[0] - 1) / rate)
        if span not in grids:  # channels sampled at the same times share the grid's times
            with clock.stage("grid times"):
                grids[span] = angle_grid(
                    angle_map, *span, samples_per_cycle=samples_per_cycle, cycle_revolutions=cycle_revolutions
                )
        jobs[name] = (channel, grids[span])

    profiles: dict[str, HighFrequencyPower] = {}
    done = dict.fromkeys(jobs, 0.0)
    progress_lock = threading.Lock()

    def report(name: str, fraction: float) -> None:
        if progress is None:
            return
        with progress_lock:
            done[name] = fraction
            progress(sum(done.values()) / max(len(done), 1))

    def channel_spectrum(name: str) -> tuple[OrderSpectrum, OrderSpeedMap | None]:
        channel, grid = jobs[name]
        options: dict[str, Any] = {
            "samples_per_cycle": samples_per_cycle,
            "cycle_revolutions": cycle_revolutions,
            "start_time": channel.start_offset,
            "interpolation_order": interpolation_order,
            "grid": grid,
            "high_frequency": high_frequency and channel.kind in ("acceleration", "velocity"),
            "progress": lambda fraction: report(name, fraction),
            "clock": clock,
        }
        if speed_bins is None:  # the spectrum only: each block transformed as it is resampled
            spectrum, profile = angle_domain_spectrum(
                channel.data,
                _rate(channel),
                angle_map,
                block_cycles=block_cycles,
                max_order=max_order,
                **options,
            )
            if profile is not None:
                profiles[name] = profile
            return spectrum, None
        resampled = to_angle_domain(channel.data, _rate(channel), angle_map, max_order=max_order, **options)
        with clock.stage("order spectra"):
            spectrum = order_spectrum(resampled, block_cycles=block_cycles, max_order=max_order)
        if resampled.high_frequency is not None:
            profiles[name] = resampled.high_frequency
        with clock.stage("order against speed"):
            return spectrum, order_speed_map(resampled, angle_map, bins=speed_bins, max_order=max_order)

    # channels in parallel threads: reading, FFTs, splines and the compiled loops release the GIL
    count = workers if workers is not None else min(os.cpu_count() or 1, len(jobs) + 1)

    def timed_crank_spectra() -> tuple[OrderSpectrum, OrderSpectrum] | None:
        with clock.stage("crank speed"):
            return crank_speed_spectra(
                angle_map,
                reference.pulses_per_revolution,
                cycle_revolutions=cycle_revolutions,
                block_cycles=block_cycles,
                max_order=max_order,
                known=list(grids.values()),
            )

    with ThreadPoolExecutor(max_workers=max(1, count)) as pool:
        crank_job = pool.submit(timed_crank_spectra)
        channel_jobs = {name: pool.submit(channel_spectrum, name) for name in jobs}
        outcomes = {name: job.result() for name, job in channel_jobs.items()}
        crank = crank_job.result()
    result = {name: spectrum for name, (spectrum, _) in outcomes.items()}
    units = {name: jobs[name][0].unit for name in jobs}
    maps = {name: m for name, (_, m) in outcomes.items() if m is not None}
    if crank is not None:
        result[SPEED_CHANNEL], result[ANGULAR_VIBRATION_CHANNEL] = crank
        units[SPEED_CHANNEL], units[ANGULAR_VIBRATION_CHANNEL] = "rad/s", "rad"
    profiled = dict(sorted(profiles.items()))
    reference = replace(reference, notes=reference.notes + tuple(_pressure_peak_notes(recording, reference)))
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
                _rate(channel),
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
