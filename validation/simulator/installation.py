"""The sensors on an engine: sample rate, structural modes, crosstalk, ranges, noise, angle sensors."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy import signal

from validation.simulator.engine import SimEngine
from validation.simulator.gas import rated_of_seed
from validation.simulator.kinematics import bearing_split, cylinder_vertical_forces
from validation.simulator.shared import INSTALLATION_STREAM, FloatArray


@dataclass(frozen=True)
class Installation:
    """The sensors on an engine: the same for every case of that engine.

    Attributes
    ----------
    sample_rate : float
        Of the bearing channels [Hz].
    sensor_bearings : tuple of int
        Main bearings (1-based) carrying a vertical accelerometer.
    crosstalk : ndarray, shape (s, b)
        Each sensor's view of the bearings' vertical forces (1 for its own) [-].
    modes : tuple of ndarray
        Per sensor, rows (frequency [Hz], damping ratio [-], gain [1/kg]).
    level : ndarray, shape (s,)
        Expected rms acceleration of each sensor in rated operation [m/s^2].
    noise : ndarray, shape (s,)
        Broadband noise, standard deviation [m/s^2].
    hum_frequency : float
        Mains [Hz].
    hum : ndarray, shape (s,)
        Mains hum amplitude [m/s^2].
    adc_range : ndarray, shape (s,)
        Symmetric measuring range [m/s^2].
    tooth_errors : ndarray, shape (60,)
        Angular error of each tooth position (0 for the first after the gap) [rad].
    first_tooth_angle : float
        Crank angle of the first tooth after the gap after cylinder 1's TDC [rad].
    cam_angle : float or None
        Cycle angle of the cam pulse after cylinder 1's firing TDC [rad] (four-strokes).
    keyphasor_angle : float or None
        Crank angle of the keyphasor pulse after cylinder 1's TDC [rad], if fitted.
    tooth_jitter : float
        Timing jitter of the tooth and keyphasor events, standard deviation [s].
    cam_jitter : float
        Of the cam events [s].
    """

    sample_rate: float
    sensor_bearings: tuple[int, ...]
    crosstalk: FloatArray
    modes: tuple[FloatArray, ...]
    level: FloatArray
    noise: FloatArray
    hum_frequency: float
    hum: FloatArray
    adc_range: FloatArray
    tooth_errors: FloatArray
    first_tooth_angle: float
    cam_angle: float | None
    keyphasor_angle: float | None
    tooth_jitter: float
    cam_jitter: float

    def channel_name(self, sensor: int) -> str:
        """Name of sensor ``sensor``'s channel (index into ``sensor_bearings``)."""
        return f"mb{self.sensor_bearings[sensor]}-vertical"


def mode_sos(frequency: float, damping: float, gain: float, sample_rate: float) -> FloatArray:
    """``g s^2 / (s^2 + 2 zeta w s + w^2)`` by the bilinear transform, prewarped at the mode."""
    w = 2 * sample_rate * math.tan(math.pi * frequency / sample_rate)
    poles = np.roots([1.0, 2 * damping * w, w**2])
    z, p, k = signal.bilinear_zpk(np.zeros(2), poles, gain, sample_rate)
    return np.asarray(signal.zpk2sos(z, p, k))


def antialias_sos(sample_rate: float) -> FloatArray:
    return np.asarray(signal.butter(6, 0.4 * sample_rate, fs=sample_rate, output="sos"))


def sensor_mix(engine: SimEngine, crosstalk: FloatArray) -> FloatArray:
    """Throw-force weights of each sensor's input, ``crosstalk @ split`` [-]."""
    split = bearing_split(engine.cylinder_positions, engine.bearing_positions, engine.throw_bearings)
    return np.asarray(crosstalk @ split)


def _nice_ceiling(value: float) -> float:
    """The next value of the 1-2-5 series at or above ``value``."""
    decade = 10 ** math.floor(math.log10(value))
    for mantissa in (1, 2, 5, 10):
        if mantissa * decade >= value:
            return float(mantissa * decade)
    return float(10 * decade)  # pragma: no cover


def random_installation(engine: SimEngine) -> Installation:
    """Draw the sensors of an engine (from the engine's seed, its own stream).

    Parameters
    ----------
    engine : SimEngine

    Returns
    -------
    Installation

    Notes
    -----
    Mode frequencies are log-uniform between ``30 sqrt(0.32 / D)`` and ``2500 sqrt(0.32 / D)`` Hz
    (below 0.4 of the sample rate), damping ratios 0.02-0.08, modal gains (inverse modal masses)
    in a random ratio.  A sensor's steady response to the bearing forces of the rated cycle at an
    even rated speed is computed over the cycle's harmonics (Parseval), and its gains are scaled
    so that its rms velocity over 2-1000 Hz is 2-8 mm/s (a healthy engine in ISO 10816-6 terms);
    its rms acceleration then sets the noise (0.5-3 %), the hum (0.2-1 %) and the measuring range
    (20-40 times, rounded up to 1-2-5: an engine's structure-borne acceleration has crest factors
    past 10, and an installer leaves headroom above them), the same in every case of the engine.
    """
    rng = np.random.default_rng(np.random.SeedSequence([engine.seed, INSTALLATION_STREAM]))
    rated_rpm = engine.rated_speed * 30 / math.pi
    fs = 10240.0 if rated_rpm < 300 else 25600.0
    nb = engine.bearing_count
    count = min(nb, int(rng.integers(2, 5)))
    bearings = tuple(sorted(int(b) + 1 for b in rng.choice(nb, size=count, replace=False)))
    crosstalk = np.zeros((count, nb))
    for s, b in enumerate(bearings):
        crosstalk[s, b - 1] = 1.0
        for nb_ in (b - 1, b + 1):
            if 1 <= nb_ <= nb:
                crosstalk[s, nb_ - 1] = rng.uniform(0.05, 0.2)
    size = math.sqrt(0.32 / engine.bore)
    f_low, f_high = 30 * size, min(2500 * size, 0.4 * fs)
    modes = []
    for _ in bearings:
        k = int(rng.integers(2, 4))
        modes.append(
            np.column_stack(
                [
                    np.exp(rng.uniform(math.log(f_low), math.log(f_high), k)),
                    rng.uniform(0.02, 0.08, k),
                    1 / rng.uniform(0.5, 2.0, k),
                ]
            )
        )
    # expected level: the steady response, at rated speed and load, to the bearing forces of the
    # rated cycle with the crank turning evenly (Parseval over the cycle's harmonics)
    _, angle, rated_pressure = rated_of_seed(engine.seed, engine.is_vee)
    mix = sensor_mix(engine, crosstalk)
    points = 4096
    cycle = engine.cycle_angle
    psi = cycle * np.arange(points)[None, :] / points - engine.firing_angles[:, None]
    local = np.mod(psi + cycle / 2, cycle) - cycle / 2
    pressure = np.interp(local, angle, rated_pressure, period=cycle)
    throws = cylinder_vertical_forces(engine, psi, pressure, engine.rated_speed, 0.0)
    spectrum = np.fft.rfft(mix @ throws, axis=1) / points
    frequency = np.arange(spectrum.shape[1]) * engine.rated_speed / cycle
    s_var = 2j * math.pi * frequency
    band = (frequency >= 2.0) & (frequency <= 1000.0)
    level = np.empty(count)
    for s in range(count):
        response = np.zeros(frequency.size, dtype=complex)
        for f, z, g in modes[s]:
            w = 2 * math.pi * f
            response += g * s_var**2 / (s_var**2 + 2 * z * w * s_var + w**2)
        response[frequency > 0.45 * fs] = 0.0
        acceleration = spectrum[s] * response
        velocity = math.sqrt(2 * float(np.sum(np.abs(acceleration[band] / s_var[band]) ** 2)))
        scale = float(rng.uniform(2e-3, 8e-3)) / velocity  # healthy rated velocity 2-8 mm/s rms
        modes[s][:, 2] *= scale
        level[s] = scale * math.sqrt(2 * float(np.sum(np.abs(acceleration[1:]) ** 2)))
    noise = level * rng.uniform(0.005, 0.03, count)
    hum = level * rng.uniform(0.002, 0.01, count)
    adc = np.array([_nice_ceiling(v * rng.uniform(20, 40)) for v in level])
    errors = rng.normal(0.0, math.radians(0.02), 60)
    errors[0] = 0.0
    first = math.radians(float(rng.uniform(0, 360)))
    cam = math.radians(float(rng.uniform(0, 720))) if engine.cycle_revolutions == 2 else None
    keyphasor = math.radians(float(rng.uniform(0, 360))) if rng.random() < 0.3 else None
    return Installation(
        sample_rate=fs,
        sensor_bearings=bearings,
        crosstalk=crosstalk,
        modes=tuple(modes),
        level=level,
        noise=noise,
        hum_frequency=float(rng.choice([50.0, 60.0])),
        hum=hum,
        adc_range=adc,
        tooth_errors=errors,
        first_tooth_angle=first,
        cam_angle=cam,
        keyphasor_angle=keyphasor,
        tooth_jitter=float(rng.uniform(0.2e-6, 1e-6)),
        cam_jitter=20e-6,
    )


def without_bearing_sensors(install: Installation) -> Installation:
    """The installation with its angle sensors only: an engine measured by its crank speed alone.

    Parameters
    ----------
    install : Installation

    Returns
    -------
    Installation
        No bearing sensors (and so no bearing channels), the angle sensors unchanged.
    """
    nothing = np.zeros(0)
    return replace(
        install,
        sensor_bearings=(),
        crosstalk=np.zeros((0, install.crosstalk.shape[1])),
        modes=(),
        level=nothing,
        noise=nothing,
        hum=nothing,
        adc_range=nothing,
    )
