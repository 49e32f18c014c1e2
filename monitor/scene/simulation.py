"""A scene turned into a recording, evaluating only the effects it names.

Order domain, quasi-static.  Every force and torque of the engine is a sum
of orders of the crank (cycle) angle whose coefficients depend on the mean
speed ``Omega`` as ``A + Omega^2 B``: gas forces and weights do not depend
on it, inertia forces grow with its square (the angular acceleration of a
slow trend is left out). Each named source contributes its coefficients,
cylinder by cylinder (the gas part of cylinder ``c`` scaled by its faults),
phase-shifted by the firing angles as in :mod:`monitor.model.crankshaft`.
Channels are synthesised sample by sample as ``Re sum_k C_k(Omega(t))
exp(i k theta(t))`` with the crank angle ``theta(t)`` of the recording.

Crank angle.  The mean speed follows the scene's trend. With
``crank_speed`` (rigid) named, the engine side of the shaft line (free end,
throws with their reciprocating parts at their mean, flywheel) turns as one
rigid body of inertia ``J``: the kinetic energy balance gives
``omega(theta)^2 = Omega^2 + (2 / J) integral (T - T_mean) dtheta``, exact
for the rigid body at a steady mean speed, and the time at each angle is
``integral dtheta / omega`` (Simpson on 512 points per revolution); sample
times are mapped back to angles by interpolation of that table. Without it
the crank turns at the trend's speed. The shaft-line and variable-inertia
models give the tooth wheel's lead over the mean rotation instead.

Sensors.  Accelerometers on main bearing ``b`` (location "main bearing b",
direction vertical: the force's y component, horizontal: x) measure the
bearing force through the modes of ``bearing_vibration``; a tooth wheel
gives flat-bottomed pulses whose mid-level rising edge is at each tooth's
angle (or the edge times), or as its ``signal`` says a Hall sensor's square
pulses (timed alike) or a variable-reluctance sensor's voltage (the rate of
change of a flux of one Gaussian bump per tooth, falling through zero at
each tooth's centre, proportional to speed); an encoder, square pulses
rising through their mid level at each pulse's angle; a keyphasor, a pulse
rising through its mid level at its angle once per revolution; a cam, once
per cycle; a pressure sensor, its cylinder's pressure. Noise is Gaussian,
seeded per sensor.
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from pydantic import BaseModel

from monitor.errors import SceneError
from monitor.io.recording import Channel, Recording
from monitor.model.engine import Engine, bundled_engines, load_engine
from monitor.model.predicted import load_reversals
from monitor.scene.effects import (
    BearingVibrationParams,
    ClippingParams,
    CrankSpeedParams,
    ExternalTorqueParams,
    GainErrorParams,
    GasParams,
    InertiaParams,
    KeyphasorFaultsParams,
    LeakingCylinderParams,
    MisfireParams,
    NoiseParams,
    ToothSpacingParams,
    UnbalanceParams,
    WeakCylinderParams,
    WornBearingParams,
    named,
)
from monitor.scene.model import Scene, Sensor
from monitor.types import ComplexArray, FloatArray

__all__ = ["Simulation", "simulate"]

MAX_ORDER = 36.0  # highest order synthesised [-]
_FINE = 512  # points per revolution of the angle-time table
_SPEED_NODES = 9  # mean speeds at which coefficients are tabulated along a trend


@dataclass(frozen=True)
class Simulation:
    """A simulated recording and what was put into it.

    Attributes
    ----------
    recording : Recording
        With the truth (JSON) in ``recording.truth``.
    truth : dict
        Scene, effects, per-cylinder gas scales, and the expected orders of
        each simulated channel at the mean speed of the recording.
    evaluated : tuple of str
        The effects the simulation evaluated (exactly the ones named).
    """

    recording: Recording
    truth: dict[str, Any]
    evaluated: tuple[str, ...] = field(default=())


def _engine(scene: Scene) -> Engine:
    if scene.engine in bundled_engines():
        return load_engine(bundled_engines()[scene.engine])
    path = Path(scene.engine)
    if not path.is_absolute() and scene.source_dir is not None:
        path = scene.source_dir / path
    if not path.exists():
        raise SceneError(
            f"engine {scene.engine!r} is neither a bundled engine ({', '.join(sorted(bundled_engines()))}) "
            "nor a file"
        )
    return load_engine(path)


# ------------------------------------------------------------------------------------------- speed
def _mean_speed(scene: Scene) -> Callable[[FloatArray], FloatArray]:
    op = scene.operating_point
    w0 = op.speed_rpm * math.pi / 30
    trend = op.trend
    if trend.kind == "ramp":
        assert trend.to_rpm is not None
        w1 = trend.to_rpm * math.pi / 30
        return lambda t: w0 + (w1 - w0) * np.clip(t / scene.duration_s, 0.0, 1.0)
    if trend.kind == "sine":
        return lambda t: w0 * (1 + trend.amplitude * np.sin(2 * np.pi * t / trend.period_s))
    return lambda t: np.full_like(t, w0)


@dataclass(frozen=True)
class _Orders:
    """Coefficients ``A + Omega^2 B`` of one quantity's orders (complex, peak)."""

    orders: FloatArray
    a: ComplexArray  # shape (..., n_orders)
    b: ComplexArray

    def at(self, speed: FloatArray | float) -> ComplexArray:
        w2 = np.asarray(speed, dtype=np.float64) ** 2
        return np.asarray(self.a + np.multiply.outer(w2, self.b) if np.ndim(w2) else self.a + w2 * self.b)


@dataclass
class _Sources:
    """The named sources' orders: engine torque, bearing forces (x, y), cylinder pressures."""

    orders: FloatArray
    torque: _Orders | None = None
    bearing: _Orders | None = None  # shape (n_bearings, 2, n_orders)
    pressure: FloatArray | None = None  # (n_cylinders, grid) absolute [Pa] over each cylinder's cycle
    grid: FloatArray | None = None
    gas_scale: list[float] = field(default_factory=list)
    charge_scale: list[float] = field(default_factory=list)
    cylinder_torque: _Orders | None = None  # shape (n_cylinders, n_orders): each throw's own
    gas_model: str = "none"  # the pressure model used ("parametric" when cylinder faults are named)
    external: ComplexArray | None = None  # the external torque's orders (speed-independent)


def _sources(scene: Scene, engine: Engine, evaluated: list[str]) -> _Sources | None:
    """Order coefficients of every named source (None if none is named: nothing is computed)."""
    inertia = named(scene, "inertia")
    gas = named(scene, "gas")
    unbalance = named(scene, "unbalance")
    external = named(scene, "external_torque")
    n = engine.cylinders
    if isinstance(gas, GasParams) and gas.scale is not None and len(gas.scale) != n:
        raise SceneError(f"effect 'gas': scale has {len(gas.scale)} values; the engine has {n} cylinders")
    if inertia is None and gas is None and unbalance is None:
        if external is None:
            return None
        evaluated.append("external_torque")
        orders = np.arange(round(MAX_ORDER * engine.cycle_revolutions) + 1) / engine.cycle_revolutions
        speed_free = np.zeros(orders.size, dtype=np.complex128)
        outside = _external_torque(external, orders)
        torque = _Orders(orders, outside, speed_free)
        return _Sources(orders, torque=torque, gas_scale=[1.0] * n, charge_scale=[1.0] * n, external=outside)
    from monitor.fourier import order_coefficients
    from monitor.model.crankshaft import EngineModel, GasModel
    from monitor.model.forces import crank_train_forces
    from monitor.model.gas import gas_force

    gas_scale = list(gas.scale) if isinstance(gas, GasParams) and gas.scale is not None else [1.0] * n
    charge_scale = [1.0] * n
    for effect, params in (
        ("misfire", named(scene, "misfire")),
        ("weak_cylinder", named(scene, "weak_cylinder")),
        ("leaking_cylinder", named(scene, "leaking_cylinder")),
    ):
        if params is None:
            continue
        evaluated.append(effect)
        cylinders = (
            params.cylinders if isinstance(params, MisfireParams) else [params.cylinder]  # type: ignore[attr-defined]
        )
        for c in cylinders:
            if not 1 <= c <= n:
                raise SceneError(f"effect {effect!r}: cylinder {c} does not exist (the engine has {n})")
            if isinstance(params, MisfireParams):
                gas_scale[c - 1] = 0.0
            elif isinstance(params, WeakCylinderParams):
                gas_scale[c - 1] *= params.scale
            elif isinstance(params, LeakingCylinderParams):
                charge_scale[c - 1] = params.compression
    faulted = any(s != 1.0 for s in gas_scale + charge_scale)
    rod_model = inertia.rod_model if isinstance(inertia, InertiaParams) else "rigid"
    kinematics = inertia.kinematics if isinstance(inertia, InertiaParams) else "exact"
    gas_model: GasModel = "none"
    if isinstance(gas, GasParams):
        gas_model = gas.model
        if faulted:
            if gas_model == "measured":
                raise SceneError(
                    "cylinder faults scale the parametric cycle's heat release and charge pressure: "
                    "set gas.model = 'parametric' (or 'auto')"
                )
            gas_model = "parametric"
    model = EngineModel(
        engine,
        grid_size=1024,
        rod_model=rod_model,
        kinematics=kinematics,
        gas=gas_model,
    )
    R = engine.cycle_revolutions
    kin, train = model.kinematics, model.train
    load = scene.operating_point.load
    ambient = model._ambient

    def rows(speed: float, force: FloatArray | float, gravity: float) -> FloatArray:
        f = crank_train_forces(
            kin, train, crank_speed=speed, gas_force=force, rod_model=rod_model, gravity=gravity
        )
        return np.stack([f.torque, f.pin_force_x, f.pin_force_y])

    parts: list[tuple[FloatArray, FloatArray]] = []  # per cylinder: (A rows, B rows) over the cycle grid
    zero = np.zeros((3, model.grid_size))
    inertia_a, inertia_b = zero, zero
    if inertia is not None:
        evaluated.append("inertia")
        base = rows(1.0, 0.0, model.gravity)
        twice = rows(2.0, 0.0, model.gravity)
        inertia_b = (twice - base) / 3.0  # forces a + w^2 b at w = 1 and 2
        inertia_a = base - inertia_b
        unb_x, unb_y = model.unbalance_force(1.0)
        inertia_b = inertia_b + np.stack([np.zeros_like(unb_x), unb_x, unb_y])
    pressure = None
    if gas is not None:
        evaluated.append("gas")
        if model.gas == "parametric":
            assert model._cycle is not None and model._setup.gas_basis is not None
            basis_a, basis_b = model._setup.gas_basis
            charge, heat = model._cycle.charge_pressure(load), model._cycle.heat_release(load)
            pressure = np.stack(
                [charge_scale[c] * charge * basis_a + gas_scale[c] * heat * basis_b for c in range(n)]
            )
        else:
            pressure = np.repeat(model.cylinder_pressure(load)[None, :], n, axis=0)
    for c in range(n):
        a_rows = inertia_a.copy()
        if pressure is not None:
            f_gas = gas_force(pressure[c], engine.piston_area, ambient)
            a_rows += rows(1.0, f_gas, 0.0) - rows(1.0, 0.0, 0.0)  # the gas part alone (linear in it)
        parts.append((a_rows, inertia_b))
    stacked = np.stack([np.stack([a, b]) for a, b in parts])  # (n_cyl, 2, 3, grid)
    oc = order_coefficients(stacked, cycle_revolutions=R, max_order=MAX_ORDER)
    orders = oc.orders
    # each cylinder's own coefficients delayed by its firing angle (model.crankshaft.phase_shift's rule)
    shifts = np.exp(-1j * np.multiply.outer(engine.firing_angles, orders))
    coefficients = oc.coefficients * shifts[:, None, None, :]  # (n_cyl, 2, 3, n_orders)
    torque = _Orders(orders, coefficients[:, 0, 0].sum(axis=0), coefficients[:, 1, 0].sum(axis=0))
    throw_a, throw_b = coefficients[:, 0, 1:3], coefficients[:, 1, 1:3]  # (n_cyl, 2, n_orders)
    if unbalance is not None:
        assert isinstance(unbalance, UnbalanceParams)
        evaluated.append("unbalance")
        c = unbalance.throw
        if not 1 <= c <= n:
            raise SceneError(f"effect 'unbalance': throw {c} does not exist (the engine has {n})")
        # U w^2 (sin, cos) of the throw's angle plus the offset: order 1 of the crank angle
        phase = unbalance.angle_deg * math.pi / 180 - engine.firing_angles[c - 1]
        k1 = int(np.argmin(np.abs(orders - 1.0)))
        throw_b = throw_b.copy()
        throw_b[c - 1, 0, k1] += unbalance.kgm * -1j * np.exp(1j * phase)
        throw_b[c - 1, 1, k1] += unbalance.kgm * np.exp(1j * phase)
    share = engine.bearing_share
    bearing = _Orders(
        orders, np.einsum("bc,cko->bko", share, throw_a), np.einsum("bc,cko->bko", share, throw_b)
    )
    has_cylinders = inertia is not None or gas is not None
    per_cylinder = _Orders(orders, coefficients[:, 0, 0], coefficients[:, 1, 0]) if has_cylinders else None
    external_torque: ComplexArray | None = None
    if external is not None:
        evaluated.append("external_torque")
        external_torque = _external_torque(external, orders)
        torque = _Orders(orders, torque.a + external_torque, torque.b)
    return _Sources(
        orders,
        gas_model=model.gas if gas is not None else "none",
        cylinder_torque=per_cylinder,
        external=external_torque,
        torque=torque if (has_cylinders or external is not None) else None,
        bearing=bearing,
        pressure=pressure,
        grid=model.crank_angle,
        gas_scale=gas_scale,
        charge_scale=charge_scale,
    )


def _external_torque(params: BaseModel, orders: FloatArray) -> ComplexArray:
    """The external torque's coefficients on the grid of orders (speed-independent) [N m]."""
    assert isinstance(params, ExternalTorqueParams)
    out = np.zeros(orders.size, dtype=np.complex128)
    for item in params.orders:
        i = int(np.argmin(np.abs(orders - item.order)))
        if abs(orders[i] - item.order) > 1e-9:
            step = orders[1] - orders[0]
            raise SceneError(
                f"effect 'external_torque': order {item.order:g} is not a multiple of {step:g} "
                f"(the engine's cycle) or above {orders[-1]:g}"
            )
        out[i] += item.amplitude_nm * np.exp(1j * math.radians(item.phase_deg))
    return out


def _shaft_line_lead(
    scene: Scene,
    engine: Engine,
    sources: _Sources,
    angle: FloatArray,
    omega_mean: FloatArray,
    expected: dict[str, Any],
) -> FloatArray:
    """The tooth wheel's angle lead over the mean rotation, from the shaft line's forced response [rad].

    Tabulated on a grid of mean speeds over the trend (241 for a run-up: a resonance is sharp) and
    interpolated linearly in speed; order by order ``Re Theta_k exp(i k theta)`` (first order in it).
    """
    from monitor.torsion.shaft_line import shaft_line_of

    if engine.shaft_line is None:
        raise SceneError(f"crank_speed (shaft_line) needs the [shaft_line] of engine {engine.id!r}")
    line = shaft_line_of(engine)
    wheel = engine.shaft_line.tooth_wheel or line.node_names[0]
    probe = line.index(wheel)
    throws = [line.index(f"cylinder {c}") for c in range(1, engine.cylinders + 1)]
    external = named(scene, "external_torque")
    where = None
    if isinstance(external, ExternalTorqueParams):
        default = (
            engine.shaft_line.driven_end[-1].name if engine.shaft_line.driven_end else line.node_names[-1]
        )
        name = external.element or default
        if name not in line.node_names:
            raise SceneError(
                f"effect 'external_torque': element {name!r} is not on the shaft line; elements: "
                f"{', '.join(line.node_names)}"
            )
        where = line.index(name)
    lo, hi = float(omega_mean.min()), float(omega_mean.max())
    speeds = np.array([lo]) if hi - lo <= 1e-9 * hi else np.linspace(lo, hi, 241)
    k = sources.orders
    table = np.zeros((speeds.size, k.size), dtype=np.complex128)
    for i, w in enumerate(speeds):
        torque = np.zeros((len(line.nodes), k.size), dtype=np.complex128)
        if sources.cylinder_torque is not None:
            torque[throws] = sources.cylinder_torque.at(w)
        if where is not None and sources.external is not None:
            torque[where] += sources.external
        for j in np.flatnonzero(k > 0):
            table[i, j] = line.harmonic_response(float(k[j] * w), torque[:, j])[0][probe]
    lead = _CycleTable.of(table, k, engine.cycle_revolutions, speeds).at(angle, omega_mean)
    start_speed = float(omega_mean[0])
    at_start = np.array(
        [
            np.interp(start_speed, speeds, table[:, j].real)
            + 1j * np.interp(start_speed, speeds, table[:, j].imag)
            for j in range(k.size)
        ]
    )
    fluctuation = 1j * k * start_speed * at_start
    fluctuation[0] = start_speed
    expected["crank speed"] = {
        "orders": k.tolist(),
        "amplitude": np.abs(fluctuation).tolist(),
        "phase_deg": np.degrees(np.angle(fluctuation)).tolist(),
        "unit": "rad/s",
        "speed_rpm": start_speed * 30 / math.pi,
        "element": wheel,
        "resonance_table": {
            "speed_rpm": (speeds * 30 / math.pi).tolist(),
            "angle_rad_by_order": {
                f"{o:g}": np.abs(table[:, j]).tolist() for j, o in enumerate(k) if o > 0 and o <= 12
            },
        },
    }
    return lead


def _axial_orders(sensor: Sensor, engine: Engine, sources: _Sources, speeds: FloatArray) -> ComplexArray:
    """Axial acceleration [m/s^2] (velocity [mm/s]) orders of the sensor's journal at each mean speed."""
    from monitor.torsion.axial_coupling import AxialTorsionalCrankshaft

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


def _variable_inertia_crank(
    scene: Scene,
    engine: Engine,
    params: CrankSpeedParams,
    angle: FloatArray,
    omega_mean: FloatArray,
    mean: Callable[[FloatArray], FloatArray],
    expected: dict[str, Any],
) -> _Crank:
    """The crank's angle ``tau + gamma(tau)`` against the flywheel's ``tau = Omega t`` (paper 002 eq. 6)."""
    import dataclasses

    from monitor.fourier import order_coefficients
    from monitor.torsion.time_response import harmonic_content
    from monitor.torsion.time_response import simulate as respond
    from monitor.torsion.variable_inertia import HarmonicExcitation, crank_of_engine, gas_excitation

    if scene.operating_point.trend.kind != "constant":
        raise SceneError("crank_speed (variable_inertia) is for a constant speed: remove the trend")
    if "inertia" not in scene.effects:
        raise SceneError(
            "crank_speed (variable_inertia) is driven by the reciprocating parts' inertia: "
            "add inertia to [effects]"
        )
    if engine.shaft_line is None:
        raise SceneError(f"crank_speed (variable_inertia) needs the [shaft_line] of engine {engine.id!r}")
    faults = [name for name in ("misfire", "weak_cylinder", "leaking_cylinder") if name in scene.effects]
    gas = named(scene, "gas")
    if faults or (isinstance(gas, GasParams) and gas.scale is not None):
        raise SceneError(
            "crank_speed (variable_inertia) is one equivalent crank driven by one healthy cylinder's gas "
            f"torque: remove {', '.join(faults) or 'gas.scale'} or use the rigid or shaft_line model"
        )
    w = float(omega_mean[0])
    excitation = (
        gas_excitation(engine, w, load=scene.operating_point.load, max_order=MAX_ORDER)
        if "gas" in scene.effects
        else HarmonicExcitation()
    )
    crank = dataclasses.replace(crank_of_engine(engine, w), zeta=params.damping, excitation=excitation)
    initial = (params.initial_twist_rad, 0.0)
    response = respond(crank, angle, initial=initial, form="linear", integrator="periodic")
    crank_angle = angle + response.gamma
    if not np.all(np.isfinite(crank_angle)) or np.any(1.0 + response.gamma_prime <= 0):
        raise SceneError(
            f"the variable-inertia crank (epsilon {crank.epsilon:.3g}, r {crank.r:.3g}) does not settle: "
            "it is in an unstable range; raise the damping or change the speed"
        )
    truth: dict[str, Any] = {"speed_rpm": w * 30 / math.pi, "epsilon": crank.epsilon, "r": crank.r}
    if params.damping == 0.0 and not excitation.orders:
        # a free vibration: its principal order and sidebands (the Floquet analysis of paper 002 Table 2)
        content = harmonic_content(crank, initial=initial)
        truth |= {
            "principal_order": float(content["principal_order"]),
            "orders": np.asarray(content["orders"]).tolist(),
            "amplitude": np.asarray(content["amplitudes"]).tolist(),
            "unit": "rad",
        }
        expected["crank angular vibration"] = truth
    else:
        # the steady speed's orders in the crank's own angle over the last whole cycle
        R = engine.cycle_revolutions
        cycle = 2 * math.pi * R
        cycles = math.floor(crank_angle[-1] / cycle)
        if cycles < 2:
            raise SceneError(
                "crank_speed (variable_inertia) needs two whole cycles or more: lengthen the scene"
            )
        on_cycle = (cycles - 1) * cycle + np.arange(_FINE * R) * (cycle / (_FINE * R))
        steady = w * (1.0 + np.interp(on_cycle, crank_angle, response.gamma_prime))
        oc = order_coefficients(steady, cycle_revolutions=R, max_order=MAX_ORDER)
        truth |= {
            "orders": oc.orders.tolist(),
            "amplitude": np.abs(oc.coefficients).tolist(),
            "phase_deg": np.degrees(np.angle(oc.coefficients)).tolist(),
            "unit": "rad/s",
        }
        expected["crank speed"] = truth
    return _Crank(crank_angle, angle / w, lambda t: mean(np.asarray(t, dtype=np.float64)))


def _check_locations(scene: Scene, engine: Engine) -> None:
    """Refuse main bearings the engine does not have, in sensor locations and in worn_bearing."""
    count = engine.bearing_count
    for sensor in scene.sensors:
        words = sensor.location.lower().replace("-", " ").split()
        if words[:2] == ["main", "bearing"] and (sensor.bearing is None or not 1 <= sensor.bearing <= count):
            raise SceneError(
                f"sensor {sensor.name!r}: location {sensor.location!r}: expected 'main bearing N' with N = "
                f"1..{count} (engine {engine.id!r})"
            )
    worn = named(scene, "worn_bearing")
    if isinstance(worn, WornBearingParams) and not 1 <= worn.bearing <= count:
        raise SceneError(
            f"effect 'worn_bearing': bearing {worn.bearing} does not exist (the engine has {count})"
        )


def _rigid_inertia(engine: Engine) -> float:
    """The engine side of the shaft line as one rigid body [kg m^2] (see ``engine_side_inertia``)."""
    from monitor.model.inertia import engine_side_inertia

    if engine.shaft_line is None:
        raise SceneError(
            f"effect 'crank_speed' (rigid) needs the inertias of engine {engine.id!r}: add its [shaft_line]"
        )
    return engine_side_inertia(engine)


def _synthesise(coefficients: ComplexArray, orders: FloatArray, angle: FloatArray) -> FloatArray:
    """``Re sum_k c_k exp(i k angle)`` for coefficients per sample (n, n_orders) or shared (n_orders,)."""
    phasor = np.exp(1j * np.multiply.outer(angle, orders))
    return np.asarray(np.real((phasor * coefficients).sum(axis=-1)))


@dataclass(frozen=True)
class _CycleTable:
    """``Re sum_k C_k(w) exp(i k theta)`` tabulated over a cycle (2^16 points per revolution) at a few
    mean speeds.

    Evaluated per sample by linear interpolation in angle (error below 1e-5 of the sum of the order
    magnitudes, for orders up to 36; tested against the direct sum) and in speed between the tabulated
    speeds: a cost per sample that does not grow with the number of orders.
    """

    values: FloatArray  # (n_speeds, points + 1), the first point repeated at the end
    speeds: FloatArray
    cycle: float

    @classmethod
    def of(
        cls, coefficients: ComplexArray, orders: FloatArray, revolutions: int, speeds: FloatArray
    ) -> _CycleTable:
        points = (1 << 16) * revolutions
        harmonics = np.rint(orders * revolutions).astype(np.int64)  # per cycle
        spectrum = np.zeros((speeds.size, points // 2 + 1), dtype=np.complex128)
        spectrum[:, harmonics] = coefficients * (points / 2)
        spectrum[:, 0] = (
            coefficients[:, harmonics == 0].real.sum(axis=1) * points if (harmonics == 0).any() else 0
        )
        table = np.fft.irfft(spectrum, n=points, axis=-1)
        return cls(np.concatenate([table, table[:, :1]], axis=1), speeds, 2 * math.pi * revolutions)

    def at(self, angle: FloatArray, speed: FloatArray | None = None) -> FloatArray:
        """The tabulated sum at crank angles ``angle`` [rad] and mean speeds ``speed`` [rad/s].

        ``speed`` is needed only when more than one speed is tabulated.
        """
        points = self.values.shape[1] - 1
        where = np.mod(angle, self.cycle) * (points / self.cycle)
        i = np.minimum(where.astype(np.int64), points - 1)
        frac = where - i
        if self.speeds.size == 1:
            row = self.values[0]
            return np.asarray(row[i] * (1 - frac) + row[i + 1] * frac)
        if speed is None:
            raise ValueError("a table over several mean speeds needs the speed of every sample")
        position = np.clip((speed - self.speeds[0]) / (self.speeds[-1] - self.speeds[0]), 0, 1) * (
            self.speeds.size - 1
        )
        j = np.minimum(position.astype(np.int64), self.speeds.size - 2)
        g = position - j
        low = self.values[j, i] * (1 - frac) + self.values[j, i + 1] * frac
        high = self.values[j + 1, i] * (1 - frac) + self.values[j + 1, i + 1] * frac
        return np.asarray(low * (1 - g) + high * g)


@dataclass(frozen=True)
class _Crank:
    """The crank's angle-time table: angles on a fine grid and the times they are reached."""

    angle: FloatArray
    time: FloatArray
    speed: Callable[[FloatArray], FloatArray]

    def angle_at(self, t: FloatArray) -> FloatArray:
        return np.interp(t, self.time, self.angle)

    def time_at(self, angle: FloatArray) -> FloatArray:
        return np.interp(angle, self.angle, self.time)


def _crank(
    scene: Scene, engine: Engine, sources: _Sources | None, evaluated: list[str], expected: dict[str, Any]
) -> _Crank:
    mean = _mean_speed(scene)
    span = scene.duration_s + 1.0  # a second beyond the end, so the last samples have angles
    coarse_t = np.linspace(0.0, span, max(2, int(span * 200)) + 1)
    coarse_w = mean(coarse_t)
    coarse_a = np.concatenate([[0.0], np.cumsum(0.5 * (coarse_w[1:] + coarse_w[:-1]) * np.diff(coarse_t))])
    revolutions = coarse_a[-1] / (2 * math.pi)
    count = 2 * math.ceil(revolutions * _FINE / 2) + 1  # odd, for Simpson
    angle = np.linspace(0.0, coarse_a[-1], count)
    omega_mean = np.interp(np.interp(angle, coarse_a, coarse_t), coarse_t, coarse_w)
    omega = omega_mean
    crank_speed = named(scene, "crank_speed")
    if isinstance(crank_speed, CrankSpeedParams) and crank_speed.model == "shaft_line":
        evaluated.append("crank_speed")
        assert sources is not None
        lead = _shaft_line_lead(scene, engine, sources, angle, omega_mean, expected)
        time = np.interp(angle - lead, coarse_a, coarse_t)
        return _Crank(angle, time, lambda t: mean(np.asarray(t, dtype=np.float64)))
    if isinstance(crank_speed, CrankSpeedParams) and crank_speed.model == "variable_inertia":
        evaluated.append("crank_speed")
        return _variable_inertia_crank(scene, engine, crank_speed, angle, omega_mean, mean, expected)
    if crank_speed is not None:
        evaluated.append("crank_speed")
        assert sources is not None and sources.torque is not None  # check_effects saw to a torque source
        inertia = _rigid_inertia(engine)
        k = sources.orders
        positive = k > 0
        # the integral of T - T_mean: sum over k > 0 of T_k exp(i k a) / (i k), with T_k = A_k + w^2 B_k
        over_k = np.where(positive, 1.0 / (1j * np.where(positive, k, 1.0)), 0.0)
        integral_a, integral_b = (
            _CycleTable.of((part * over_k)[None, :], k, engine.cycle_revolutions, np.zeros(1)).at(
                angle, angle
            )
            for part in (sources.torque.a, sources.torque.b)
        )
        energy = omega_mean**2 + (2.0 / inertia) * (integral_a + omega_mean**2 * integral_b)
        if np.any(energy <= 0):
            raise SceneError(
                "the crank would stop within a revolution at this speed (torque fluctuation larger "
                "than the rotating energy): raise the speed"
            )
        omega = np.sqrt(energy)
        # the truth: the speed's orders over one cycle at the mean speed at the start
        from monitor.fourier import order_coefficients

        R = engine.cycle_revolutions
        cycle: FloatArray = np.arange(1024 * R, dtype=np.float64) * (2 * math.pi / 1024)
        w0 = float(omega_mean[0])
        over_a = _synthesise(sources.torque.a[positive] / (1j * k[positive]), k[positive], cycle)
        over_b = _synthesise(sources.torque.b[positive] / (1j * k[positive]), k[positive], cycle)
        steady = np.sqrt(w0**2 + (2.0 / inertia) * (over_a + w0**2 * over_b))
        oc = order_coefficients(steady, cycle_revolutions=R, max_order=MAX_ORDER)
        expected["crank speed"] = {
            "orders": oc.orders.tolist(),
            "amplitude": np.abs(oc.coefficients).tolist(),
            "phase_deg": np.degrees(np.angle(oc.coefficients)).tolist(),
            "unit": "rad/s",
            "speed_rpm": w0 * 30 / math.pi,
        }
    slowness = 1.0 / omega
    h = angle[1] - angle[0]
    # Simpson over pairs of intervals, trapezoid halves for the odd points in between
    time = np.empty(angle.size)
    time[0] = 0.0
    pairs = h / 3 * (slowness[:-2:2] + 4 * slowness[1:-1:2] + slowness[2::2])
    time[2::2] = np.cumsum(pairs)
    mid = h / 12 * (5 * slowness[:-2:2] + 8 * slowness[1:-1:2] - slowness[2::2])  # first half of each pair
    time[1::2] = time[:-2:2] + mid
    return _Crank(angle, time, lambda t: mean(np.asarray(t, dtype=np.float64)))


# -------------------------------------------------------------------------------------- channels
def _bearing_response(
    sensor: Sensor, engine: Engine, sources: _Sources, params: BearingVibrationParams
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


def _pulses(position: FloatArray, present: npt.NDArray[np.bool_] | None = None) -> FloatArray:
    """Flat-bottomed pulses, 0.2 to 3.2 V: the mid level (1.7 V) is crossed rising at whole positions."""
    fraction = np.mod(position + 1.0 / 6.0, 1.0)
    pulse = np.clip(np.sin(np.pi * fraction) * 1.6 - 0.3, 0.0, 1.0)
    if present is not None:
        pulse = np.where(present, pulse, 0.0)
    return 0.2 + 3.0 * pulse


_VR_WIDTH = 0.4  # standard deviation of one tooth's flux bump [pitch]: neighbouring teeth overlap
_EDGE_MAX = 0.125  # largest half-width of a square pulse's edge [pitch]
_BLOCK = 1 << 20  # samples shaped at a time (bounded memory on a long recording)


def _square(
    v: FloatArray, present: Callable[[FloatArray], npt.NDArray[np.bool_]] | None = None
) -> FloatArray:
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
    from scipy.interpolate import CubicSpline

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


def _shaped_tooth_wheel(
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
        values = 0.2 + 4.8 * _square(v, lambda k: np.mod(k, teeth) < teeth - missing)
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
    from scipy.optimize import brentq

    cubic = None
    if np.any(errors):
        from scipy.interpolate import CubicSpline

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


def _channel(
    sensor: Sensor,
    index: int,
    scene: Scene,
    engine: Engine,
    crank: _Crank,
    sources: _Sources | None,
    seed: int,
    expected: dict[str, Any],
) -> Channel:
    R = engine.cycle_revolutions
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
    if sensor.representation == "events":
        last = crank.angle_at(np.array([scene.duration_s]))[0]
        if sensor.kind == "tooth":
            step = math.radians(pitch_deg)
            first = math.radians(sensor.first_tooth_angle_deg)
            k = np.arange(math.ceil(-first / step), math.floor((last - first) / step) + 1)
            k = k[np.mod(k, sensor.teeth) < sensor.teeth - sensor.missing_teeth]
            angles = (
                first
                + k * step
                + _tooth_errors(scene, sensor, seed, index, expected)[np.mod(k, sensor.teeth)]
            )
        elif sensor.kind == "encoder":  # each pulse's rising edge at its angle
            step = math.radians(pitch_deg)
            first = math.radians(sensor.first_pulse_angle_deg)
            angles = first + step * np.arange(math.ceil(-first / step), math.floor((last - first) / step) + 1)
        else:
            period = 2 * math.pi * (R if sensor.kind == "cam" else 1)
            offset = math.radians(sensor.cam_angle_deg if sensor.kind == "cam" else sensor.pulse_angle_deg)
            angles = offset + period * np.arange(
                math.ceil(-offset / period), math.floor((last - offset) / period) + 1
            )
            if sensor.kind == "keyphasor":
                dropped, extra = _keyphasor_faults(scene, sensor, angles, seed, index, expected)
                angles = np.sort(np.concatenate([np.delete(angles, dropped), extra]))
        angles = angles[(angles >= 0) & (angles <= last)]
        times = crank.time_at(angles)
        return Channel(sensor.name, sensor.kind, "s", times, None, location=sensor.location, fields=fields)
    fs = sensor.sample_rate_hz
    n = round(scene.duration_s * fs)
    t = np.arange(n) / fs
    angle = crank.angle_at(t)
    if sensor.kind == "tooth" and sensor.signal != "pulse":
        values = _shaped_tooth_wheel(
            sensor, angle, _tooth_errors(scene, sensor, seed, index, expected), expected
        )
    elif sensor.kind == "encoder":
        start = math.radians(sensor.first_pulse_angle_deg)
        values = 5.0 * _square((angle - start) / math.radians(pitch_deg))
    elif sensor.kind == "tooth":
        position = (angle - math.radians(sensor.first_tooth_angle_deg)) / math.radians(pitch_deg)
        tooth = np.floor(position + 1.0 / 6.0).astype(np.int64)
        errors = _tooth_errors(scene, sensor, seed, index, expected)
        position = position - errors[np.mod(tooth, sensor.teeth)] / math.radians(pitch_deg)
        values = _pulses(position, np.mod(tooth, sensor.teeth) < sensor.teeth - sensor.missing_teeth)
    elif sensor.kind in ("keyphasor", "cam"):
        # one pulse per period (20 deg of crank angle long), its mid level crossed rising at its angle
        periods = 18 * (R if sensor.kind == "cam" else 1)
        offset = math.radians(sensor.cam_angle_deg if sensor.kind == "cam" else sensor.pulse_angle_deg)
        position = (angle - offset) / math.radians(20.0)
        slot = np.floor(position + 1.0 / 6.0).astype(np.int64)
        present = np.mod(slot, periods) == 0
        if sensor.kind == "keyphasor":
            nominal = offset + 2 * math.pi * np.arange(math.ceil(angle[-1] / (2 * math.pi)) + 1)
            dropped, extra = _keyphasor_faults(scene, sensor, nominal, seed, index, expected)
            present &= ~np.isin(slot // periods, dropped)
        values = _pulses(position, present)
        if sensor.kind == "keyphasor":
            for angle_x in extra:  # a spurious pulse: the same shape at another angle
                near = np.abs(angle - angle_x) < math.radians(20.0)
                local = (angle[near] - angle_x) / math.radians(20.0)
                values[near] = np.maximum(values[near], _pulses(local, np.floor(local + 1.0 / 6.0) == 0))
    elif sensor.kind == "pressure":
        if sources is None or sources.pressure is None or sources.grid is None:
            raise SceneError(f"sensor {sensor.name!r} measures cylinder pressure: add the effect 'gas'")
        c = int(sensor.cylinder or 1)
        if not 1 <= c <= engine.cylinders:
            raise SceneError(f"sensor {sensor.name!r}: cylinder {c} does not exist")
        cycle = 2 * math.pi * R
        own = np.mod(angle - engine.firing_angles[c - 1], cycle)
        grid = np.append(sources.grid, cycle)
        trace = np.append(sources.pressure[c - 1], sources.pressure[c - 1][0])
        values = np.interp(own, grid, trace) / 1e5  # [bar]
    elif sensor.direction == "axial":  # axial acceleration [m/s^2] or velocity [mm/s] of a journal
        values = np.zeros(n)
        if named(scene, "axial_vibration") is not None and (
            sources is None or sources.cylinder_torque is None
        ):
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
            lo_w, hi_w = float(speed.min()), float(speed.max())
            nodes = np.array([lo_w]) if hi_w - lo_w <= 1e-9 * hi_w else np.linspace(lo_w, hi_w, 33)
            coefficients = _axial_orders(sensor, engine, sources, nodes)
            values = _CycleTable.of(coefficients, sources.orders, R, nodes).at(angle, speed)
            w_mean = float(np.mean(speed))
            at_mean = _axial_orders(sensor, engine, sources, np.array([w_mean]))[0]
            expected[sensor.name] = {
                "orders": sources.orders.tolist(),
                "amplitude": np.abs(at_mean).tolist(),
                "phase_deg": np.degrees(np.angle(at_mean)).tolist(),
                "unit": sensor.unit,
                "speed_rpm": w_mean * 30 / math.pi,
            }
    else:  # acceleration [m/s^2] or velocity [mm/s] at a main bearing
        values = np.zeros(n)
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

            lo_w, hi_w = float(speed.min()), float(speed.max())
            nodes = np.array([lo_w]) if hi_w - lo_w <= 1e-9 * hi_w else np.linspace(lo_w, hi_w, 65)
            table = _CycleTable.of(
                (a[None, :] + np.multiply.outer(nodes**2, b)) * measured(nodes), orders, R, nodes
            )
            values = table.at(angle, speed)
            w_mean = float(np.mean(speed))
            at_mean = (a + w_mean**2 * b) * measured(np.array(w_mean))
            expected[sensor.name] = {
                "orders": orders.tolist(),
                "amplitude": np.abs(at_mean).tolist(),
                "phase_deg": np.degrees(np.angle(at_mean)).tolist(),
                "unit": sensor.unit,
                "speed_rpm": w_mean * 30 / math.pi,
            }
        worn = named(scene, "worn_bearing")
        if isinstance(worn, WornBearingParams) and sources is not None and sources.bearing is not None:
            values = values + _knocks(worn, sensor, engine, sources, crank, t, expected)
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


def _tooth_errors(
    scene: Scene, sensor: Sensor, seed: int, index: int, expected: dict[str, Any]
) -> FloatArray:
    """Each tooth's angle error [rad] (zeros unless the scene names tooth_spacing_errors for it)."""
    params = named(scene, "tooth_spacing_errors")
    if not isinstance(params, ToothSpacingParams) or params.sensor != sensor.name:
        return np.zeros(sensor.teeth)
    errors = np.random.default_rng([seed, index, 1]).standard_normal(sensor.teeth)
    errors = math.radians(params.rms_deg) * (errors - errors.mean()) / errors.std()
    expected[f"{sensor.name} tooth errors"] = {"error_deg": np.degrees(errors).tolist()}
    return errors


def _keyphasor_faults(
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


def _knocks(
    params: WornBearingParams,
    sensor: Sensor,
    engine: Engine,
    sources: _Sources,
    crank: _Crank,
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


def simulate(
    scene: Scene, *, seed: int | None = None, progress: Callable[[float], None] | None = None
) -> Simulation:
    """Simulate a scene: only the effects it names are evaluated.

    Parameters
    ----------
    scene : Scene
    seed : int, optional
        Noise seed; default: the scene's. The same scene and seed give the same recording.
    progress : callable, optional
        Called with the fraction done [-] after each channel.

    Returns
    -------
    Simulation

    Raises
    ------
    SceneError
        When the scene cannot be simulated as written (the message says what to change).
    """
    engine = _engine(scene)
    seed = scene.seed if seed is None else seed
    _check_locations(scene, engine)
    evaluated: list[str] = []
    sources = _sources(scene, engine, evaluated)
    expected: dict[str, Any] = {}
    crank = _crank(scene, engine, sources, evaluated, expected)
    channels = []
    for i, sensor in enumerate(scene.sensors):
        channels.append(_channel(sensor, i, scene, engine, crank, sources, seed, expected))
        if progress is not None:
            progress((i + 1) / len(scene.sensors))
    for name in (
        "bearing_vibration",
        "axial_vibration",
        "worn_bearing",
        "noise",
        "keyphasor_faults",
        "tooth_spacing_errors",
        "clipping",
        "gain_error",
    ):
        if name in scene.effects:  # applied channel by channel above
            evaluated.append(name)
    truth = {
        "engine": engine.id,
        "duration_s": scene.duration_s,
        "seed": seed,
        "operating_point": scene.operating_point.model_dump(),
        "effects": scene.effects,
        "gas_model": sources.gas_model if sources else "none",
        "cylinder_gas_scale": sources.gas_scale if sources else [1.0] * engine.cylinders,
        "cylinder_charge_scale": sources.charge_scale if sources else [1.0] * engine.cylinders,
        "expected_orders": expected,
    }
    recording = Recording(
        engine_id=engine.id,
        start_time="2026-01-01T00:00:00Z",
        channels=tuple(channels),
        notes=f"simulated scene, seed {seed}",
        truth=json.dumps(truth, sort_keys=True),
    )
    return Simulation(recording, truth, tuple(evaluated))
