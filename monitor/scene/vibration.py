"""What the vibration sensors measure: bearing accelerations, axial vibration, a worn bearing's knocks.

Accelerometers on main bearing ``b`` (location "main bearing b", direction vertical: the force's
y component, horizontal: x) measure the bearing force through the modes of ``bearing_vibration``;
an axial sensor, its journal's axial response to the cylinders' torques.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from monitor.errors import SceneError
from monitor.model.engine import Engine
from monitor.model.predicted import load_reversals
from monitor.scene.crank import Crank
from monitor.scene.effects import BearingVibrationParams, WornBearingParams, named
from monitor.scene.model import Scene, Sensor
from monitor.scene.sources import Sources
from monitor.scene.synthesis import CycleTable
from monitor.torsion.axial_coupling import AxialTorsionalCrankshaft
from monitor.types import ComplexArray, FloatArray


def _bearing_response(
    sensor: Sensor, engine: Engine, sources: Sources, params: BearingVibrationParams
) -> tuple[ComplexArray, ComplexArray, FloatArray]:
    b = sensor.bearing
    if b is None or not 1 <= b <= engine.bearing_count or sensor.direction not in ("vertical", "horizontal"):
        raise SceneError(
            f"sensor {sensor.name!r}: bearing_vibration needs location = 'main bearing N' (N = 1.."
            f"{engine.bearing_count}) and direction = 'vertical' or 'horizontal'"
        )
    assert sources.bearing is not None
    component = 1 if sensor.direction == "vertical" else 0
    return sources.bearing.a[b - 1, component], sources.bearing.b[b - 1, component], sources.orders


def _transfer(params: BearingVibrationParams, frequency: FloatArray, sensor: str = "") -> ComplexArray:
    w = 2 * np.pi * np.asarray(frequency)
    total = np.zeros(w.shape, dtype=np.complex128)
    for mode in params.sensors.get(sensor, params.modes):
        wn = 2 * np.pi * mode.frequency_hz
        total += mode.gain * w**2 / (wn**2 - w**2 + 2j * mode.damping * wn * w)
    return total


def _axial_orders(sensor: Sensor, engine: Engine, sources: Sources, speeds: FloatArray) -> ComplexArray:
    """Axial acceleration [m/s^2] (velocity [mm/s]) orders of the sensor's journal at each mean speed."""

    if engine.shaft_line is None or engine.shaft_line.axial is None:
        raise SceneError(f"axial_vibration needs the [shaft_line.axial] data of engine {engine.id!r}")
    journal = 1 if sensor.location.lower() == "free end" else sensor.bearing
    if journal is None or not 1 <= journal <= engine.cylinders + 1:
        raise SceneError(
            f"sensor {sensor.name!r}: an axial sensor is at 'free end' or 'main bearing N' "
            f"(N = 1..{engine.cylinders + 1})"
        )
    assert sources.cylinder_torque is not None
    shaft = AxialTorsionalCrankshaft.of_engine(engine)
    k = sources.orders
    out = np.zeros((speeds.size, k.size), dtype=np.complex128)
    for i, w in enumerate(speeds):
        torque = sources.cylinder_torque.at(float(w))  # (n_cylinders, n_orders)
        for j in np.flatnonzero(k > 0):
            nodal = np.zeros(shaft.n_nodes, dtype=np.complex128)
            nodal[1 : 2 * engine.cylinders : 2] = torque[:, j]
            displacement = shaft.harmonic_response(float(k[j] * w), torque=nodal).axial[2 * (journal - 1)]
            frequency = k[j] * w
            out[i, j] = -(frequency**2) * displacement
            if sensor.kind == "velocity":
                out[i, j] = 1e3 * out[i, j] / (1j * frequency)
    return out


def _knocks(
    params: WornBearingParams,
    sensor: Sensor,
    engine: Engine,
    sources: Sources,
    crank: Crank,
    t: FloatArray,
    expected: dict[str, Any],
) -> FloatArray:
    """Decaying rings where the worn bearing's load is least (local minima of its magnitude)."""
    b = sensor.bearing
    if b is None or abs(b - params.bearing) > 1 or sensor.direction not in ("vertical", "horizontal"):
        return np.zeros(t.size)
    if not 1 <= params.bearing <= engine.bearing_count:
        raise SceneError(
            f"effect 'worn_bearing': bearing {params.bearing} does not exist "
            f"(the engine has {engine.bearing_count})"
        )
    assert sources.bearing is not None
    R = engine.cycle_revolutions
    w = float(np.mean(crank.speed(t)))
    force = (
        sources.bearing.a[params.bearing - 1] + w**2 * sources.bearing.b[params.bearing - 1]
    )  # (2, orders)
    cycle = 2 * math.pi * R
    # the journal crosses its clearance where the load is least (what the diagnosis looks at)
    reversals = load_reversals(force, sources.orders, R)
    expected[f"{sensor.name} knocks"] = {
        "bearing": params.bearing,
        "knock_angles_deg": np.degrees(reversals).tolist(),
    }
    scale = params.severity * (1.0 if b == params.bearing else 1.0 / 3.0)
    last = crank.angle_at(t[-1:])[0]
    starts = (reversals[None, :] + cycle * np.arange(math.ceil(last / cycle) + 1)[:, None]).ravel()
    times = crank.time_at(starts[starts <= last])
    out = np.zeros(t.size)
    fs = 1.0 / (t[1] - t[0])
    span = int(5e-3 * params.decay_ms * fs) + 1  # five decay times
    omega = 2 * np.pi * params.ring_hz
    for start in times:
        i0 = math.ceil(start * fs)
        local = t[i0 : i0 + span] - start
        envelope = scale * np.exp(-local / (1e-3 * params.decay_ms))
        if sensor.kind == "velocity":  # the ring's velocity [mm/s] (the decay is slow against the ring)
            out[i0 : i0 + span] -= 1e3 * envelope * np.cos(omega * local) / omega
        else:
            out[i0 : i0 + span] += envelope * np.sin(omega * local)
    return out


def _speed_nodes(speed: FloatArray, count: int) -> FloatArray:
    """Mean speeds at which a response is tabulated: the one speed, or ``count`` over the range."""
    lo_w, hi_w = float(speed.min()), float(speed.max())
    return np.array([lo_w]) if hi_w - lo_w <= 1e-9 * hi_w else np.linspace(lo_w, hi_w, count)


def _truth(orders: FloatArray, at_mean: ComplexArray, unit: str, w_mean: float) -> dict[str, Any]:
    """The expected orders of a channel at the recording's mean speed."""
    return {
        "orders": orders.tolist(),
        "amplitude": np.abs(at_mean).tolist(),
        "phase_deg": np.degrees(np.angle(at_mean)).tolist(),
        "unit": unit,
        "speed_rpm": w_mean * 30 / math.pi,
    }


def axial_waveform(
    sensor: Sensor,
    scene: Scene,
    engine: Engine,
    crank: Crank,
    sources: Sources | None,
    t: FloatArray,
    angle: FloatArray,
    expected: dict[str, Any],
) -> FloatArray:
    """Axial acceleration [m/s^2] or velocity [mm/s] of a journal at times ``t`` (zero unless named)."""
    values = np.zeros(t.size)
    if named(scene, "axial_vibration") is not None and (sources is None or sources.cylinder_torque is None):
        raise SceneError(
            "axial_vibration is driven by the cylinders' torques (the model ends at the thrust bearing, "
            "an external torque does not reach it): add inertia or gas to [effects]"
        )
    if (
        named(scene, "axial_vibration") is not None
        and sources is not None
        and sources.cylinder_torque is not None
    ):
        speed = crank.speed(t)
        nodes = _speed_nodes(speed, 33)
        coefficients = _axial_orders(sensor, engine, sources, nodes)
        values = CycleTable.of(coefficients, sources.orders, engine.cycle_revolutions, nodes).at(angle, speed)
        w_mean = float(np.mean(speed))
        at_mean = _axial_orders(sensor, engine, sources, np.array([w_mean]))[0]
        expected[sensor.name] = _truth(sources.orders, at_mean, sensor.unit, w_mean)
    return values


def bearing_waveform(
    sensor: Sensor,
    scene: Scene,
    engine: Engine,
    crank: Crank,
    sources: Sources | None,
    t: FloatArray,
    angle: FloatArray,
    expected: dict[str, Any],
) -> FloatArray:
    """Acceleration [m/s^2] or velocity [mm/s] at a main bearing at times ``t``, with any knocks."""
    values = np.zeros(t.size)
    params = named(scene, "bearing_vibration")
    if isinstance(params, BearingVibrationParams) and sources is not None and sources.bearing is not None:
        a, b, orders = _bearing_response(sensor, engine, sources, params)
        speed = crank.speed(t)

        def measured(w: FloatArray) -> ComplexArray:
            """Per unit of bearing force, at the orders' frequencies for mean speed(s) w."""
            frequency = np.multiply.outer(w, orders)  # [rad/s]
            transfer = _transfer(params, frequency / (2 * np.pi), sensor.name)
            if sensor.kind == "velocity":  # the acceleration integrated, order by order, in mm/s
                transfer = np.where(
                    frequency > 0, 1e3 * transfer / (1j * np.where(frequency > 0, frequency, 1)), 0
                )
            return np.asarray(transfer)

        nodes = _speed_nodes(speed, 65)
        table = CycleTable.of(
            (a[None, :] + np.multiply.outer(nodes**2, b)) * measured(nodes),
            orders,
            engine.cycle_revolutions,
            nodes,
        )
        values = table.at(angle, speed)
        w_mean = float(np.mean(speed))
        at_mean = (a + w_mean**2 * b) * measured(np.array(w_mean))
        expected[sensor.name] = _truth(orders, at_mean, sensor.unit, w_mean)
    worn = named(scene, "worn_bearing")
    if isinstance(worn, WornBearingParams) and sources is not None and sources.bearing is not None:
        values = values + _knocks(worn, sensor, engine, sources, crank, t, expected)
    return values
