"""The angle sensors' signals: tooth wheels, encoders, keyphasors and cams.

A tooth wheel gives flat-bottomed pulses whose mid-level rising edge is at each tooth's angle (or
the edge times), or as its ``signal`` says a Hall sensor's square pulses (timed alike) or a
variable-reluctance sensor's voltage (the rate of change of a flux of one Gaussian bump per tooth,
falling through zero at each tooth's centre, proportional to speed); an encoder, square pulses
rising through their mid level at each pulse's angle; a keyphasor, a pulse rising through its mid
level at its angle once per revolution; a cam, once per cycle.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.interpolate import CubicSpline
from scipy.optimize import brentq

from monitor.errors import SceneError
from monitor.scene.crank import Crank
from monitor.scene.effects import KeyphasorFaultsParams, ToothSpacingParams, named
from monitor.scene.model import Scene, Sensor
from monitor.types import FloatArray

_VR_WIDTH = 0.4  # standard deviation of one tooth's flux bump [pitch]: neighbouring teeth overlap
_EDGE_MAX = 0.125  # largest half-width of a square pulse's edge [pitch]
_BLOCK = 1 << 20  # samples shaped at a time (bounded memory on a long recording)


def pulses(position: FloatArray, present: npt.NDArray[np.bool_] | None = None) -> FloatArray:
    """Flat-bottomed pulses, 0.2 to 3.2 V: the mid level (1.7 V) is crossed rising at whole positions."""
    fraction = np.mod(position + 1.0 / 6.0, 1.0)
    pulse = np.clip(np.sin(np.pi * fraction) * 1.6 - 0.3, 0.0, 1.0)
    if present is not None:
        pulse = np.where(present, pulse, 0.0)
    return 0.2 + 3.0 * pulse


def square(v: FloatArray, present: Callable[[FloatArray], npt.NDArray[np.bool_]] | None = None) -> FloatArray:
    """Square pulses, 0 to 1, of a wheel coordinate ``v`` sampled evenly in time [pitch].

    Pulse ``k`` rises through 0.5 at ``v = k`` and falls through it at ``k + 0.5``; each edge is a
    straight ramp over two sample intervals (the acquisition's bandwidth; at most a quarter pitch), so
    the mid level interpolated between the two samples around it is at the edge exactly (with eight
    samples a pitch or more). ``present(k)`` says which pulses exist (a tooth wheel's gap).
    """
    out = np.empty(v.size)
    for a in range(0, v.size, _BLOCK):
        lo, hi = max(a - 1, 0), min(a + _BLOCK + 1, v.size)
        part = v[lo:hi]
        half = np.minimum(np.abs(np.gradient(part)), _EDGE_MAX)[a - lo : a - lo + _BLOCK]  # a sample [pitch]
        w = v[a : a + _BLOCK]
        k = np.floor(w + 0.25)
        w = w - k  # from -0.25 (the middle of the low level) to 0.75
        level = np.clip(np.minimum(0.5 + w / (2 * half), 0.5 - (w - 0.5) / (2 * half)), 0.0, 1.0)
        out[a : a + _BLOCK] = level if present is None else np.where(present(k), level, 0.0)
    return out


def _vr_flux_slope(v: FloatArray, teeth: int, missing: int) -> FloatArray:
    """d(flux)/dv of a wheel whose teeth each add a Gaussian flux bump ``_VR_WIDTH`` pitch wide [/pitch]."""
    nearest = np.floor(v)
    slope = np.zeros(v.shape)
    for step in range(-3, 4):  # bumps within three pitches: beyond, exp(-28) of their peak
        k = nearest + step
        x = v - k
        bump = -x / _VR_WIDTH**2 * np.exp(-(x**2) / (2 * _VR_WIDTH**2))
        slope += np.where(np.mod(k, teeth) < teeth - missing, bump, 0.0)
    return slope


@functools.cache
def _vr_lobe_peak() -> float:
    """Peak of |d(flux)/dv| away from the gap (a wheel of teeth all present) [per pitch]."""
    v = np.linspace(0.0, 1.0, 20001)
    return float(np.max(np.abs(_vr_flux_slope(v + 30.0, 10**6, 1))))


def _wheel_coordinate(u: FloatArray, errors: FloatArray, teeth: int, name: str) -> FloatArray:
    """The wheel's own coordinate ``v`` at positions ``u`` [pitch], the teeth at their errors.

    A tooth-spacing error moves the wheel's profile around its tooth: ``u = v + e(v)``, ``e`` the
    periodic cubic spline through each tooth position's error [pitch], so tooth ``k`` (``v = k``) sits
    at ``k + e_k`` and what lies between teeth is stretched smoothly. Inverted by Newton's method.
    """
    if not np.any(errors):
        return u

    spline = CubicSpline(np.arange(teeth + 1), np.append(errors, errors[0]), bc_type="periodic")
    slope = spline.derivative()
    if np.min(slope(np.linspace(0.0, teeth, 64 * teeth + 1))) <= -0.5:
        raise SceneError(
            f"tooth_spacing_errors on sensor {name!r}: the errors bring neighbouring teeth within half a "
            f"pitch ({180.0 / teeth:.3g} deg) of each other somewhere on the wheel; lower rms_deg"
        )
    v = u - spline(np.mod(u, teeth))
    for _ in range(3):  # quadratic convergence from an error of (error x its slope): round-off after 3
        m = np.mod(v, teeth)
        v = v - (v + spline(m) - u) / (1.0 + slope(m))
    return np.asarray(v)


def shaped_tooth_wheel(
    sensor: Sensor, angle: FloatArray, errors: FloatArray, expected: dict[str, Any]
) -> FloatArray:
    """A Hall or VR tooth wheel's waveform [V] at crank angles ``angle`` sampled evenly in time.

    Hall: square pulses, 0.2 to 5 V, half a pitch high, each rising through its mid level at its
    tooth's angle. VR: ``d(flux)/dt``, the flux one Gaussian bump per tooth present, so the voltage
    falls through zero at each tooth's centre and grows with speed (``vr_peak_v_at_1000_rpm`` the peak
    of a lobe away from the gap at 1000 rpm); the gap is a dip in the flux, and its lobes are larger.
    A tooth-spacing error moves its tooth's timing point by the error (:func:`_wheel_coordinate`).
    The truth gets each present tooth's timing point against its angle plus its error: zero for a Hall
    sensor; for a VR sensor the gap's field moves its two neighbours' zero crossings (real wheels do).
    """
    teeth, missing = sensor.teeth, sensor.missing_teeth
    pitch = 2 * math.pi / teeth
    u = (angle - math.radians(sensor.first_tooth_angle_deg)) / pitch
    v = _wheel_coordinate(u, errors / pitch, teeth, sensor.name)
    offsets = np.zeros(teeth - missing)
    if sensor.signal == "hall":
        values = 0.2 + 4.8 * square(v, lambda k: np.mod(k, teeth) < teeth - missing)
    else:
        # [V] per (pitch per second) of wheel speed per unit slope: an ordinary lobe peaks at the stated
        # voltage at 1000 rpm
        scale = sensor.vr_peak_v_at_1000_rpm / (1000.0 / 60.0 * teeth) / _vr_lobe_peak()
        scale *= -1.0 if sensor.polarity == "reversed" else 1.0
        rate = sensor.sample_rate_hz
        values = np.empty(v.size)
        for a in range(0, v.size, _BLOCK):
            lo, hi = max(a - 1, 0), min(a + _BLOCK + 1, v.size)
            speed = (np.gradient(v[lo:hi]) * rate)[a - lo : a - lo + _BLOCK]  # [pitch/s]
            values[a : a + _BLOCK] = scale * speed * _vr_flux_slope(v[a : a + _BLOCK], teeth, missing)
        offsets = _vr_timing_offsets(teeth, missing, errors / pitch)
    expected[f"{sensor.name} timing"] = {
        "signal": sensor.signal,
        "polarity": sensor.polarity,
        "timing_offset_deg": (np.degrees(offsets * pitch)).tolist(),
    }
    return values


def _vr_timing_offsets(teeth: int, missing: int, errors: FloatArray) -> FloatArray:
    """Where each present tooth's VR zero crossing is, against the tooth's position plus its error [pitch].

    The downward zero crossing of ``d(flux)/dt`` nearest the tooth (``d(flux)/dv = 0`` in the wheel's
    coordinate, then carried to the position by the errors' spline): zero away from the gap, where the
    neighbouring bumps are symmetric about the tooth.
    """

    cubic = None
    if np.any(errors):
        cubic = CubicSpline(np.arange(teeth + 1), np.append(errors, errors[0]), bc_type="periodic")

    def moved(x: float) -> float:  # the errors' spline at wheel coordinate x [pitch]
        return 0.0 if cubic is None else float(cubic(x % teeth))

    offsets = np.zeros(teeth - missing)
    grid = np.linspace(-0.45, 0.45, 181)
    for k in range(teeth - missing):
        centre = k + teeth  # positive coordinates: the missing teeth just before it are k - 1, ...
        slope = _vr_flux_slope(centre + grid, teeth, missing)
        down = np.flatnonzero((slope[:-1] > 0) & (slope[1:] <= 0))
        if down.size == 0:
            raise SceneError(f"VR wheel {teeth}-{missing}: tooth {k} has no zero crossing at its centre")
        i = int(down[np.argmin(np.abs(grid[down]))])
        root = brentq(
            lambda x: float(_vr_flux_slope(np.array([x]), teeth, missing)[0]),
            centre + grid[i],
            centre + grid[i + 1],
            xtol=1e-12,
        )
        offsets[k] = root - centre + moved(root) - moved(float(centre))
    return offsets


def tooth_errors(scene: Scene, sensor: Sensor, seed: int, index: int, expected: dict[str, Any]) -> FloatArray:
    """Each tooth's angle error [rad] (zeros unless the scene names tooth_spacing_errors for it)."""
    params = named(scene, "tooth_spacing_errors")
    if not isinstance(params, ToothSpacingParams) or params.sensor != sensor.name:
        return np.zeros(sensor.teeth)
    errors = np.random.default_rng([seed, index, 1]).standard_normal(sensor.teeth)
    errors = math.radians(params.rms_deg) * (errors - errors.mean()) / errors.std()
    expected[f"{sensor.name} tooth errors"] = {"error_deg": np.degrees(errors).tolist()}
    return errors


def keyphasor_faults(
    scene: Scene, sensor: Sensor, angles: FloatArray, seed: int, index: int, expected: dict[str, Any]
) -> tuple[npt.NDArray[np.int64], FloatArray]:
    """Indices of dropped pulses among ``angles`` and the angles of spurious ones [rad] (seeded)."""
    params = named(scene, "keyphasor_faults")
    if not isinstance(params, KeyphasorFaultsParams) or params.sensor != sensor.name:
        return np.zeros(0, dtype=np.int64), np.zeros(0)
    rng = np.random.default_rng([seed, index, 2])
    inner = np.arange(3, max(3, angles.size - 3))  # not at the ends of the record
    if params.dropouts + params.extras > inner.size // 3:
        raise SceneError(
            f"effect 'keyphasor_faults': {params.dropouts} dropouts and {params.extras} extras in "
            f"{angles.size} revolutions: at most one fault in three revolutions"
        )
    chosen = rng.choice(inner[::3], size=params.dropouts + params.extras, replace=False)
    dropped = np.sort(chosen[: params.dropouts])
    extra = angles[np.sort(chosen[params.dropouts :])] + rng.uniform(0.3, 0.7, params.extras) * 2 * math.pi
    expected[f"{sensor.name} faults"] = {
        "dropped_pulse_angles_deg": np.degrees(angles[dropped]).tolist(),
        "extra_pulse_angles_deg": np.degrees(extra).tolist(),
    }
    return dropped, extra


def event_times(
    sensor: Sensor,
    index: int,
    scene: Scene,
    crank: Crank,
    revolutions: int,
    seed: int,
    pitch_deg: float,
    expected: dict[str, Any],
) -> FloatArray:
    """An angle sensor's event times [s]: each tooth's or pulse's rising edge at its angle (seeded faults).

    ``revolutions`` is the engine's cycle in revolutions (a cam pulses once a cycle).
    """
    last = crank.angle_at(np.array([scene.duration_s]))[0]
    if sensor.kind == "tooth":
        step = math.radians(pitch_deg)
        first = math.radians(sensor.first_tooth_angle_deg)
        k = np.arange(math.ceil(-first / step), math.floor((last - first) / step) + 1)
        k = k[np.mod(k, sensor.teeth) < sensor.teeth - sensor.missing_teeth]
        angles = (
            first + k * step + tooth_errors(scene, sensor, seed, index, expected)[np.mod(k, sensor.teeth)]
        )
    elif sensor.kind == "encoder":  # each pulse's rising edge at its angle
        step = math.radians(pitch_deg)
        first = math.radians(sensor.first_pulse_angle_deg)
        angles = first + step * np.arange(math.ceil(-first / step), math.floor((last - first) / step) + 1)
    else:
        period = 2 * math.pi * (revolutions if sensor.kind == "cam" else 1)
        offset = math.radians(sensor.cam_angle_deg if sensor.kind == "cam" else sensor.pulse_angle_deg)
        angles = offset + period * np.arange(
            math.ceil(-offset / period), math.floor((last - offset) / period) + 1
        )
        if sensor.kind == "keyphasor":
            dropped, extra = keyphasor_faults(scene, sensor, angles, seed, index, expected)
            angles = np.sort(np.concatenate([np.delete(angles, dropped), extra]))
    angles = angles[(angles >= 0) & (angles <= last)]
    return crank.time_at(angles)


def pulse_waveform(
    sensor: Sensor,
    index: int,
    scene: Scene,
    angle: FloatArray,
    revolutions: int,
    seed: int,
    pitch_deg: float,
    expected: dict[str, Any],
) -> FloatArray:
    """An angle sensor's waveform [V] at crank angles ``angle`` sampled evenly in time.

    ``revolutions`` is the engine's cycle in revolutions (a cam pulses once a cycle).
    """
    if sensor.kind == "tooth" and sensor.signal != "pulse":
        return shaped_tooth_wheel(sensor, angle, tooth_errors(scene, sensor, seed, index, expected), expected)
    if sensor.kind == "encoder":
        start = math.radians(sensor.first_pulse_angle_deg)
        return 5.0 * square((angle - start) / math.radians(pitch_deg))
    if sensor.kind == "tooth":
        position = (angle - math.radians(sensor.first_tooth_angle_deg)) / math.radians(pitch_deg)
        tooth = np.floor(position + 1.0 / 6.0).astype(np.int64)
        errors = tooth_errors(scene, sensor, seed, index, expected)
        position = position - errors[np.mod(tooth, sensor.teeth)] / math.radians(pitch_deg)
        return pulses(position, np.mod(tooth, sensor.teeth) < sensor.teeth - sensor.missing_teeth)
    # keyphasor or cam: one pulse per period (20 deg of crank angle long), its mid level crossed rising
    # at its angle
    periods = 18 * (revolutions if sensor.kind == "cam" else 1)
    offset = math.radians(sensor.cam_angle_deg if sensor.kind == "cam" else sensor.pulse_angle_deg)
    position = (angle - offset) / math.radians(20.0)
    slot = np.floor(position + 1.0 / 6.0).astype(np.int64)
    present = np.mod(slot, periods) == 0
    if sensor.kind != "keyphasor":
        return pulses(position, present)
    nominal = offset + 2 * math.pi * np.arange(math.ceil(angle[-1] / (2 * math.pi)) + 1)
    dropped, extra = keyphasor_faults(scene, sensor, nominal, seed, index, expected)
    present &= ~np.isin(slot // periods, dropped)
    values = pulses(position, present)
    for angle_x in extra:  # a spurious pulse: the same shape at another angle
        near = np.abs(angle - angle_x) < math.radians(20.0)
        local = (angle[near] - angle_x) / math.radians(20.0)
        values[near] = np.maximum(values[near], pulses(local, np.floor(local + 1.0 / 6.0) == 0))
    return values
