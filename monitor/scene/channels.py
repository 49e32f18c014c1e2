"""One sensor's channel of a simulated scene: its waveform or events, with the sensor effects.

A pressure sensor measures its cylinder's pressure; the angle sensors are in
:mod:`monitor.scene.pulses`, the vibration sensors in :mod:`monitor.scene.vibration`. Noise is
Gaussian, seeded per sensor.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from monitor.errors import SceneError
from monitor.io.recording import Channel
from monitor.model.engine import Engine
from monitor.scene.crank import Crank
from monitor.scene.effects import ClippingParams, GainErrorParams, NoiseParams, named
from monitor.scene.model import Scene, Sensor
from monitor.scene.pulses import event_times, pulse_waveform
from monitor.scene.sources import Sources
from monitor.scene.vibration import axial_waveform, bearing_waveform
from monitor.types import FloatArray

__all__ = ["channel"]


def _fields(sensor: Sensor) -> tuple[dict[str, float | int | str], float]:
    """The channel's fields (what the recording states about the sensor) and its pulse pitch [deg]."""
    fields: dict[str, float | int | str] = {}
    pitch_deg = 0.0
    if sensor.kind == "tooth":
        fields = {
            "teeth": sensor.teeth,
            "missing_teeth": sensor.missing_teeth,
            "first_tooth_angle_deg": sensor.first_tooth_angle_deg,
        }
        pitch_deg = 360.0 / sensor.teeth
        if sensor.signal != "pulse" and "sensor" not in sensor.unstated:
            fields["sensor"] = sensor.signal
        if sensor.polarity == "reversed" and "polarity" not in sensor.unstated:
            fields["polarity"] = "reversed"
    elif sensor.kind == "encoder":
        fields = {
            "pulses_per_revolution": sensor.pulses_per_revolution,
            "first_pulse_angle_deg": sensor.first_pulse_angle_deg,
        }
        if sensor.index_channel is not None:
            fields["index_channel"] = sensor.index_channel
        pitch_deg = 360.0 / sensor.pulses_per_revolution
    elif sensor.kind == "keyphasor":
        fields = {"pulse_angle_deg": sensor.pulse_angle_deg}
    elif sensor.kind == "cam":
        fields = {"cam_angle_deg": sensor.cam_angle_deg}
    elif sensor.kind == "pressure":
        fields = {"cylinder": int(sensor.cylinder or 1)}
    return fields, pitch_deg


def channel(
    sensor: Sensor,
    index: int,
    scene: Scene,
    engine: Engine,
    crank: Crank,
    sources: Sources | None,
    seed: int,
    expected: dict[str, Any],
) -> Channel:
    """The channel of sensor ``index``: its event times, or its waveform with the sensor effects named.

    Parameters
    ----------
    sensor : Sensor
        The sensor: its kind, representation, sample rate [Hz], unit, location and fields.
    index : int
        Its position in ``scene.sensors`` [-]; with ``seed`` it seeds its noise and faults.
    scene : Scene
        The scene: duration [s] and the named effects (gain_error, noise, clipping, faults).
    engine : Engine
        The simulated engine (cycle, cylinders, firing angles, bearings).
    crank : Crank
        The crank's angle-time table (:func:`~monitor.scene.crank.crank_motion`).
    sources : Sources or None
        The named sources' orders (:func:`~monitor.scene.sources.sources_of`); None if none is named.
    seed : int
        The simulation's noise seed [-].
    expected : dict
        The truth's expected orders and faults, by channel; this sensor's entries are added to it.

    Returns
    -------
    Channel
        Event times [s], or float32 samples [the sensor's unit] at its sample rate [Hz] over the
        scene's duration.

    Raises
    ------
    SceneError
        If the sensor needs a source that is not named (a pressure sensor without 'gas') or names
        a cylinder the engine does not have.
    """
    R = engine.cycle_revolutions
    fields, pitch_deg = _fields(sensor)
    if sensor.representation == "events":
        times = event_times(sensor, index, scene, crank, R, seed, pitch_deg, expected)
        return Channel(sensor.name, sensor.kind, "s", times, None, location=sensor.location, fields=fields)
    fs = sensor.sample_rate_hz
    n = round(scene.duration_s * fs)
    t = np.arange(n) / fs
    angle = crank.angle_at(t)
    if sensor.kind in ("tooth", "encoder", "keyphasor", "cam"):
        values = pulse_waveform(sensor, index, scene, angle, R, seed, pitch_deg, expected)
    elif sensor.kind == "pressure":
        values = _pressure(sensor, engine, sources, angle)
    elif sensor.direction == "axial":  # axial acceleration [m/s^2] or velocity [mm/s] of a journal
        values = axial_waveform(sensor, scene, engine, crank, sources, t, angle, expected)
    else:  # acceleration [m/s^2] or velocity [mm/s] at a main bearing
        values = bearing_waveform(sensor, scene, engine, crank, sources, t, angle, expected)
    gain = named(scene, "gain_error")
    if isinstance(gain, GainErrorParams) and gain.sensor == sensor.name:
        values = values * gain.gain
    noise = named(scene, "noise")
    if isinstance(noise, NoiseParams):
        rms = float((noise.model_extra or {}).get(sensor.name, 0.0))
        if rms > 0:
            values = values + rms * np.random.default_rng([seed, index]).standard_normal(n)
    measuring_range = sensor.range
    clipping = named(scene, "clipping")
    if isinstance(clipping, ClippingParams) and clipping.sensor == sensor.name:
        values = np.clip(values, -clipping.limit, clipping.limit)
        measuring_range = (-clipping.limit, clipping.limit)
    return Channel(
        sensor.name,
        sensor.kind,
        sensor.unit,
        values.astype(np.float32),
        fs,
        location=sensor.location,
        direction=sensor.direction,
        fields=fields,
        range=measuring_range,
    )


def _pressure(sensor: Sensor, engine: Engine, sources: Sources | None, angle: FloatArray) -> FloatArray:
    """The cylinder's pressure [bar] at crank angles ``angle`` (the gas source's cycle, at its firing)."""
    if sources is None or sources.pressure is None or sources.grid is None:
        raise SceneError(f"sensor {sensor.name!r} measures cylinder pressure: add the effect 'gas'")
    c = int(sensor.cylinder or 1)
    if not 1 <= c <= engine.cylinders:
        raise SceneError(f"sensor {sensor.name!r}: cylinder {c} does not exist")
    cycle = 2 * math.pi * engine.cycle_revolutions
    own = np.mod(angle - engine.firing_angles[c - 1], cycle)
    grid = np.append(sources.grid, cycle)
    trace = np.append(sources.pressure[c - 1], sources.pressure[c - 1][0])
    return np.asarray(np.interp(own, grid, trace) / 1e5)  # [bar]
