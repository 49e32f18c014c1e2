"""The calibration of a baseline: each bearing sensor's transfer, learned on a healthy recording.

The recording is analysed as a diagnosis would be (:mod:`monitor.diagnosis.analysis`); it must
show no cylinder finding.  Each bearing sensor's orders over the model's bearing force at the
strengths found are its transfer, kept with the wheel's pitch errors, the crank-speed model's
calibration and each sensor's rms velocity in a :class:`~monitor.diagnosis.baseline.Baseline`
(with no sensor at all for a recording of the crank speed alone).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from monitor.diagnosis.analysis import Analysis, analyse, bearing_sensors, engine_orders
from monitor.diagnosis.balance import Transfer
from monitor.diagnosis.baseline import Baseline, SensorBaseline
from monitor.diagnosis.findings import cylinder_findings
from monitor.diagnosis.sensors import screen_sensors
from monitor.diagnosis.zones import velocity_rms
from monitor.errors import DiagnosisError, SignalError
from monitor.io.recording import Channel, Recording
from monitor.model.engine import Engine
from monitor.model.predicted import inertia_angle_fluctuation
from monitor.signal.pitch import PitchCorrection
from monitor.signal.reference import learn_pitch_errors, learn_pitch_errors_over_speed

__all__ = ["calibrate", "pitch_over_speed"]


def calibrate(
    recording: Recording,
    engine: Engine,
    *,
    load: float = 1.0,
    transfer: Transfer = "rigid",
    max_order: float = 24.0,
    source: str = "",
    cycle_phase: float | None = None,
    pitch_from: Recording | None = None,
    exclude: tuple[str, ...] | list[str] = (),
    progress: Callable[[float], None] | None = None,
) -> Baseline:
    """Calibrate the crank-speed model and each bearing sensor's transfer on a healthy recording.

    Parameters
    ----------
    recording : Recording
        Healthy, at a steady speed.
    engine : Engine
    load : float, optional
        The load it ran at [-].
    transfer : {"rigid", "shaft-line"}, optional
        For the cylinder balance the calibration is made at.
    max_order : float, optional
        Highest order analysed [-].
    source : str, optional
        Name of the recording, kept in the baseline.
    cycle_phase : float, optional
        Four-stroke: the shift (0 or 2 pi) that puts cylinder 1's firing TDC at cycle angle 0, for a
        recording without a cam or cylinder-1 pressure channel [rad].
    pitch_from : Recording, optional
        A run of the same wheel whose speed changes (motored run-up, coast-down with the fuel
        cut): the wheel's pitch errors are learned on it at every order, firing harmonics included
        (:func:`monitor.signal.reference.learn_pitch_errors_over_speed`), instead of on ``recording`` with
        the firing harmonics left to the engine.
    exclude : sequence of str, optional
        Channels left out (not calibrated).
    progress : callable, optional
        Told the fraction of the resampling done, from 0 to 1 [-].

    Returns
    -------
    Baseline

    Raises
    ------
    DiagnosisError
        Without a vibration sensor on a main bearing and without a cylinder balance (crank-speed
        orders) either, or with a sensor that is clipped, dead or implausibly scaled (a baseline is
        the reference for later recordings: leave it out).

    Notes
    -----
    A recording of the crank speed alone (a tooth wheel, a cam) gives a baseline without sensors:
    its pitch errors, its crank-speed model's calibration, its operating point and strengths. The
    main bearings are then not judged against it.
    """
    recording, bad, _ = screen_sensors(recording, exclude=exclude)
    if bad:
        raise DiagnosisError(
            "cannot calibrate on faulty sensors: "
            + "; ".join(f"{f.channel}: {f.fault}: {f.detail}" for f in bad)
            + ". Mend them, or leave them out with "
            + " ".join(f"--exclude-channel {f.channel}" for f in bad)
        )
    sensors = bearing_sensors(recording, engine)
    # the wheel's pitch errors, learned here once for every later recording (and used here too)
    pitch = _learn_pitch(recording, engine, pitch_from)
    analysis = analyse(
        recording,
        engine,
        load=load,
        transfer=transfer,
        max_order=max_order,
        cycle_phase=cycle_phase,
        pitch=pitch,
        progress=progress,
    )
    if analysis.balance is not None and analysis.balance.separable and engine.cylinders > 1:
        faults = cylinder_findings(analysis.balance)
        if faults:
            raise DiagnosisError(
                "the recording is not healthy enough to calibrate on: "
                + "; ".join(f.summary for f in faults)
                + ". Calibrate on a recording of the engine in good order"
            )
    result = analysis.spectra
    balance = analysis.balance
    if not sensors and balance is None:
        raise DiagnosisError(
            "the recording has neither an acceleration or velocity channel on a main bearing (location "
            "'main bearing N', direction 'vertical' or 'horizontal') nor a cylinder balance from crank-speed "
            "orders (a tooth wheel or an encoder gives them; see the notes): nothing to calibrate"
        )
    out = {channel.name: _sensor_baseline(channel, b, analysis) for channel, b in sensors}
    # the sensors' profiles are sampled alike; a crank-speed-only baseline has none
    profile = result.high_frequency[sensors[-1][0].name].mean.size if sensors else 0
    used = balance is not None and balance.separable  # the strengths the bearing forces were predicted with
    strengths = balance.strength.tolist() if balance is not None and used else [1.0] * engine.cylinders
    return Baseline(
        engine_id=engine.id,
        speed_rpm=result.mean_speed * 30 / math.pi,
        load=load,
        strengths=[float(s) for s in strengths],
        samples_per_cycle=int(profile),
        sensors=out,
        source=source,
        pitch=result.reference.pitch_correction,
        pitch_channel=result.reference.source if result.reference.pitch_correction is not None else "",
        crank=balance.calibration() if balance is not None else None,
    )


def _velocity_or_nan(channel: Channel) -> float:
    try:
        return velocity_rms(channel).value
    except SignalError:  # a channel in volts: no rms velocity
        return math.nan


def pitch_over_speed(run: Recording, engine: Engine | None) -> PitchCorrection:
    """The wheel's pitch errors at every order, learned on a run whose speed changes by a quarter.

    Parameters
    ----------
    run : Recording
        A motored run-up, a coast-down or a fuel cut of the same wheel.
    engine : Engine or None
        With a ``[shaft_line]``, its reciprocating parts' inertia fluctuation (the same at every
        speed, like the wheel's errors) is taken out of what is learned; without one, or None, those
        orders stay in (:func:`monitor.signal.reference.learn_pitch_errors_over_speed`).

    Returns
    -------
    PitchCorrection
        With each whole order's standard error.

    Raises
    ------
    SignalError
        For a run without a tooth wheel or encoder, or whose speed changes too little.
    """
    inertia = None
    if engine is not None and engine.shaft_line is not None:
        inertia = inertia_angle_fluctuation(engine)
    return learn_pitch_errors_over_speed(run, inertia)


def _learn_pitch(
    recording: Recording, engine: Engine, pitch_from: Recording | None
) -> PitchCorrection | None:
    """The wheel's pitch errors: over a run of changing speed if given, else on the steady recording."""
    if pitch_from is not None:
        return pitch_over_speed(pitch_from, engine)
    harmonics = engine_orders(engine, recording, firing_only=True)
    return learn_pitch_errors(recording, engine_orders=harmonics) if harmonics is not None else None


def _sensor_baseline(channel: Channel, b: int, analysis: Analysis) -> SensorBaseline:
    """One bearing sensor's transfer ``H = X / F`` from the model's bearing force, with its error."""
    result = analysis.spectra
    spectrum = result.spectra[channel.name]
    component = 1 if channel.direction == "vertical" else 0
    force_orders = analysis.combined.orders
    index = [int(np.argmin(np.abs(force_orders - k))) for k in spectrum.orders]
    force = analysis.combined.bearing_force[b - 1, component, index]
    magnitude = np.abs(force)
    safe = np.where(magnitude > 0, force, 1.0)
    transfer_k = np.where(magnitude > 0, spectrum.amplitude / safe, 0.0)
    # H = X / F: the relative errors of X (block spread) and of F (the strengths') add
    relative = np.hypot(
        spectrum.standard_error
        / np.where(magnitude > 0, magnitude, 1.0)
        / np.maximum(np.abs(transfer_k), 1e-300),
        analysis.force_error[b - 1, component, index] / np.where(magnitude > 0, magnitude, 1.0),
    )
    error = np.where(magnitude > 0, relative * np.abs(transfer_k), 0.0)
    profile = result.high_frequency[channel.name]
    return SensorBaseline(
        channel=channel.name,
        kind=channel.kind,
        unit=channel.unit,
        bearing=b,
        direction=channel.direction,
        sample_rate=float(channel.sample_rate or 0.0),
        orders=spectrum.orders,
        transfer=np.asarray(transfer_k, dtype=np.complex128),
        transfer_error=np.asarray(error, dtype=np.float64),
        high_frequency=profile,
        velocity_rms=_velocity_or_nan(channel),
    )
