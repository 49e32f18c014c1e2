"""The recorded channels: bearing accelerations (structure, bursts, sensor faults) and angle events."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy import signal

from monitor.io.recording import Channel, quality_spans
from validation.simulator.crank import CrankRun
from validation.simulator.engine import SimEngine
from validation.simulator.installation import Installation, antialias_sos, mode_sos
from validation.simulator.scenario import Scenario
from validation.simulator.shared import FloatArray, SimulationError


def _cubic(values: FloatArray | npt.NDArray[np.float32], position: FloatArray) -> FloatArray:
    """Catmull-Rom interpolation of rows sampled on a uniform grid at fractional indices."""
    size = values.shape[-1]
    i = np.floor(position).astype(np.int64)
    f = position - i
    f2, f3 = f * f, f * f * f
    weights = (
        0.5 * (-f3 + 2 * f2 - f),
        0.5 * (3 * f3 - 5 * f2 + 2),
        0.5 * (-3 * f3 + 4 * f2 + f),
        0.5 * (f3 - f2),
    )
    out = np.zeros(values.shape[:-1] + position.shape)
    for shift, w in zip((-1, 0, 1, 2), weights, strict=True):
        out += w * values[..., np.clip(i + shift, 0, size - 1)]
    return out


def _quantise(x: FloatArray, full_scale: float, bits: int = 16) -> FloatArray:
    lsb = 2 * full_scale / 2**bits
    codes = np.clip(np.round(x / lsb), -(2 ** (bits - 1)), 2 ** (bits - 1) - 1)
    return np.asarray(codes * lsb)


def _reversals(force: npt.NDArray[np.float32], hysteresis: float) -> tuple[FloatArray, str]:
    """Fractional grid indices where a force changes sign (with hysteresis), else its magnitude's minima.

    A reversal is a sign change between excursions beyond +-``hysteresis`` [N]; a force that never
    reverses gives instead the prominent minima of its magnitude (prominence 0.2 of its span, below
    its mean), where the bearing is nearest to unloading.
    """
    f = np.asarray(force, dtype=np.float64)
    state = np.where(f > hysteresis, 1, np.where(f < -hysteresis, -1, 0))
    settled = np.flatnonzero(state)
    if settled.size >= 2:
        flips = settled[1:][np.diff(state[settled]) != 0]
        if flips.size >= 4:
            sign_change = np.flatnonzero(np.signbit(f[1:]) != np.signbit(f[:-1]))
            idx = sign_change[np.searchsorted(sign_change, flips, side="left") - 1]
            frac = f[idx] / (f[idx] - f[idx + 1])
            return idx + frac, "sign"
    magnitude = np.abs(f)
    spread = float(magnitude.max() - magnitude.min())
    minima, _ = signal.find_peaks(-magnitude, prominence=0.2 * spread)
    minima = minima[magnitude[minima] < magnitude.mean()]
    return minima.astype(np.float64), "minimum"


def _load_minima(magnitude: FloatArray) -> tuple[FloatArray, str]:
    """Fractional grid indices of a planar load's prominent minima (prominence 0.2 of its span, below
    its mean): where it turns, the journal crossing its clearance ("plane"; none found: "minimum")."""
    spread = float(magnitude.max() - magnitude.min())
    minima, _ = signal.find_peaks(-magnitude, prominence=0.2 * spread)
    minima = minima[magnitude[minima] < magnitude.mean()]
    return minima.astype(np.float64), "plane" if minima.size else "minimum"


def _events(
    run: CrankRun,
    offset: float,
    span: float,
    angles0: FloatArray,
    period: float,
    jitter: float,
    rng: np.random.Generator,
) -> FloatArray:
    """Times in the recording of events at crank angles ``angles0 + j period`` (cylinder 1's angle) [s]."""
    total_angle = run.step * (run.time.size - 1)
    j = np.arange(np.floor(-angles0.max() / period), np.ceil(total_angle / period) + 1)
    angles = (j[:, None] * period + angles0[None, :]).ravel()
    angles = np.sort(angles[(angles >= 0) & (angles <= total_angle)])
    times = _cubic(run.time, angles / run.step) - offset
    times = times + rng.normal(0.0, jitter, times.size)
    out = times[(times >= 0) & (times < span)]
    if np.any(np.diff(out) <= 0):
        raise SimulationError("event jitter reordered two events: the jitter is too large for the spacing")
    return np.asarray(out)


def structural_response(
    run: CrankRun, install: Installation, pre: float, duration_s: float
) -> tuple[FloatArray, FloatArray]:
    """Clean accelerations of the bearing sensors, shape (s, samples), and the sample times' grid index."""
    fs = install.sample_rate
    count = len(install.sensor_bearings)
    samples = round((pre + duration_s) * fs)
    first = round(pre * fs)
    t = np.arange(samples) / fs
    index = np.interp(t, run.time, np.arange(run.time.size, dtype=np.float64))
    inputs = _cubic(run.forces[:count], index)
    aa = antialias_sos(fs)
    clean = np.empty((count, samples - first))
    for s in range(count):
        y = np.zeros(samples)
        for f, z, g in install.modes[s]:
            sos = mode_sos(float(f), float(z), float(g), fs)
            zi = signal.sosfilt_zi(sos) * inputs[s, 0]  # start in the steady state of the first force
            y += signal.sosfilt(sos, inputs[s], zi=zi)[0]
        clean[s] = signal.sosfilt(aa, y)[first:]
    return clean, index[first:]


def velocity_mm_s(clean: FloatArray, fs: float, band_hz: tuple[float, float] = (2.0, 1000.0)) -> FloatArray:
    """Each sensor's rms vibration velocity over a band, of its clean structural acceleration [mm/s].

    The truth a zone finding is judged against: the structure's own vibration before noise, hum and
    the converter, integrated in the frequency domain (a Hann-windowed periodogram of the whole
    record, power-normalised, divided by ``(2 pi f)^2``).  ``clean`` is in m/s^2, shape (s, samples).
    """
    n = clean.shape[1]
    window = np.hanning(n)
    spectrum = np.fft.rfft((clean - clean.mean(axis=1, keepdims=True)) * window, axis=1)
    frequency = np.fft.rfftfreq(n, 1.0 / fs)
    band = (frequency >= band_hz[0]) & (frequency <= band_hz[1])
    # one-sided power per bin, the window's power taken out: sum over bins = mean square
    power = 2.0 * np.abs(spectrum[:, band]) ** 2 / (n * float(np.sum(window**2)))
    velocity = power / (2 * math.pi * frequency[band]) ** 2
    return np.sqrt(velocity.sum(axis=1)) * 1e3


def worn_bearing_bursts(
    run: CrankRun,
    cycle: float,
    install: Installation,
    scenario: Scenario,
    pre: float,
    duration_s: float,
    rng: np.random.Generator,
    *,
    planar: bool = False,
) -> tuple[FloatArray, dict[str, Any]]:
    """Ringing bursts at a bearing's load reversals, as seen by every sensor, shape (s, samples).

    ``cycle`` is the engine's cycle angle [rad]. ``planar`` (a V engine, whose run keeps each sensor
    bearing's horizontal load after its vertical one): the load turns in the plane, and the journal
    crosses its clearance where the load's magnitude has its prominent minima, not where its
    vertical alone changes sign.
    """
    fs = install.sample_rate
    count = len(install.sensor_bearings)
    span = round((pre + duration_s) * fs) - round(pre * fs)
    found = []
    for s in range(count):
        force = run.forces[count + s]
        if planar:
            found.append(_load_minima(np.hypot(force, run.forces[2 * count + s])))
        else:
            found.append(_reversals(force, 0.03 * float(np.abs(force).max())))
    pool = [s for s in range(count) if found[s][1] in ("sign", "plane")] or list(range(count))
    worn = pool[min(int(scenario.bearing_choice * len(pool)), len(pool) - 1)]
    where, how = found[worn]
    when = _cubic(run.time, where) - pre
    when = np.sort(when[(when >= 0) & (when < duration_s - 0.01)])
    position = when * fs
    i0 = np.floor(position).astype(np.int64)
    frac = position - i0
    sizes = np.clip(1 + 0.3 * rng.standard_normal(when.size), 0.3, None) * rng.choice([-1.0, 1.0], when.size)
    pulses = np.zeros(span)
    np.add.at(pulses, i0, sizes * (1 - frac))
    np.add.at(pulses, np.minimum(i0 + 1, span - 1), sizes * frac)
    w0 = 2 * math.pi * scenario.burst_frequency / fs
    r = math.exp(-scenario.burst_frequency / (scenario.burst_cycles * fs))
    ring = signal.lfilter([0.0, r * math.sin(w0)], [1.0, -2 * r * math.cos(w0), r * r], pulses)
    bursts = np.empty((count, span))
    for s in range(count):  # burst over noise falls by the attenuation per bearing of distance
        distance = abs(install.sensor_bearings[s] - install.sensor_bearings[worn])
        bursts[s] = scenario.burst_size * scenario.neighbour**distance * float(install.noise[s]) * ring
    first = float(np.searchsorted(run.time, pre))  # the recording's first grid point
    one = where[(where >= first) & (where < first + cycle / run.step)]  # one cycle's reversals
    angles = np.sort(np.mod(np.degrees(one * run.step), math.degrees(cycle)))
    truth = {
        "bearing": install.sensor_bearings[worn],
        "channel": install.channel_name(worn),
        "strength": scenario.burst_size,
        "burst_frequency_hz": scenario.burst_frequency,
        "burst_decay_cycles": scenario.burst_cycles,
        "burst_count": int(when.size),
        "burst_amplitude_m_s2": scenario.burst_size * float(install.noise[worn]),
        "neighbour_attenuation": scenario.neighbour,
        "reversal": how,
        "reversal_angles_deg": [round(float(a), 2) for a in angles],
    }
    return bursts, truth


def bearing_channel(
    x: FloatArray, s: int, install: Installation, scenario: Scenario, rng: np.random.Generator
) -> tuple[Channel, dict[str, Any]]:
    """One accelerometer channel, with its sensor fault if it has one (16-bit over its range)."""
    fs = install.sample_rate
    full = float(install.adc_range[s])
    unit_scale = 1.0
    truth: dict[str, Any] = {}
    if scenario.sensor == s:
        kind = scenario.sensor_fault
        truth = {
            "channel": install.channel_name(s),
            "bearing": install.sensor_bearings[s],
            "sensor_fault": kind,
        }
        if kind == "clipped":
            peak = float(np.abs(x).max())
            level = scenario.clip_fraction * peak
            for _ in range(8):  # lower the range until the product's own rule sees clipped runs
                cut = np.clip(x, -level, level).astype(np.float32)
                spans, _ = quality_spans(cut, fs, limits=(-level, level))
                if len(spans) >= 3:
                    break
                level *= 0.8
            full = level
            x = np.clip(x, -level, level)
            truth["strength"] = level / peak
        elif kind == "dead_flat":
            x = np.full(x.size, float(rng.normal(0.0, install.noise[s])))
            truth["strength"] = 0.0
        elif kind == "dead_noise":
            x = rng.normal(0.0, float(install.noise[s]) * float(rng.uniform(0.5, 2.0)), x.size)
            truth["strength"] = 0.0
        elif kind == "unit_x1000":
            unit_scale = 1000.0
            truth["strength"] = 1000.0
        else:
            unit_scale = 1 / 9.81
            truth["strength"] = 1 / 9.81
    data = (_quantise(x, full) * unit_scale).astype(np.float32)
    lsb = 2 * full / 2**16  # the range is the converter's codes: -32768 to +32767 LSB
    low, high = -full * unit_scale, (full - lsb) * unit_scale
    channel = Channel(
        name=install.channel_name(s),
        kind="acceleration",
        unit="m/s^2",
        data=data,
        sample_rate=fs,
        location=f"main bearing {install.sensor_bearings[s]}",
        direction="vertical",
        range=(low, high),
    )
    return channel, truth


def angle_channels(
    engine: SimEngine,
    install: Installation,
    run: CrankRun,
    pre: float,
    duration_s: float,
    rng: np.random.Generator,
) -> list[Channel]:
    """The 60-2 tooth wheel, the cam (four-strokes) and the keyphasor (if fitted), as event times."""
    present = np.arange(58)
    tooth_angles = install.first_tooth_angle + 2 * math.pi * present / 60 + install.tooth_errors[present]
    teeth = _events(run, pre, duration_s, tooth_angles, 2 * math.pi, install.tooth_jitter, rng)
    channels = [
        Channel(
            name="crank-teeth",
            kind="tooth",
            unit="s",
            data=teeth,
            sample_rate=None,
            location="flywheel",
            fields={
                "teeth": 60,
                "missing_teeth": 2,
                "first_tooth_angle_deg": round(math.degrees(install.first_tooth_angle), 6),
            },
        )
    ]
    if install.cam_angle is not None:
        cam = _events(
            run, pre, duration_s, np.array([install.cam_angle]), engine.cycle_angle, install.cam_jitter, rng
        )
        channels.append(
            Channel(
                name="cam",
                kind="cam",
                unit="s",
                data=cam,
                sample_rate=None,
                location="camshaft",
                fields={"cam_angle_deg": round(math.degrees(install.cam_angle), 6)},
            )
        )
    if install.keyphasor_angle is not None:
        pulses = _events(
            run, pre, duration_s, np.array([install.keyphasor_angle]), 2 * math.pi, install.tooth_jitter, rng
        )
        channels.append(
            Channel(
                name="keyphasor",
                kind="keyphasor",
                unit="s",
                data=pulses,
                sample_rate=None,
                location="flywheel",
                fields={"pulse_angle_deg": round(math.degrees(install.keyphasor_angle), 6)},
            )
        )
    return channels
