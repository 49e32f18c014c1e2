"""The angle reference of a recording: its crank (cycle) angle against time, and how it was found.

A tooth-wheel channel is preferred (many pulses per revolution: a precise map
at varying speed), then an encoder with its index, else a keyphasor; a
recording with none is refused, not guessed.  A tooth wheel's or encoder's
own pitch errors are estimated from the recording (or taken from a baseline,
:func:`learn_pitch_errors`, or a run-up, :func:`learn_pitch_errors_over_speed`)
and corrected (:func:`monitor.signal.pitch.estimate_pitch_errors`).
Four-stroke engines also need the cycle phase: given, else the recording's
``cycle_phase_deg``, else from a cam channel, else from cylinder 1's pressure
channel; without these it is refused.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
import numpy.typing as npt

from monitor.errors import SignalError
from monitor.io.recording import INFER_PATTERN, Channel, Recording
from monitor.runtime.timing import StageClock, stage
from monitor.signal.anglemap import AngleMap, cycle_phase_from_pressure
from monitor.signal.cam import cycle_phase_from_cam
from monitor.signal.pitch import (
    PitchCorrection,
    correct_pitch,
    estimate_pitch_errors,
    learn_pitch_over_speed,
    speed_range,
)
from monitor.signal.pitch_uncertainty import pitch_scatter
from monitor.signal.pulses import detect_edges, detect_pulses, repair_keyphasor
from monitor.signal.toothwheel import (
    ToothWheelDecoding,
    decode_encoder,
    decode_tooth_signal,
    decode_tooth_wheel,
    infer_tooth_sensor,
    tooth_edges,
)
from monitor.signal.wheels import WheelPattern, decode_pattern, infer_pattern
from monitor.types import FloatArray

__all__ = [
    "PLAUSIBLE_PITCH_ERROR",
    "AngleReference",
    "angle_reference",
    "declared_as_read",
    "learn_pitch_errors",
    "learn_pitch_errors_over_speed",
    "read_wheel",
    "waveform_rate",
]

#: A recording whose revolutions lie within this share of the speeds a stored pitch correction was
#: learned over keeps its gap teeth as learned: the 4GB10's weak tooth moves 0.45 deg per 1000 rpm,
#: 0.07 deg over 5 % of 3000 rpm, about the least a gap tooth's estimate tells from nothing [-].
SAME_SPEED = 0.05
# a learned pitch error of a tooth away from the gap larger than this share of the pitch is no wheel's
# machining (hundredths of a degree): it is the engine's own speed fluctuation at orders above those
# left to it (a single cylinder's sharp firing pulse); correcting it would take that motion away [-]
PLAUSIBLE_PITCH_ERROR = 0.1


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
    pitch_scatter : float or None
        The standard deviation of the wheel's tooth-position errors left in the map
        (:mod:`monitor.signal.pitch_uncertainty`) [rad]; 0 when all were learned at every order; None
        where not known (a keyphasor, too short a recording).
    pitch_orders : tuple of int or None
        The integer orders those errors are left in: None every one, else only these (the orders a
        baseline's correction left to the engine).
    """

    angle_map: AngleMap
    source: str
    repairs: int
    cycle_phase: str
    pulses_per_revolution: int
    pitch_correction: PitchCorrection | None = None
    notes: tuple[str, ...] = ()
    pitch_scatter: float | None = None
    pitch_orders: tuple[int, ...] | None = None


def _edges(channel: Channel, *, alike: bool = False) -> np.ndarray:
    """Edge times of a pulse channel; ``alike``: pulses all of one height, glitches left out."""
    if channel.is_events:
        return np.asarray(channel.data, dtype=np.float64)
    _refuse_unusable_spans(channel)
    if alike:
        return detect_pulses(channel.data, waveform_rate(channel), start_time=channel.start_offset).times
    return detect_edges(channel.data, waveform_rate(channel), start_time=channel.start_offset).times


def _refuse_unusable_spans(channel: Channel) -> None:
    """Refuse a pulse channel with NaN, Inf or clipped spans: its edges cannot be trusted around them."""
    if channel.mask is not None:
        raise SignalError(
            f"channel {channel.name!r} has {len(channel.quality)} unusable span(s) "
            "(NaN, Inf or clipping): a pulse channel must be clean"
        )


def read_wheel(channel: Channel) -> WheelPattern:
    """The wheel a tooth channel's edges show (for ``pattern = "infer"``: teeth and gaps read off them).

    Parameters
    ----------
    channel : Channel
        A tooth channel: edge times, or a waveform (timed as its ``sensor`` and ``polarity`` state, or
        as the waveform shows the sensor, wired the normal way).

    Returns
    -------
    WheelPattern
        By name where one fits (:func:`monitor.signal.wheels.infer_pattern`).

    Raises
    ------
    SignalError
        Where the edges show no pattern that repeats in most revolutions (no gap, fewer than three
        revolutions, a tooth between the pitches): the wheel must then be declared.
    """
    if channel.is_events:
        edges = _edges(channel)
    else:
        _refuse_unusable_spans(channel)
        stated = channel.fields.get("sensor")
        sensor = infer_tooth_sensor(np.asarray(channel.data[: 1 << 20])) if stated is None else stated
        edges = tooth_edges(
            channel.data,
            waveform_rate(channel),
            "vr" if sensor == "vr" else "hall",
            reversed_=channel.fields.get("polarity") == "reversed",
            start_time=channel.start_offset,
        )
    found = infer_pattern(edges)
    if found is None:
        raise SignalError(
            f"tooth wheel {channel.name!r}: pattern = {INFER_PATTERN!r}, but its {edges.size} edges show no "
            "wheel whose gaps repeat in most revolutions (three or more revolutions, at least one gap, no "
            "tooth between the pitches): declare teeth, missing_teeth and the pattern"
        )
    return found


def declared_as_read(channel: Channel) -> tuple[Channel, WheelPattern]:
    """The tooth channel declared as its edges show its wheel (:func:`read_wheel`), and the wheel.

    Parameters
    ----------
    channel : Channel
        A tooth channel.

    Returns
    -------
    tuple of Channel and WheelPattern
        The channel with ``teeth``, ``missing_teeth`` and ``pattern`` as found.

    Raises
    ------
    SignalError
        As :func:`read_wheel`.
    """
    found = read_wheel(channel)
    wheel: dict[str, float | int | str] = {
        "teeth": found.positions,
        "missing_teeth": found.missing,
        "pattern": found.name,
    }
    return replace(channel, fields=channel.fields | wheel), found


def _tooth_decoding(channel: Channel) -> ToothWheelDecoding:
    if channel.fields.get("pattern") == INFER_PATTERN:
        as_read, found = declared_as_read(channel)
        decoding = _tooth_decoding(as_read)
        said = (
            f"wheel read off the edges: {found.name} ({found.spelled}); declare teeth = {found.positions}, "
            f"missing_teeth = {found.missing}, pattern = {found.name!r} to have it checked instead"
        )
        return replace(decoding, notes=(*decoding.notes, said))
    teeth, missing = int(channel.fields["teeth"]), int(channel.fields["missing_teeth"])
    first = math.radians(float(channel.fields["first_tooth_angle_deg"]))
    try:
        declared = channel.fields.get("pattern")
        pattern = WheelPattern.parse(str(declared)) if declared is not None else None
        if channel.is_events:
            return decode_tooth_wheel(
                _edges(channel), teeth=teeth, missing=missing, first_tooth_angle=first, pattern=pattern
            )
        _refuse_unusable_spans(channel)
        sensor = channel.fields.get("sensor")
        polarity = channel.fields.get("polarity")
        return decode_tooth_signal(
            channel.data,
            waveform_rate(channel),
            teeth=teeth,
            missing=missing,
            first_tooth_angle=first,
            start_time=channel.start_offset,
            sensor=None if sensor is None else "vr" if sensor == "vr" else "hall",
            polarity=None if polarity is None else "reversed" if polarity == "reversed" else "normal",
            pattern=pattern,
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


def _wheel_channel(recording: Recording) -> Channel | None:
    """The recording's (first) tooth wheel, else its encoder; None without either."""
    wheels = recording.of_kind("tooth") or recording.of_kind("encoder")
    return wheels[0] if wheels else None


def _wheel_decoding(recording: Recording, channel: Channel) -> ToothWheelDecoding:
    """The pulses of a tooth wheel or an encoder (with its index), decoded."""
    return _tooth_decoding(channel) if channel.kind == "tooth" else _encoder_decoding(recording, channel)


def waveform_rate(channel: Channel) -> float:
    """A waveform channel's sample rate [Hz]; an event channel is refused.

    Parameters
    ----------
    channel : Channel
        The channel of a recording.

    Returns
    -------
    float
        Its sample rate [Hz].

    Raises
    ------
    SignalError
        If it holds events (no sample rate).
    """
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
    wheel = _wheel_channel(recording)
    keyphasors = recording.of_kind("keyphasor")
    notes: list[str] = []
    correction: PitchCorrection | None = None
    if wheel is not None:
        channel = wheel
        with stage(clock, "angle reference: pulses and decoding"):
            decoding = _wheel_decoding(recording, channel)
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
            raw = decoding
            if correction is not None:
                try:
                    decoding = correct_pitch(decoding, correction)
                    if isinstance(pitch_correction, PitchCorrection) and pitch_correction.source == "run-up":
                        decoding, correction, regapped = _gap_here(decoding, pitch_correction)
                        notes.extend([f"{channel.name}: {regapped}"] if regapped else [])
                except SignalError as error:
                    raise SignalError(f"{channel.name}: {error}") from None
            scatter, left_in = _left_errors(raw, decoding, correction)
        # the wheel's gap: the speed's shape inside it from the cycle's shape elsewhere (orders the
        # pulses determine, below half the pulses per cycle)
        with stage(clock, "angle reference: gap filling"):
            angle_map = AngleMap(decoding.times, decoding.angles).with_gaps_filled(
                2 * math.pi * cycle_revolutions, harmonics=decoding.teeth * cycle_revolutions
            )
        repairs = int(decoding.inserted.size + decoding.removed.size)
        pulses = decoding.pattern.teeth if decoding.pattern is not None else decoding.teeth - decoding.missing
    elif keyphasors:
        scatter, left_in = None, None
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
        notes.extend([said] if (said := repaired.note(channel.name)) else [])
        pulses = 1
    else:
        raise SignalError(
            "the recording has no tooth-wheel, encoder or keyphasor channel: no usable angle reference"
        )
    how = ""
    if cycle_revolutions == 2:
        start = time.perf_counter()
        shift, how, said = _cycle_phase(recording, angle_map, cycle_phase)
        notes.extend([said] if said else [])
        angle_map = angle_map.shifted(shift)
        if clock is not None:
            clock.add("angle reference: cycle phase", time.perf_counter() - start)
    return AngleReference(
        angle_map, channel.name, repairs, how, pulses, correction, tuple(notes), scatter, left_in
    )


def _gap_here(
    decoding: ToothWheelDecoding, correction: PitchCorrection
) -> tuple[ToothWheelDecoding, PitchCorrection, str]:
    """A stored correction's gap teeth re-estimated on this recording, where it shows them elsewhere.

    A gap's neighbour is read where the sensor's field bends, and a weak tooth's edge lags by a time
    rather than an angle: its error moves with the speed (the tooth after the gap of the real 4GB10
    wheel: +1.26 deg at 1340 rpm, +1.44 at 1790, +2.06 to 2.11 at 2940 to 3200 rpm, about 0.45 deg per
    1000 rpm, tests/signal/test_pitch_from_a_fuel_cut.py). A correction learned at other speeds (a
    baseline, a run-up, a fuel cut) is right for the other teeth; the gap's are estimated again on
    the corrected decoding (:func:`estimate_pitch_errors`, ``scope="gap"``), and moved where what is
    left stands out. Where the recording's revolutions lie within the speeds the correction was learned
    over (within :data:`SAME_SPEED`), it is kept as it is.

    Only a correction learned over speed (a run-up, a coast-down, a fuel cut) is read again: its trend
    is pinned on the tooth after the gap, so its gap teeth are the ones it learns worst. A baseline's,
    learned tooth by tooth at a steady point, is kept: read again on a simulated two-cylinder engine at
    835 rpm against its baseline's 1120 (make bench-diagnosis, case 200369), the gap teeth moved by
    0.5 deg and the cylinders were no longer told apart, where kept the weak one was named.
    """
    if correction.speeds:
        low, high = correction.speeds
        here = speed_range(decoding)
        if here[0] >= (1 - SAME_SPEED) * low and here[1] <= (1 + SAME_SPEED) * high:
            return decoding, correction, ""  # learned at this speed: its gap teeth hold here
    try:
        left = estimate_pitch_errors(decoding, scope="gap")
    except SignalError:
        return decoding, correction, ""
    moved = np.flatnonzero(left.errors)
    if moved.size == 0:
        return decoding, correction, ""
    said = ", ".join(f"tooth {i} {math.degrees(left.errors[i]):+.2f} deg" for i in moved)
    return (
        correct_pitch(decoding, left),
        replace(correction, errors=correction.errors + left.errors),
        f"the gap's neighbours' errors change with speed: re-estimated on this recording ({said} "
        f"beyond the {correction.source}'s correction)",
    )


def _left_errors(
    raw: ToothWheelDecoding, corrected: ToothWheelDecoding, correction: PitchCorrection | None
) -> tuple[float | None, tuple[int, ...] | None]:
    """The scatter of the tooth-position errors left in the map, and the orders they are left in.

    Uncorrected, or only beside the gap: every tooth's but those corrected, at every integer order.
    Learned on a baseline (every tooth, the kept orders left to the engine): the raw wheel's, at the
    kept orders only. Learned over speed (nothing kept): none. None where the scatter cannot be read.
    """
    try:
        if correction is None or correction.scope != "all":
            return pitch_scatter(corrected), None
        if not correction.kept_orders:
            return 0.0, ()
        return pitch_scatter(raw), tuple(int(k) for k in correction.kept_orders)
    except SignalError:
        return None, None


def _cam_marks(cam: Channel) -> FloatArray:
    """The cam's pulses that mark the cycle: every one, or on a cam wheel of several teeth (a
    ``pattern``, as 4+1) those of its position 0, the wheel decoded over the cam's turns; its
    ``cam_angle_deg`` is then that tooth's."""
    edges = _edges(cam, alike=True)
    if "pattern" not in cam.fields:
        return edges
    wheel = WheelPattern.parse(str(cam.fields["pattern"]))
    times, _, tooth = decode_pattern(edges, wheel)
    return np.asarray(times[tooth == 0], dtype=np.float64)


def _cycle_phase(
    recording: Recording, angle_map: AngleMap, cycle_phase: float | None
) -> tuple[float, str, str | None]:
    """A four-stroke map's shift (0 or 2 pi) [rad], how it was found (given, the recording's, from a cam
    channel or from cylinder 1's pressure) and a note (cam pulses left out) or None.

    Raises
    ------
    SignalError
        Without any of these.
    """
    firing_pressure = [c for c in recording.of_kind("pressure") if int(c.fields.get("cylinder", 0)) == 1]
    if cycle_phase is not None:
        return float(cycle_phase), "given", None
    if recording.cycle_phase_deg is not None:
        return math.radians(recording.cycle_phase_deg), "recording", None
    if recording.of_kind("cam"):
        cam = recording.of_kind("cam")[0]
        try:
            phase = cycle_phase_from_cam(
                angle_map, _cam_marks(cam), cam_angle=math.radians(float(cam.fields["cam_angle_deg"]))
            )
        except SignalError as error:
            raise SignalError(f"cam {cam.name!r}: {error}") from None
        return phase.shift, "cam", phase.note(cam.name)
    if firing_pressure:
        p = firing_pressure[0]
        return (
            cycle_phase_from_pressure(angle_map, p.data, waveform_rate(p), start_time=p.start_offset),
            "pressure",
            None,
        )
    raise SignalError(
        "four-stroke recording without a cam or cylinder-1 pressure channel: the cycle phase "
        "(which revolution holds cylinder 1's firing TDC) cannot be found; give it with "
        "--cycle-phase 0 or 360 (the crank angle added to the angle reference's, in degrees), or "
        "state it as the recording's cycle_phase_deg"
    )


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
    channel = _wheel_channel(recording)
    if channel is None:
        return None
    decoding = _wheel_decoding(recording, channel)
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


def learn_pitch_errors_over_speed(
    recording: Recording, speed_independent: Callable[[npt.ArrayLike], FloatArray] | None = None
) -> PitchCorrection:
    """Every tooth's pitch error at every order, learned on a run whose speed changes.

    Parameters
    ----------
    recording : Recording
        A motored run-up, a coast-down with the fuel cut, or a run-up at a fixed fuel setting, with
        a tooth wheel or an encoder; its mean speed must change by a quarter or more.
    speed_independent : callable, optional
        The engine's reciprocating parts' inertia fluctuation (the same at every speed, like the
        wheel's errors) at crank angles [rad] -> [rad], taken out of the estimate: the model's
        (:func:`monitor.model.predicted.inertia_angle_fluctuation`, for an engine with a
        ``[shaft_line]``). Without it the inertia's orders stay in.

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
    channel = _wheel_channel(recording)
    if channel is None:
        raise SignalError("the run has no tooth-wheel or encoder channel: no pitch errors to learn")
    return learn_pitch_over_speed(_wheel_decoding(recording, channel), speed_independent=speed_independent)
