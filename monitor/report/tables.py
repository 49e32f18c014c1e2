"""Edge formatting of model results: JSON documents and text tables.

Units appear here, at the edge, in field names (``amplitude_kn``,
``phase_deg``, ``speed_rpm``); the JSON fields are documented in
``docs/orders-json.md``.  Phases are in degrees relative to TDC of cylinder
1 under the convention ``q = q0 + sum |Q_k| cos(k alpha + phase_k)``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from monitor import __version__
from monitor.model.engine import Engine
from monitor.model.predicted import ModelOrders
from monitor.types import ComplexArray

__all__ = ["ORDERS_FORMAT", "model_orders_document", "model_orders_table"]

ORDERS_FORMAT = "engine-monitor/model-orders"
ORDERS_FORMAT_VERSION = 1


def _series(values: ComplexArray, scale: float) -> dict[str, list[float]]:
    return {
        "amplitude": [round(float(v), 9) for v in np.abs(values) / scale],
        "phase_deg": [round(float(v), 6) for v in np.degrees(np.angle(values))],
    }


def _xy(values: ComplexArray, scale: float) -> dict[str, Any]:
    return {"horizontal": _series(values[0], scale), "vertical": _series(values[1], scale)}


def model_orders_document(result: ModelOrders, engine: Engine) -> dict[str, Any]:
    """The JSON document of a predicted order table (see docs/orders-json.md).

    Parameters
    ----------
    result : ModelOrders
        The predicted orders.
    engine : Engine
        The engine they belong to.

    Returns
    -------
    dict
        JSON-serialisable; amplitudes in kN and kN m, phases in degrees.
    """
    kn, knm = 1e3, 1e3
    mean_torque = float(result.engine_torque[0].real)
    return {
        "format": ORDERS_FORMAT,
        "format_version": ORDERS_FORMAT_VERSION,
        "product_version": __version__,
        "engine": {
            "id": engine.id,
            "name": engine.name,
            "cycle": engine.cycle,
            "cylinders": engine.cylinders,
            "main_bearings": engine.bearing_count,
            "firing_order": engine.firing.order,
            "firing_angles_deg": [round(float(a), 9) for a in np.degrees(engine.firing_angles)],
            "cylinder_names": engine.cylinder_names,
            "vee": engine.vee.model_dump() if engine.vee is not None else None,
        },
        "operating_point": {
            "speed_rpm": result.speed_rpm,
            "load": result.load,
            "mean_torque_knm": mean_torque / knm,
            "indicated_power_kw": mean_torque * result.crank_speed / 1e3,
        },
        "model": {
            "kinematics": result.kinematics,
            "rod_model": result.rod_model,
            "gas": result.gas,
            "grid_samples_per_cycle": result.grid_size,
            "max_order": float(result.orders[-1]),
            "aliasing_error": result.aliasing_error,
            "truncation_error": result.truncation_error,
        },
        "convention": (
            "q = q0 + sum_k amplitude_k cos(k alpha + phase_k); alpha crank angle from TDC of "
            "cylinder 1 in the direction of rotation; amplitudes are peak values"
        ),
        "orders": [float(k) for k in result.orders],
        "engine_torque_knm": _series(result.engine_torque, knm),
        "cylinders": [
            {
                "cylinder": c + 1,
                "name": engine.cylinder_names[c],
                "firing_angle_deg": round(math.degrees(float(engine.firing_angles[c])), 9),
                "inertia_force_kn": _xy(result.cylinder_inertia_force[c], kn),
                "torque_knm": _series(result.cylinder_torque[c], knm),
                "gas_torque_knm": _series(result.cylinder_gas_torque[c], knm),
            }
            for c in range(engine.cylinders)
        ],
        "main_bearings": [
            {"bearing": b + 1, "force_kn": _xy(result.bearing_force[b], kn)}
            for b in range(engine.bearing_count)
        ],
        "free_force_kn": _xy(result.free_force, kn),
        "free_moment_knm": {
            "vertical": _series(result.free_moment[0], knm),
            "horizontal": _series(result.free_moment[1], knm),
        },
    }


#: Amplitudes below this fraction of a quantity's largest order are round-off: shown as 0, no phase.
_NEGLIGIBLE = 1e-9


def _phase(value: complex, scale: float, width: int) -> str:
    if abs(value) <= _NEGLIGIBLE * scale:
        return f"{'-':>{width}}"
    return f"{math.degrees(np.angle(value)):{width}.0f}"


def _amp(value: complex, scale: float, unit: float, width: int = 9) -> str:
    return _fmt(0.0 if abs(value) <= _NEGLIGIBLE * scale else abs(value) / unit, width)


def _fmt(value: float, width: int = 9) -> str:
    if value == 0 or abs(value) >= 0.01:
        return f"{value:{width}.3f}"
    return f"{value:{width}.2e}"


def model_orders_table(result: ModelOrders, engine: Engine) -> str:
    """A plain-text report of a predicted order table.

    Parameters
    ----------
    result : ModelOrders
    engine : Engine

    Returns
    -------
    str
        Amplitudes in kN and kN m (peak), phases in degrees.
    """
    orders = result.orders
    lines: list[str] = []
    imep = engine.combustion.rated_imep_bar if engine.combustion else None
    lines.append(f"Engine {engine.id}: {engine.name}")
    load_text = f"load {result.load:.2f} of rated IMEP" + (f" ({imep:g} bar)" if imep else "")
    lines.append(f"Operating point: {result.speed_rpm:.1f} rpm ({result.crank_speed:.4f} rad/s), {load_text}")
    lines.append(
        f"Model: {result.kinematics} kinematics, {result.rod_model} connecting rod, {result.gas} gas "
        f"pressure; {result.grid_size} samples per cycle; largest grid error of a torque order "
        f"{result.aliasing_error['torque']:.2g} N m"
    )
    lines.append(
        "Amplitudes are peak; phases [deg] relative to TDC of cylinder 1: "
        "q = q0 + sum |Q_k| cos(k alpha + phase_k)."
    )
    mean = result.engine_torque[0].real
    lines.append("")
    lines.append(
        f"Engine torque [kN m]: mean {mean / 1e3:.3f}, "
        f"indicated power {mean * result.crank_speed / 1e3:.1f} kW"
    )
    lines.append(f"{'order':>6} {'amplitude':>10} {'phase':>8}")
    scale = float(np.abs(result.engine_torque[1:]).max(initial=0.0))
    for i in range(1, orders.size):
        q = result.engine_torque[i]
        lines.append(f"{orders[i]:6.1f} {_amp(q, scale, 1e3, 10)} {_phase(q, scale, 8)}")

    lines.append("")
    frame = " in the engine's frame, the banks leaning alike" if engine.vee is not None else ""
    lines.append(
        f"Inertia force of each cylinder's moving parts [kN] (same amplitude in every cylinder{frame});"
    )
    lines.append("phase of the vertical component per cylinder [deg] (k x firing angle behind cylinder 1):")
    labels = [name if engine.vee is not None else f"c{name}" for name in engine.cylinder_names]
    head = f"{'order':>6} {'vertical':>9} {'horiz.':>9} " + " ".join(f"{label:>6}" for label in labels)
    lines.append(head)
    scale = float(np.abs(result.cylinder_inertia_force[0, :, 1:]).max(initial=0.0))
    for i in range(1, orders.size):
        f = result.cylinder_inertia_force[:, :, i]
        phases = " ".join(_phase(f[c, 1], scale, 6) for c in range(engine.cylinders))
        lines.append(f"{orders[i]:6.1f} {_amp(f[0, 1], scale, 1e3)} {_amp(f[0, 0], scale, 1e3)} {phases}")

    for axis, label in ((1, "vertical"), (0, "horizontal")):
        lines.append("")
        lines.append(f"Main-bearing force, {label} [kN amplitude]:")
        lines.append(
            f"{'order':>6} " + " ".join(f"{'MB' + str(b + 1):>9}" for b in range(engine.bearing_count))
        )
        scale = float(np.abs(result.bearing_force[:, axis, 1:]).max(initial=0.0))
        for i in range(1, orders.size):
            row = " ".join(
                _amp(result.bearing_force[b, axis, i], scale, 1e3) for b in range(engine.bearing_count)
            )
            lines.append(f"{orders[i]:6.1f} {row}")

    lines.append("")
    lines.append("Free forces [kN] and moments [kN m] (amplitudes):")
    lines.append(f"{'order':>6} {'F vert.':>9} {'F horiz.':>9} {'M vert.':>9} {'M horiz.':>9}")
    for i in range(1, orders.size):
        if orders[i] > 4:
            break
        cells = [
            result.free_force[1, i],
            result.free_force[0, i],
            result.free_moment[0, i],
            result.free_moment[1, i],
        ]
        scales = [float(np.abs(result.cylinder_inertia_force[0]).max())] * 2 + [
            float(
                np.abs(result.cylinder_inertia_force[0]).max()
                * max(1.0, float(np.ptp(engine.cylinder_positions)))
            )
        ] * 2
        lines.append(
            f"{orders[i]:6.1f} " + " ".join(_amp(v, sc, 1e3) for v, sc in zip(cells, scales, strict=True))
        )
    return "\n".join(lines)
